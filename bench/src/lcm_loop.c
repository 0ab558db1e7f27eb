/*
 * LCM C udpm (ttl=0) between 2 processes, stock settings (bench figure 3 peer): 64-byte raw payloads
 * on channel "BENCH" (78-byte datagrams), the same blast and ping-pong method and output line as
 * loop_bench.c. Run inside a private network namespace (bench/run.sh uses `unshare -rn` with
 * 224.0.0.0/4 routed to lo).
 *
 *   lcm_loop blast|rtt N split|same
 */
#define _GNU_SOURCE
#include <poll.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <lcm/lcm.h>

#define URL "udpm://239.255.76.67:7667?ttl=0"

static uint64_t now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}
static void pin(int cpu) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    (void)sched_setaffinity(0, sizeof set, &set);
}

static uint64_t received, t_first, t_last;
static int echo;
static lcm_t *lc;

static void on_msg(const lcm_recv_buf_t *rbuf, const char *channel, void *user) {
    (void)channel, (void)user;
    uint64_t t = now_ns();
    if (received++ == 0) t_first = t;
    t_last = t;
    if (echo) lcm_publish(lc, "ECHO", rbuf->data, rbuf->data_size);
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv) {
    if (argc < 4) return 2;
    int rtt = strcmp(argv[1], "rtt") == 0;
    long n = atol(argv[2]);
    int split = strcmp(argv[3], "split") == 0;
    int ready[2], result[2];
    if (pipe(ready) < 0 || pipe(result) < 0) return 2;
    pid_t child = fork();
    if (child == 0) {
        pin(split ? 1 : 0);
        alarm(120);
        echo = rtt;
        lc = lcm_create(URL);
        if (lc == NULL) return 2;
        lcm_subscribe(lc, "BENCH", on_msg, NULL);
        if (write(ready[1], "r", 1) != 1) return 2;
        while (received < (uint64_t)n && lcm_handle_timeout(lc, 500) > 0) {
        }
        char line[96];
        int len = snprintf(line, sizeof line, "%llu %llu %llu\n", (unsigned long long)received,
                           (unsigned long long)t_first, (unsigned long long)t_last);
        if (write(result[1], line, (size_t)len) != len) return 2;
        lcm_destroy(lc);
        _exit(0);
    }
    pin(0);
    lc = lcm_create(URL);
    if (lc == NULL) return 2;
    lcm_subscribe(lc, "ECHO", on_msg, NULL);
    char c;
    if (read(ready[0], &c, 1) != 1) return 2;
    usleep(300000);
    uint8_t msg[64] = {0};
    uint64_t *rtts = rtt ? calloc((size_t)n, sizeof *rtts) : NULL;
    uint64_t t0 = now_ns();
    for (long i = 0; i < n; i++) {
        memcpy(msg, &i, sizeof i);
        uint64_t ts = now_ns();
        uint64_t before = received;
        lcm_publish(lc, "BENCH", msg, sizeof msg);
        if (rtt) {
            while (received == before)
                if (lcm_handle_timeout(lc, 1000) <= 0) {
                    fprintf(stderr, "lcm_loop: echo lost at %ld\n", i);
                    return 3;
                }
            rtts[i] = now_ns() - ts;
        }
    }
    uint64_t t1 = now_ns();
    char line[96] = {0};
    ssize_t got = read(result[0], line, sizeof line - 1);
    waitpid(child, NULL, 0);
    unsigned long long rx = 0, f = 0, l = 0;
    if (got <= 0 || sscanf(line, "%llu %llu %llu", &rx, &f, &l) != 3) return 3;
    const char *where = split ? "rx/echo cpu1, tx cpu0" : "both cpu0";
    if (rtt) {
        size_t warm = (size_t)n / 20, k = (size_t)n - warm;
        qsort(rtts + warm, k, sizeof *rtts, cmp_u64);
        printf("mode=rtt transport=lcm-udpm placement=\"%s\" n=%ld p50_us=%.2f p99_us=%.2f\n", where, n,
               rtts[warm + k / 2] / 1e3, rtts[warm + k * 99 / 100] / 1e3);
    } else {
        printf("mode=blast transport=lcm-udpm placement=\"%s\" batching=0 n=%ld received=%llu delivered_per_s=%.0f "
               "lost_pct=%.3f offered_per_s=%.0f refused_retried=0\n",
               where, n, rx, rx > 1 && l > f ? (double)(rx - 1) / ((l - f) / 1e9) : 0.0,
               100.0 * (1.0 - (double)rx / (double)n), n / ((t1 - t0) / 1e9));
    }
    free(rtts);
    lcm_destroy(lc);
    return 0;
}

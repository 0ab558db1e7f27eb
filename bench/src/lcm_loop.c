/*
 * LCM C udpm (ttl=0) between 2 processes, stock settings (bench figure 3 peer): 64-byte raw payloads
 * on channel "BENCH" (78-byte datagrams), the same blast and ping-pong method and output line as
 * loop_bench.c. Run inside a private network namespace (bench/run.sh uses `unshare -rn` with
 * 224.0.0.0/4 routed to lo).
 *
 *   lcm_loop blast|rtt N split|same
 *
 * Deadlines as in loop_bench.c (issue #28): the sample ends within LOOP_BENCH_DEADLINE_S seconds (default
 * 120); the receiver stops when it has N messages or when the sender is done and the socket has been quiet
 * for 300 ms, never while the sender is still sending; a sample that cannot finish prints one result line
 * with status=failed and a reason, and exits 3.
 */
#define _GNU_SOURCE
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <sys/prctl.h>
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

static const char *s_mode = "?", *s_where = "?";
static long s_n;
static pid_t s_child; /* 0 in the child */
static uint64_t s_deadline;

static void fail(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));
static void fail(const char *fmt, ...) {
    char why[200];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, sizeof why, fmt, ap);
    va_end(ap);
    fprintf(stderr, "lcm_loop: %s %ld %s: %s\n", s_mode, s_n, s_where, why);
    if (s_child == 0) _exit(3);
    if (s_child > 0) {
        kill(s_child, SIGKILL);
        waitpid(s_child, NULL, 0);
    }
    printf("mode=%s transport=lcm-udpm placement=\"%s\" n=%ld status=failed reason=\"%s\"\n", s_mode, s_where, s_n, why);
    exit(3);
}

/* Sender side: the deadline, and a receiver that exited without its result. */
static void check_alive(long at, int result_fd) {
    int status;
    if (now_ns() > s_deadline) fail("deadline passed at message %ld (LOOP_BENCH_DEADLINE_S)", at);
    if (s_child > 0 && waitpid(s_child, &status, WNOHANG) == s_child) {
        s_child = -1;
        struct pollfd rp = {.fd = result_fd, .events = POLLIN};
        if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0 && poll(&rp, 1, 0) == 1))
            fail("the receiver/echo child exited early at message %ld", at);
    }
    if (now_ns() > s_deadline) fail("deadline passed at message %ld (LOOP_BENCH_DEADLINE_S)", at);
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
    s_mode = rtt ? "rtt" : "blast";
    s_where = split ? "rx/echo cpu1, tx cpu0" : "both cpu0";
    s_n = n;
    const char *dl = getenv("LOOP_BENCH_DEADLINE_S");
    s_deadline = now_ns() + (uint64_t)((dl && atof(dl) > 0 ? atof(dl) : 120.0) * 1e9);
    int ready[2], result[2], done_pipe[2];
    if (pipe(ready) < 0 || pipe(result) < 0 || pipe(done_pipe) < 0) return 2;
    fflush(stdout);
    pid_t child = fork();
    if (child < 0) return 2;
    if (child == 0) {
        s_deadline += 2000000000u; /* 2 s after the sender's: the sender reports first */
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        close(done_pipe[1]);
        pin(split ? 1 : 0);
        echo = rtt;
        lc = lcm_create(URL);
        if (lc == NULL) fail("lcm_create(%s) failed in the receiver", URL);
        lcm_subscribe(lc, "BENCH", on_msg, NULL);
        if (write(ready[1], "r", 1) != 1) return 2;
        int done = 0;
        while (received < (uint64_t)n) {
            int was_done = done; /* quiet for a whole 300 ms after "done": nothing left in flight */
            struct pollfd p[2] = {{.fd = lcm_get_fileno(lc), .events = POLLIN},
                                  {.fd = done ? -1 : done_pipe[0], .events = POLLIN}};
            int k = poll(p, 2, done ? 300 : 200);
            if (k > 0 && (p[1].revents & (POLLIN | POLLHUP))) done = 1;
            int input = k > 0 && (p[0].revents & POLLIN);
            if (input && lcm_handle(lc) != 0) fail("lcm_handle failed in the receiver");
            if (was_done && !input) break;
            if (now_ns() > s_deadline) fail("deadline passed in the receiver");
        }
        char line[96];
        int len = snprintf(line, sizeof line, "%llu %llu %llu\n", (unsigned long long)received,
                           (unsigned long long)t_first, (unsigned long long)t_last);
        if (write(result[1], line, (size_t)len) != len) return 2;
        lcm_destroy(lc);
        _exit(0);
    }
    s_child = child;
    close(ready[1]);
    close(result[1]);
    close(done_pipe[0]);
    pin(0);
    lc = lcm_create(URL);
    if (lc == NULL) fail("lcm_create(%s) failed", URL);
    lcm_subscribe(lc, "ECHO", on_msg, NULL);
    {
        struct pollfd rp = {.fd = ready[0], .events = POLLIN};
        while (poll(&rp, 1, 200) == 0) check_alive(0, result[0]);
        char c;
        if (read(ready[0], &c, 1) != 1) fail("the receiver exited before it was ready");
    }
    usleep(300000);
    uint8_t msg[64] = {0};
    uint64_t *rtts = rtt ? calloc((size_t)n, sizeof *rtts) : NULL;
    uint64_t t0 = now_ns();
    for (long i = 0; i < n; i++) {
        memcpy(msg, &i, sizeof i);
        uint64_t ts = now_ns();
        uint64_t before = received;
        if (lcm_publish(lc, "BENCH", msg, sizeof msg) != 0) check_alive(i, result[0]); /* counted as lost */
        if (rtt) {
            while (received == before) {
                if (lcm_handle_timeout(lc, 200) < 0) fail("lcm_handle failed at message %ld", i);
                check_alive(i, result[0]);
                if (received == before && now_ns() - ts > 5000000000u) fail("echo of message %ld not back within 5 s", i);
            }
            rtts[i] = now_ns() - ts;
        }
        if ((i & 4095) == 0) check_alive(i, result[0]);
    }
    uint64_t t1 = now_ns();
    close(done_pipe[1]); /* done: the receiver drains what is in flight and reports */
    char line[96] = {0};
    {
        struct pollfd rp = {.fd = result[0], .events = POLLIN};
        while (poll(&rp, 1, 200) == 0)
            if (now_ns() > s_deadline) fail("no result from the receiver before the deadline");
    }
    ssize_t got = read(result[0], line, sizeof line - 1);
    if (s_child > 0) waitpid(child, NULL, 0);
    s_child = -1;
    unsigned long long rx = 0, f = 0, l = 0;
    if (got <= 0 || sscanf(line, "%llu %llu %llu", &rx, &f, &l) != 3) fail("no result from the receiver");
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

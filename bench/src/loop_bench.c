/*
 * Loopback between 2 processes (bench figure 3): one uavbus node per process, 64-byte payloads
 * (benchBlob64, a 128-byte frame), over the runtime's own UDP or TCP driver; plus the raw C UDP floor.
 *
 *   loop_bench blast udp|tcp|raw-udp N PLACEMENT [nobatch]   -> one line of "key=value" results
 *   loop_bench rtt   udp|tcp|raw-udp N PLACEMENT
 *
 * PLACEMENT is "split" (receiver/echo pinned to CPU 1, sender/pinger to CPU 0) or "same" (both on
 * CPU 0), set with sched_setaffinity() in each process. The receiver is a fork()ed child; sockets
 * are opened before the fork on 127.0.0.1 port 0, so there are no fixed ports.
 *
 * Blast: the sender originates N DATA frames as fast as the node takes them. A frame the transport
 * refuses (UB_ERR_AGAIN: push back) is retried after a poll for POLLOUT, never dropped; "refused" counts
 * those retries. The receiver counts deliveries (the node's deliver hook); delivered/s is
 * (received-1)/(t_last-t_first) at the receiver, lost % = 1 - received/N. Both ends use SO_RCVBUF
 * 4 MiB (rmem_max here) and, unless "nobatch", the drivers' batching (sendmmsg / multi-frame writes).
 * RTT: ping-pong of single frames, poll()-blocking on both ends, p50/p99 over N round trips.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "benchcat.h"
#include "ub/ub_node.h"
#include "ub/ub_tcp.h"
#include "ub/ub_udp.h"

benchBlob64_t benchBlob64, benchBlob64Echo;
benchAttitude_t benchAttitude;
benchGpsRawInt_t benchGpsRawInt;
benchHighresImu_t benchHighresImu;

static uint64_t now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}
static uint64_t now_ms(void) { return now_ns() / 1000000u; }

static void pin(int cpu) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    if (sched_setaffinity(0, sizeof set, &set) != 0) perror("loop_bench: sched_setaffinity");
}

static void die(const char *what, int rc) {
    fprintf(stderr, "loop_bench: %s failed: %s (%d)\n", what, ub_strerror(rc), rc);
    exit(2);
}
#define CHECK(call)                      \
    do {                                 \
        int rc_ = (call);                \
        if (rc_ < 0) die(#call, rc_);    \
    } while (0)

static void big_buffers(int fd) {
    int size = 4 << 20;
    (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &size, sizeof size);
    (void)setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &size, sizeof size);
}

/* ---- one node per process: entity "tx" or "rx", one link "l0" to the other ---- */
typedef struct end {
    ub_node_t node;
    int self, other, link;
    int is_udp;
    ub_udp_t udp;
    ub_tcp_t tcp;
    uint64_t received, t_first, t_last;
    int echo;             /* rx side of RTT: send every delivery back */
    uint64_t last_echo_seq;
} end_t;

static void on_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now) {
    (void)entity;
    (void)h;
    end_t *e = user;
    uint64_t t = now_ns();
    if (e->received++ == 0) e->t_first = t;
    e->t_last = t;
    if (instance == benchcat_INST_benchBlob64Echo) e->last_echo_seq = benchBlob64Echo.seq;
    if (e->echo && instance == benchcat_INST_benchBlob64) {
        benchBlob64Echo = benchBlob64;
        int rc = ub_node_send_data(&e->node, e->self, benchcat_INST_benchBlob64Echo,
                                   ub_node_entity_id(&e->node, e->other), now);
        if (rc != 1) fprintf(stderr, "loop_bench: echo refused (%d)\n", rc);
    }
}

static void end_init(end_t *e, const char *self, const char *other) {
    CHECK(ub_node_init(&e->node, &benchcat_catalogue, NULL));
    e->self = ub_node_add_entity_name(&e->node, self, true);
    e->other = ub_node_add_entity_name(&e->node, other, false);
    CHECK(e->self);
    CHECK(e->other);
    e->link = ub_node_add_link(&e->node, e->self, 0, "l0");
    CHECK(e->link);
    CHECK(ub_node_set_mask(&e->node, e->self, e->other, 0x01));
    CHECK(ub_node_bind(&e->node, benchcat_INST_benchBlob64, &benchBlob64));
    CHECK(ub_node_bind(&e->node, benchcat_INST_benchBlob64Echo, &benchBlob64Echo));
    ub_node_set_deliver_hook(&e->node, on_deliver, e);
}

static int end_fd(end_t *e) { return e->is_udp ? ub_udp_fileno(&e->udp) : ub_tcp_fileno(&e->tcp); }
static int end_service(end_t *e) {
    return e->is_udp ? ub_udp_service(&e->udp, &e->node, now_ms()) : ub_tcp_service(&e->tcp, &e->node, now_ms());
}
static size_t end_pending(end_t *e) { return e->is_udp ? ub_udp_tx_pending(&e->udp) : ub_tcp_tx_pending(&e->tcp); }
static void end_flush(end_t *e) {
    int rc = e->is_udp ? ub_udp_flush(&e->udp) : ub_tcp_flush(&e->tcp, now_ms());
    if (rc < 0) die("flush", rc);
}
/* Waits up to `ms` for input (and for output room while something is queued), then services. */
static int end_wait(end_t *e, int ms) {
    struct pollfd p = {.fd = end_fd(e), .events = POLLIN | (end_pending(e) ? POLLOUT : 0)};
    int n = poll(&p, 1, ms);
    int rc = end_service(e);
    if (rc < 0) die("service", rc);
    return n;
}

static end_t tx_end, rx_end;

/* ---- raw C UDP floor: sendto/recv of 64 bytes, one datagram per message ---- */
static int raw_socket(uint16_t *port) {
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(0x7f000001)};
    socklen_t len = sizeof a;
    if (fd < 0 || bind(fd, (struct sockaddr *)&a, sizeof a) < 0 || getsockname(fd, (struct sockaddr *)&a, &len) < 0) {
        perror("loop_bench: raw socket");
        exit(2);
    }
    *port = ntohs(a.sin_port);
    big_buffers(fd);
    return fd;
}
static void raw_connect(int fd, uint16_t port) {
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons(port), .sin_addr.s_addr = htonl(0x7f000001)};
    if (connect(fd, (struct sockaddr *)&a, sizeof a) < 0) {
        perror("loop_bench: connect");
        exit(2);
    }
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv) {
    if (argc < 5) {
        fprintf(stderr, "usage: loop_bench blast|rtt udp|tcp|raw-udp N split|same [nobatch]\n");
        return 2;
    }
    const char *mode = argv[1], *transport = argv[2];
    long n_msgs = atol(argv[3]);
    int split = strcmp(argv[4], "split") == 0;
    int batching = !(argc > 5 && strcmp(argv[5], "nobatch") == 0);
    int rtt = strcmp(mode, "rtt") == 0;
    int raw = strcmp(transport, "raw-udp") == 0;
    int is_udp = strcmp(transport, "udp") == 0;
    if (n_msgs <= 0 || (!raw && !is_udp && strcmp(transport, "tcp") != 0)) {
        fprintf(stderr, "loop_bench: bad arguments\n");
        return 2;
    }
    int result_pipe[2], ready_pipe[2];
    if (pipe(result_pipe) < 0 || pipe(ready_pipe) < 0) return 2;

    /* Sockets before the fork, so both ports are known to both sides. */
    int raw_rx = -1, raw_tx = -1;
    uint16_t rx_port = 0, tx_port = 0;
    if (raw) {
        raw_rx = raw_socket(&rx_port);
        raw_tx = raw_socket(&tx_port);
        raw_connect(raw_tx, rx_port);
        raw_connect(raw_rx, tx_port);
    } else if (is_udp) {
        CHECK(ub_udp_open(&rx_end.udp, "127.0.0.1", 0, "127.0.0.1", 9));
        CHECK(ub_udp_open(&tx_end.udp, "127.0.0.1", 0, "127.0.0.1", 9));
        CHECK(ub_udp_local_port(&rx_end.udp, &rx_port));
        CHECK(ub_udp_local_port(&tx_end.udp, &tx_port));
        CHECK(ub_udp_set_peer(&rx_end.udp, "127.0.0.1", tx_port));
        CHECK(ub_udp_set_peer(&tx_end.udp, "127.0.0.1", rx_port));
        big_buffers(ub_udp_fileno(&rx_end.udp));
        big_buffers(ub_udp_fileno(&tx_end.udp));
    } else {
        CHECK(ub_tcp_server_open(&rx_end.tcp, "127.0.0.1", 0, NULL));
        CHECK(ub_tcp_local_port(&rx_end.tcp, &rx_port));
    }

    pid_t child = fork();
    if (child < 0) return 2;
    if (child == 0) { /* receiver (blast) or echo (rtt) */
        pin(split ? 1 : 0);
        alarm(120);
        uint64_t received = 0, t_first = 0, t_last = 0;
        if (raw) {
            close(raw_tx);
            uint8_t buf[2048];
            if (write(ready_pipe[1], "r", 1) != 1) return 2;
            struct pollfd p = {.fd = raw_rx, .events = POLLIN};
            while (received < (uint64_t)n_msgs && poll(&p, 1, 500) > 0) {
                for (;;) {
                    ssize_t k = recv(raw_rx, buf, sizeof buf, MSG_DONTWAIT);
                    if (k < 0) break;
                    uint64_t t = now_ns();
                    if (received++ == 0) t_first = t;
                    t_last = t;
                    if (rtt && send(raw_rx, buf, (size_t)k, 0) < 0) perror("loop_bench: echo");
                }
            }
        } else {
            end_t *e = &rx_end;
            e->is_udp = is_udp;
            e->echo = rtt;
            end_init(e, "rx", "tx");
            if (is_udp) {
                ub_udp_close(&tx_end.udp);
                CHECK(ub_udp_attach(&e->udp, &e->node, e->link));
                if (rtt == 0 && batching) CHECK(ub_udp_set_batching(&e->udp, 1));
            } else {
                CHECK(ub_tcp_attach(&e->tcp, &e->node, e->link));
            }
            if (write(ready_pipe[1], "r", 1) != 1) return 2;
            /* TCP: accept first (the listening socket is what poll() watches until then). */
            if (!is_udp) {
                uint64_t t0 = now_ms();
                while (ub_tcp_state(&e->tcp) != UB_TCP_UP && now_ms() - t0 < 5000) {
                    struct pollfd lp = {.fd = ub_tcp_listen_fileno(&e->tcp), .events = POLLIN};
                    (void)poll(&lp, 1, 100);
                    CHECK(ub_tcp_service(&e->tcp, &e->node, now_ms()));
                }
                big_buffers(ub_tcp_fileno(&e->tcp));
            }
            while (e->received < (uint64_t)n_msgs && end_wait(e, 500) > 0) {
            }
            received = e->received;
            t_first = e->t_first;
            t_last = e->t_last;
        }
        char line[128];
        int len = snprintf(line, sizeof line, "%llu %llu %llu\n", (unsigned long long)received,
                           (unsigned long long)t_first, (unsigned long long)t_last);
        if (write(result_pipe[1], line, (size_t)len) != len) return 2;
        _exit(0);
    }

    /* sender (blast) or pinger (rtt) */
    pin(0);
    char c;
    if (read(ready_pipe[0], &c, 1) != 1) return 2;
    usleep(100000);
    uint64_t refused = 0, t0 = 0, t1 = 0;
    uint64_t *rtts = rtt ? calloc((size_t)n_msgs, sizeof *rtts) : NULL;
    if (raw) {
        close(raw_rx);
        uint8_t msg[64] = {0}, back[2048];
        struct pollfd p = {.fd = raw_tx, .events = POLLIN};
        t0 = now_ns();
        for (long i = 0; i < n_msgs; i++) {
            memcpy(msg, &i, sizeof i);
            uint64_t ts = now_ns();
            while (send(raw_tx, msg, sizeof msg, 0) < 0) {
                if (errno != EAGAIN && errno != ENOBUFS) {
                    perror("loop_bench: send");
                    return 2;
                }
                refused++;
            }
            if (rtt) {
                if (poll(&p, 1, 1000) <= 0 || recv(raw_tx, back, sizeof back, 0) < 0) {
                    fprintf(stderr, "loop_bench: raw echo lost at %ld\n", i);
                    return 3;
                }
                rtts[i] = now_ns() - ts;
            }
        }
        t1 = now_ns();
    } else {
        end_t *e = &tx_end;
        e->is_udp = is_udp;
        end_init(e, "tx", "rx");
        if (is_udp) {
            ub_udp_close(&rx_end.udp);
            CHECK(ub_udp_attach(&e->udp, &e->node, e->link));
            if (!rtt && batching) CHECK(ub_udp_set_batching(&e->udp, 1));
        } else {
            ub_tcp_close(&rx_end.tcp);
            CHECK(ub_tcp_client_init(&e->tcp, "127.0.0.1", rx_port, NULL));
            CHECK(ub_tcp_attach(&e->tcp, &e->node, e->link));
            if (!rtt && batching) CHECK(ub_tcp_set_batching(&e->tcp, 1));
            uint64_t w = now_ms();
            while (ub_tcp_state(&e->tcp) != UB_TCP_UP && now_ms() - w < 5000) {
                CHECK(ub_tcp_service(&e->tcp, &e->node, now_ms()));
                usleep(1000);
            }
            if (ub_tcp_state(&e->tcp) != UB_TCP_UP) die("tcp connect", UB_ERR_CLOSED);
            big_buffers(ub_tcp_fileno(&e->tcp));
        }
        const uint8_t *dest = ub_node_entity_id(&e->node, e->other);
        t0 = now_ns();
        for (long i = 0; i < n_msgs; i++) {
            benchBlob64.seq = (uint64_t)i;
            uint64_t ts = now_ns();
            benchBlob64.t_ns = ts;
            for (;;) {
                int rc = ub_node_send_data(&e->node, e->self, benchcat_INST_benchBlob64, dest, ts / 1000000u);
                if (rc == 1) break;
                if (rc < 0) die("ub_node_send_data", rc);
                refused++; /* push back: wait for room, then send the same message again */
                struct pollfd p = {.fd = end_fd(e), .events = POLLOUT};
                (void)poll(&p, 1, 10);
                end_flush(e);
            }
            if (rtt) {
                while (e->last_echo_seq != (uint64_t)i || e->received == 0) {
                    if (end_wait(e, 1000) <= 0) {
                        fprintf(stderr, "loop_bench: echo lost at %ld\n", i);
                        return 3;
                    }
                }
                rtts[i] = now_ns() - ts;
            }
        }
        while (end_pending(e)) {
            struct pollfd p = {.fd = end_fd(e), .events = POLLOUT};
            (void)poll(&p, 1, 10);
            end_flush(e);
        }
        t1 = now_ns();
    }
    char line[128] = {0};
    ssize_t got = read(result_pipe[0], line, sizeof line - 1);
    int status = 0;
    waitpid(child, &status, 0);
    unsigned long long received = 0, t_first = 0, t_last = 0;
    if (got <= 0 || sscanf(line, "%llu %llu %llu", &received, &t_first, &t_last) != 3) {
        fprintf(stderr, "loop_bench: no result from the receiver\n");
        return 3;
    }
    const char *where = split ? "rx/echo cpu1, tx cpu0" : "both cpu0";
    if (rtt) {
        qsort(rtts, (size_t)n_msgs, sizeof *rtts, cmp_u64);
        size_t warm = (size_t)n_msgs / 20;
        size_t k = (size_t)n_msgs - warm;
        uint64_t *r = rtts + warm;
        qsort(r, k, sizeof *r, cmp_u64);
        printf("mode=rtt transport=%s placement=\"%s\" n=%ld p50_us=%.2f p99_us=%.2f\n", transport, where, n_msgs,
               r[k / 2] / 1e3, r[(k * 99) / 100] / 1e3);
    } else {
        double rate = received > 1 && t_last > t_first ? (double)(received - 1) / ((t_last - t_first) / 1e9) : 0;
        printf("mode=blast transport=%s placement=\"%s\" batching=%d n=%ld received=%llu delivered_per_s=%.0f "
               "lost_pct=%.3f offered_per_s=%.0f refused_retried=%llu\n",
               transport, where, raw ? 0 : batching, n_msgs, received, rate,
               100.0 * (1.0 - (double)received / (double)n_msgs), n_msgs / ((t1 - t0) / 1e9),
               (unsigned long long)refused);
    }
    free(rtts);
    return 0;
}

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
 *
 * Surviving a busy machine (issue #28): every wait has a deadline. The whole sample must finish within
 * LOOP_BENCH_DEADLINE_S seconds (default 120); the receiver never gives up on its own while the sender
 * is still sending (it stops when it has N messages, or when the sender says it is done and the socket
 * has then been quiet for a moment), and the sender checks on every wait that the receiver is alive.
 * A sample that cannot finish prints ONE result line with status=failed and a reason (the receiver
 * exited early, the deadline passed, an echo never came) and exits 3; it never hangs. A transient send
 * error (ECONNREFUSED from an ICMP error queued on a connected UDP socket, ENOBUFS) is retried and
 * counted (send_errors=); it is a failure only once the receiver is gone or the deadline has passed.
 * Faults for the harness test (tests/bench/): LOOP_BENCH_FAULT=echo-exit:K (the receiver/echo child
 * exits after K messages without a result) or send-fail-once (the first send reports ECONNREFUSED).
 *
 * Instruction counts (make bench's before-and-after, figure 3): run under valgrind --tool=callgrind, each
 * process counts only its measured loop (CALLGRIND_ZERO_STATS before it, CALLGRIND_DUMP_STATS_AT after it,
 * named "loop/MODE-TRANSPORT/tx" and ".../rx"; no-ops outside valgrind): an RTT sample's two dumps divided
 * by N are the user-space instructions of one round trip through both nodes, whatever the machine's load.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include <valgrind/callgrind.h>

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

/* The sample being measured, for the one result line a failure still prints. */
static struct sample {
    const char *mode, *transport, *where;
    long n;
    pid_t child;           /* receiver/echo; 0 in the child itself, -1 once reaped */
    int child_status;      /* its wait status once reaped */
    int result_fd;         /* the pipe its result line comes on */
    uint64_t deadline_ns;  /* absolute CLOCK_MONOTONIC */
    long fault_echo_exit;  /* -1: no fault */
    int fault_send_fail;   /* sends still to fail (fault injection) */
} smp = {.fault_echo_exit = -1};

/* Reports the sample as failed (stdout: the result line bench/tables.py reads; stderr: the reason for a
 * person), ends the child and exits 3. In the child: just the reason and exit 3 (the parent reports). */
static void fail(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));
static void fail(const char *fmt, ...) {
    char why[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, sizeof why, fmt, ap);
    va_end(ap);
    fprintf(stderr, "loop_bench: %s %s %ld %s: %s\n", smp.mode, smp.transport, smp.n, smp.where, why);
    if (smp.child == 0) _exit(3);
    if (smp.child > 0) {
        kill(smp.child, SIGKILL);
        waitpid(smp.child, NULL, 0);
    }
    for (char *c = why; *c; c++)
        if (*c == '"') *c = '\'';
    printf("mode=%s transport=%s placement=\"%s\" n=%ld status=failed reason=\"%s\"\n", smp.mode, smp.transport,
           smp.where, smp.n, why);
    fflush(stdout);
    exit(3);
}

static void die(const char *what, int rc) { fail("%s failed: %s (%d)", what, ub_strerror(rc), rc); }

/* Sender side, on every wait: the deadline, and whether the receiver/echo child is still there. */
static void check_alive(long at) {
    int status = 0;
    if (now_ns() > smp.deadline_ns) fail("deadline passed at message %ld (LOOP_BENCH_DEADLINE_S)", at);
    if (smp.child > 0 && waitpid(smp.child, &status, WNOHANG) == smp.child) {
        smp.child = -1; /* reaped: nothing left to kill */
        smp.child_status = status;
        /* A child that wrote its result finished its part (all N in): what is left in flight is still read. */
        struct pollfd rp = {.fd = smp.result_fd, .events = POLLIN};
        if (WIFEXITED(status) && WEXITSTATUS(status) == 0 && poll(&rp, 1, 0) == 1 && (rp.revents & POLLIN)) return;
        fail("the %s child exited early (%s %d) at message %ld", strcmp(smp.mode, "rtt") == 0 ? "echo" : "receiver",
             WIFEXITED(status) ? "exit" : "signal", WIFEXITED(status) ? WEXITSTATUS(status) : WTERMSIG(status), at);
    }
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

/* The callgrind dump of one side's measured loop (see the banner). */
static void count_dump(const char *side) {
    char name[64];
    snprintf(name, sizeof name, "loop/%s-%s/%s", smp.mode, smp.transport, side);
    CALLGRIND_DUMP_STATS_AT(name);
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Receiver side: poll the socket and the sender's "done" pipe. Returns when N messages are in, or once
 * the sender is done and the socket has been quiet for 300 ms; the deadline ends the child (exit 3). */
static int child_wait(int sock, int done_fd, int *done, int ms) {
    struct pollfd p[2] = {{.fd = sock, .events = POLLIN}, {.fd = *done ? -1 : done_fd, .events = POLLIN}};
    int n = poll(p, 2, ms);
    if (n > 0 && (p[1].revents & (POLLIN | POLLHUP))) *done = 1;
    if (now_ns() > smp.deadline_ns) fail("deadline passed in the receiver");
    return n > 0 && (p[0].revents & (POLLIN | POLLHUP | POLLERR));
}

/* Fault injection for the harness test: the child stops answering (exits without a result). */
static void child_fault(uint64_t received) {
    if (smp.fault_echo_exit >= 0 && received >= (uint64_t)smp.fault_echo_exit) _exit(0);
}

/* Sender: a transient send error is retried (counted); after 1000 in a row, or with the receiver gone, the
 * sample fails. */
static void send_error(uint64_t *send_errors, int err, long at, unsigned *in_row) {
    (*send_errors)++;
    if (err != ECONNREFUSED && err != ENOBUFS && err != EAGAIN) fail("send: %s at message %ld", strerror(err), at);
    if (++*in_row > 1000) fail("send: %s, 1000 times in a row at message %ld", strerror(err), at);
    check_alive(at);
    usleep(1000);
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
    const char *where = split ? "rx/echo cpu1, tx cpu0" : "both cpu0";
    smp.mode = mode;
    smp.transport = transport;
    smp.where = where;
    smp.n = n_msgs;
    const char *dl = getenv("LOOP_BENCH_DEADLINE_S");
    double deadline_s = dl && atof(dl) > 0 ? atof(dl) : 120.0;
    smp.deadline_ns = now_ns() + (uint64_t)(deadline_s * 1e9);
    const char *fault = getenv("LOOP_BENCH_FAULT");
    if (fault && strncmp(fault, "echo-exit:", 10) == 0) smp.fault_echo_exit = atol(fault + 10);
    else if (fault && strcmp(fault, "send-fail-once") == 0) smp.fault_send_fail = 1;
    else if (fault && *fault) {
        fprintf(stderr, "loop_bench: LOOP_BENCH_FAULT=%s: use echo-exit:K or send-fail-once\n", fault);
        return 2;
    }
    int result_pipe[2], ready_pipe[2], done_pipe[2];
    if (pipe(result_pipe) < 0 || pipe(ready_pipe) < 0 || pipe(done_pipe) < 0) return 2;

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

    fflush(stdout);
    pid_t child = fork();
    if (child < 0) return 2;
    if (child == 0) { /* receiver (blast) or echo (rtt) */
        smp.deadline_ns += 2000000000u; /* 2 s after the sender's: the sender, which knows more, reports first */
        /* The sender killed by a deadline (bench/run.sh's timeout) takes its receiver with it. */
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        close(result_pipe[0]);
        close(ready_pipe[0]);
        close(done_pipe[1]);
        pin(split ? 1 : 0);
        uint64_t received = 0, t_first = 0, t_last = 0;
        int done = 0;
        if (raw) {
            close(raw_tx);
            uint8_t buf[2048];
            if (write(ready_pipe[1], "r", 1) != 1) return 2;
            for (;;) {
                int was_done = done; /* quiet for a whole 300 ms after "done": nothing left in flight */
                int got_input = child_wait(raw_rx, done_pipe[0], &done, done ? 300 : 200);
                if (received >= (uint64_t)n_msgs || (was_done && !got_input)) break;
                for (;;) {
                    ssize_t k = recv(raw_rx, buf, sizeof buf, MSG_DONTWAIT);
                    if (k < 0) break;
                    uint64_t t = now_ns();
                    if (received++ == 0) t_first = t;
                    t_last = t;
                    child_fault(received);
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
                while (ub_tcp_state(&e->tcp) != UB_TCP_UP) {
                    struct pollfd lp = {.fd = ub_tcp_listen_fileno(&e->tcp), .events = POLLIN};
                    (void)poll(&lp, 1, 100);
                    CHECK(ub_tcp_service(&e->tcp, &e->node, now_ms()));
                    if (now_ns() > smp.deadline_ns) fail("no connection from the sender before the deadline");
                }
                big_buffers(ub_tcp_fileno(&e->tcp));
            }
            CALLGRIND_ZERO_STATS;
            for (;;) {
                int was_done = done;
                int got_input = child_wait(end_fd(e), done_pipe[0], &done, done ? 300 : 200);
                int rc = end_service(e);
                if (rc < 0) die("service", rc);
                child_fault(e->received);
                if (e->received >= (uint64_t)n_msgs || (was_done && !got_input)) break;
                if (!is_udp && ub_tcp_state(&e->tcp) != UB_TCP_UP) break; /* the sender hung up */
            }
            count_dump("rx");
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
    smp.child = child;
    smp.result_fd = result_pipe[0];
    /* Only the child writes these: with the parent's ends closed, a child that dies reads as EOF. */
    close(result_pipe[1]);
    close(ready_pipe[1]);
    close(done_pipe[0]);
    pin(0);
    {
        struct pollfd rp = {.fd = ready_pipe[0], .events = POLLIN};
        while (poll(&rp, 1, 200) == 0) check_alive(0);
        char c;
        if (read(ready_pipe[0], &c, 1) != 1) {
            check_alive(0);
            fail("the child exited before it was ready");
        }
    }
    usleep(100000);
    uint64_t refused = 0, send_errors = 0, t0 = 0, t1 = 0;
    uint64_t *rtts = rtt ? calloc((size_t)n_msgs, sizeof *rtts) : NULL;
    if (raw) {
        close(raw_rx);
        uint8_t msg[64] = {0}, back[2048];
        struct pollfd p = {.fd = raw_tx, .events = POLLIN};
        t0 = now_ns();
        for (long i = 0; i < n_msgs; i++) {
            memcpy(msg, &i, sizeof i);
            uint64_t ts = now_ns();
            unsigned in_row = 0;
            for (;;) {
                ssize_t k;
                if (smp.fault_send_fail > 0) {
                    smp.fault_send_fail--;
                    k = -1;
                    errno = ECONNREFUSED;
                } else {
                    k = send(raw_tx, msg, sizeof msg, 0);
                }
                if (k >= 0) break;
                if (errno == EAGAIN || errno == ENOBUFS) {
                    refused++;
                    if ((refused & 1023) == 0) check_alive(i);
                    continue;
                }
                send_error(&send_errors, errno, i, &in_row);
            }
            if (rtt) {
                for (;;) {
                    int k = poll(&p, 1, 200);
                    if (k > 0 && recv(raw_tx, back, sizeof back, MSG_DONTWAIT) >= 0) break;
                    check_alive(i);
                    if (now_ns() - ts > 5000000000u) fail("echo of message %ld not back within 5 s", i);
                }
                rtts[i] = now_ns() - ts;
            }
            if ((i & 4095) == 0) check_alive(i);
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
            while (ub_tcp_state(&e->tcp) != UB_TCP_UP) {
                CHECK(ub_tcp_service(&e->tcp, &e->node, now_ms()));
                usleep(1000);
                check_alive(0);
            }
            big_buffers(ub_tcp_fileno(&e->tcp));
        }
        const uint8_t *dest = ub_node_entity_id(&e->node, e->other);
        CALLGRIND_ZERO_STATS;
        t0 = now_ns();
        for (long i = 0; i < n_msgs; i++) {
            benchBlob64.seq = (uint64_t)i;
            uint64_t ts = now_ns();
            benchBlob64.t_ns = ts;
            unsigned in_row = 0;
            for (;;) {
                int rc;
                if (smp.fault_send_fail > 0) {
                    smp.fault_send_fail--;
                    send_error(&send_errors, ECONNREFUSED, i, &in_row);
                    continue;
                }
                rc = ub_node_send_data(&e->node, e->self, benchcat_INST_benchBlob64, dest, ts / 1000000u);
                if (rc == 1) break;
                if (rc < 0) die("ub_node_send_data", rc);
                refused++; /* push back: wait for room, then send the same message again */
                struct pollfd p = {.fd = end_fd(e), .events = POLLOUT};
                (void)poll(&p, 1, 10);
                end_flush(e);
                check_alive(i); /* a refusal that never ends is a receiver gone (TCP closed), not push back */
                if (!is_udp && ub_tcp_state(&e->tcp) != UB_TCP_UP) {
                    CHECK(ub_tcp_service(&e->tcp, &e->node, now_ms()));
                    if (ub_tcp_state(&e->tcp) != UB_TCP_UP && now_ns() - ts > 5000000000u)
                        fail("TCP connection down for 5 s at message %ld", i);
                }
            }
            if (rtt) {
                while (e->last_echo_seq != (uint64_t)i || e->received == 0) {
                    (void)end_wait(e, 200);
                    check_alive(i);
                    if (now_ns() - ts > 5000000000u) fail("echo of message %ld not back within 5 s", i);
                }
                rtts[i] = now_ns() - ts;
            }
            if ((i & 4095) == 0) check_alive(i);
        }
        while (end_pending(e)) {
            struct pollfd p = {.fd = end_fd(e), .events = POLLOUT};
            (void)poll(&p, 1, 10);
            end_flush(e);
            check_alive(n_msgs);
        }
        t1 = now_ns();
        count_dump("tx");
    }
    /* Done: the receiver drains what is in flight and reports. */
    close(done_pipe[1]);
    char line[128] = {0};
    ssize_t got = 0;
    {
        struct pollfd rp = {.fd = result_pipe[0], .events = POLLIN};
        while (poll(&rp, 1, 200) == 0)
            if (now_ns() > smp.deadline_ns) fail("no result from the receiver before the deadline");
        got = read(result_pipe[0], line, sizeof line - 1);
    }
    int status = smp.child_status;
    if (smp.child > 0) waitpid(child, &status, 0);
    smp.child = -1;
    unsigned long long received = 0, t_first = 0, t_last = 0;
    if (got <= 0 || sscanf(line, "%llu %llu %llu", &received, &t_first, &t_last) != 3)
        fail("no result from the receiver (it exited: %s %d)", WIFEXITED(status) ? "exit" : "signal",
             WIFEXITED(status) ? WEXITSTATUS(status) : WTERMSIG(status));
    if (rtt) {
        qsort(rtts, (size_t)n_msgs, sizeof *rtts, cmp_u64);
        size_t warm = (size_t)n_msgs / 20;
        size_t k = (size_t)n_msgs - warm;
        uint64_t *r = rtts + warm;
        qsort(r, k, sizeof *r, cmp_u64);
        printf("mode=rtt transport=%s placement=\"%s\" n=%ld p50_us=%.2f p99_us=%.2f send_errors=%llu status=ok\n",
               transport, where, n_msgs, r[k / 2] / 1e3, r[(k * 99) / 100] / 1e3, (unsigned long long)send_errors);
    } else {
        double rate = received > 1 && t_last > t_first ? (double)(received - 1) / ((t_last - t_first) / 1e9) : 0;
        printf("mode=blast transport=%s placement=\"%s\" batching=%d n=%ld received=%llu delivered_per_s=%.0f "
               "lost_pct=%.3f offered_per_s=%.0f refused_retried=%llu send_errors=%llu status=ok\n",
               transport, where, raw ? 0 : batching, n_msgs, received, rate,
               100.0 * (1.0 - (double)received / (double)n_msgs), n_msgs / ((t1 - t0) / 1e9),
               (unsigned long long)refused, (unsigned long long)send_errors);
    }
    free(rtts);
    return 0;
}

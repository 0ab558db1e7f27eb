/*
 * The private helpers of the stream and socket drivers (drivers/ub_stream_tx_private.h,
 * drivers/ub_sock_private.h), driven directly (issue #29 item 6). The transmit buffer gets a write function
 * that answers as a descriptor can (short writes, EINTR, EAGAIN, EPIPE, ECONNRESET, EIO, 0): whole frames go
 * in or nothing does, the unwritten rest stays in order, every byte written is counted, a dead peer is
 * UB_ERR_CLOSED and other failures UB_ERR_IO. The scenario tests reach only what a live socket answers.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <poll.h>
#include <string.h>

#include "drivers/ub_sock_private.h"
#include "drivers/ub_stream_tx_private.h"
#include "ub/ub_serial.h"
#include "ub/ub_ports.h"
#include "ub/ub_tcp.h"
#include "ub/ub_udp.h"

/* A scripted descriptor: each call takes the next answer (>0: bytes accepted, at most what is asked; <= 0:
 * that return with `err` in errno); past the script it takes everything. What it accepted is in `wire`. */
typedef struct answer {
    long n;
    int err;
} answer_t;
static const answer_t *g_script;
static size_t g_steps, g_at;
static uint8_t g_wire[256];
static size_t g_wire_len;

static long scripted_write(int fd, const uint8_t *data, size_t len) {
    (void)fd;
    size_t take = len;
    if (g_at < g_steps) {
        const answer_t *a = &g_script[g_at++];
        if (a->n <= 0) {
            errno = a->err;
            return a->n;
        }
        if ((size_t)a->n < len) take = (size_t)a->n;
    }
    if (take > sizeof g_wire - g_wire_len) take = sizeof g_wire - g_wire_len;
    memcpy(g_wire + g_wire_len, data, take);
    g_wire_len += take;
    return (long)take;
}

static void script(const answer_t *a, size_t n) {
    g_script = a;
    g_steps = n;
    g_at = 0;
    g_wire_len = 0;
}

static void test_stream_tx_answers(void **state) {
    (void)state;
    uint8_t buf[16], frame[12];
    for (int i = 0; i < 12; i++) frame[i] = (uint8_t)(0xA0 + i);
    size_t len = 0;
    uint64_t written = 0;
    /* Short writes and EINTR: all of it goes, in order. */
    static const answer_t a1[] = {{3, 0}, {-1, EINTR}, {2, 0}};
    script(a1, 3);
    assert_int_equal(ub_stream_tx_send(0, scripted_write, buf, sizeof buf, &len, frame, 10, &written), UB_OK);
    assert_int_equal(len, 0);
    assert_int_equal(written, 10);
    assert_memory_equal(g_wire, frame, 10);
    /* EAGAIN after 4 bytes: the rest stays queued; a second frame does not fit beside it (nothing of it
     * is taken); the next flush sends the rest in order. */
    static const answer_t a2[] = {{4, 0}, {-1, EAGAIN}, {-1, EWOULDBLOCK}};
    script(a2, 3);
    assert_int_equal(ub_stream_tx_send(0, scripted_write, buf, sizeof buf, &len, frame, 10, &written), UB_OK);
    assert_int_equal(len, 6);
    assert_int_equal(ub_stream_tx_send(0, scripted_write, buf, sizeof buf, &len, frame, 11, &written), UB_ERR_AGAIN);
    assert_int_equal(len, 6);
    script(NULL, 0);
    assert_int_equal(ub_stream_tx_flush(0, scripted_write, buf, &len, &written), UB_OK);
    assert_int_equal(len, 0);
    assert_memory_equal(g_wire, frame + 4, 6);
    assert_int_equal(written, 20);
    /* A dead peer: EPIPE and ECONNRESET are UB_ERR_CLOSED; EIO and a zero write are UB_ERR_IO; the bytes
     * written before the failure are counted and gone from the buffer. */
    static const answer_t dead[][2] = {{{2, 0}, {-1, EPIPE}}, {{2, 0}, {-1, ECONNRESET}}, {{2, 0}, {-1, EIO}},
                                      {{2, 0}, {0, 0}}};
    static const int want[] = {UB_ERR_CLOSED, UB_ERR_CLOSED, UB_ERR_IO, UB_ERR_IO};
    for (int k = 0; k < 4; k++) {
        len = 0;
        written = 0;
        script(dead[k], 2);
        assert_int_equal(ub_stream_tx_send(0, scripted_write, buf, sizeof buf, &len, frame, 10, &written), want[k]);
        assert_int_equal(written, 2);
        assert_int_equal(len, 8);
        assert_int_equal(buf[0], frame[2]);
        /* with bytes queued, the next send's flush fails first: the new frame is not taken */
        script(dead[k] + 1, 1);
        assert_int_equal(ub_stream_tx_send(0, scripted_write, buf, sizeof buf, &len, frame, 2, &written), want[k]);
        assert_int_equal(len, 8);
    }
}

static void test_sock_helpers(void **state) {
    (void)state;
    struct sockaddr_in a;
    assert_int_equal(ub_sock_address(NULL, 1, &a), UB_ERR_INVAL);
    assert_int_equal(ub_sock_address("300.1.1.1", 1, &a), UB_ERR_INVAL);
    assert_int_equal(ub_sock_address("127.0.0.1", 5001, &a), UB_OK);
    assert_int_equal(ntohs(a.sin_port), 5001);
    assert_int_equal(ub_sock_set_nonblocking(-1), UB_ERR_IO); /* not a descriptor */
    uint16_t port = 0;
    assert_int_equal(ub_sock_local_port(-1, &port), UB_ERR_IO);
    errno = EAGAIN;
    ub_sock_close_keep_errno(-1);
    assert_int_equal(errno, EAGAIN); /* close()'s EBADF does not replace the caller's errno */
    char host[32];
    assert_true(ub_sock_parse_hostport("localhost:5001", host, sizeof host, &port));
    assert_string_equal(host, "127.0.0.1");
    assert_int_equal(port, 5001);
    assert_false(ub_sock_parse_hostport("5001", host, sizeof host, &port));           /* no colon */
    assert_false(ub_sock_parse_hostport(":5001", host, sizeof host, &port));          /* no host */
    assert_false(ub_sock_parse_hostport("127.0.0.1:5001", host, 4, &port));           /* no room */
    assert_false(ub_sock_parse_hostport("127.0.0.1:5001", host, 300, &port));         /* cap beyond the copy */
    assert_false(ub_sock_parse_hostport("example.org:5001", host, sizeof host, &port)); /* not dotted IPv4 */
    assert_false(ub_sock_parse_hostport("127.0.0.1:65536", host, sizeof host, &port));
    assert_false(ub_sock_parse_hostport("127.0.0.1:x", host, sizeof host, &port));
}

/* ub_tcp.h called the wrong way (a real listening socket on 127.0.0.1): NULLs, a node it is not attached
 * to, a port of a client, a bind that cannot work. */
static ub_tcp_t g_srv, g_cli;
static void test_tcp_contracts(void **state) {
    (void)state;
    assert_int_equal(ub_tcp_server_open(&g_srv, "127.0.0.1", 0, NULL), UB_OK);
    uint16_t port = 0;
    assert_int_equal(ub_tcp_local_port(&g_srv, &port), UB_OK);
    assert_true(port > 0);
    assert_int_equal(ub_tcp_local_port(NULL, &port), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_local_port(&g_srv, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_client_init(&g_cli, "127.0.0.1", port, NULL), UB_OK);
    assert_int_equal(ub_tcp_local_port(&g_cli, &port), UB_ERR_INVAL); /* a client does not listen */
    assert_int_equal(ub_tcp_client_init(NULL, "127.0.0.1", port, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_client_init(&g_cli, "127.0.0.1", 0, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_client_init(&g_cli, "not-an-address", port, NULL), UB_ERR_INVAL);
    ub_tcp_t other;
    assert_int_equal(ub_tcp_server_open(NULL, "127.0.0.1", 0, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_server_open(&other, "1.2.3.256", 0, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_server_open(&other, "127.0.0.1", port, NULL), UB_ERR_IO); /* taken: bind fails */
    assert_int_equal(ub_tcp_service(NULL, NULL, 0), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_service(&g_srv, NULL, 0), UB_ERR_INVAL); /* not attached to that node */
    assert_int_equal(ub_tcp_set_batching(NULL, 1), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_flush(NULL, 0), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_flush(&g_srv, 0), 0); /* nothing queued, not connected */
    assert_int_equal(ub_tcp_candidates(NULL), 0);
    assert_int_equal(ub_tcp_candidates(&g_srv), 0);
    assert_null(ub_tcp_stats(NULL));
    /* The driver table's hooks (what ub_ports calls): counters counted without a place to put them or with
     * room for two, a poll set with no room, the retry time only a waiting client has. */
    ub_driver_counter_t two[2];
    size_t all = ub_tcp_driver.counters(&g_srv, NULL, 0);
    assert_true(all > 2);
    assert_int_equal(ub_tcp_driver.counters(&g_srv, two, 2), all);
    assert_string_equal(two[0].name, "connects");
    struct pollfd fds[2];
    assert_int_equal(ub_tcp_driver.pollfds(&g_srv, fds, 0), UB_ERR_NOSPACE);
    assert_int_equal(ub_tcp_driver.pollfds(&g_srv, fds, 2), 1); /* the listener */
    assert_int_equal(fds[0].events, POLLIN);
    uint64_t due = 0;
    assert_false(ub_tcp_driver.next_due(&g_srv, &due));
    assert_int_equal(ub_tcp_client_init(&g_cli, "127.0.0.1", port, NULL), UB_OK);
    assert_true(ub_tcp_driver.next_due(&g_cli, &due));
    ub_tcp_close(&g_srv);
    ub_tcp_close(&g_cli);
    ub_tcp_close(NULL);
}

/* ub_udp.h called the wrong way on a real 127.0.0.1 socket. */
static ub_udp_t g_udp;
static void test_udp_contracts(void **state) {
    (void)state;
    assert_int_equal(ub_udp_open(&g_udp, "127.0.0.1", 0, "127.0.0.1", 0), UB_ERR_INVAL); /* peer port 0 */
    assert_int_equal(ub_udp_open(&g_udp, "127.0.0.1", 0, "nowhere", 5000), UB_ERR_INVAL);
    assert_int_equal(ub_udp_open(&g_udp, "127.0.0.1", 0, "127.0.0.1", 5000), UB_OK);
    uint16_t port = 0;
    assert_int_equal(ub_udp_local_port(&g_udp, &port), UB_OK);
    assert_true(port > 0);
    assert_int_equal(ub_udp_set_peer(NULL, "127.0.0.1", 1), UB_ERR_INVAL);
    assert_int_equal(ub_udp_set_peer(&g_udp, "127.0.0.1", 0), UB_ERR_INVAL);
    assert_int_equal(ub_udp_set_accept(NULL, UB_UDP_ACCEPT_ANY), UB_ERR_INVAL);
    assert_int_equal(ub_udp_set_accept(&g_udp, (ub_udp_accept_t)(UB_UDP_ACCEPT_ANY + 1)), UB_ERR_INVAL);
    char host[16];
    assert_int_equal(ub_udp_peer_at(NULL, 0, host, &port), UB_ERR_INVAL);
    assert_int_equal(ub_udp_peer_at(&g_udp, 0, NULL, &port), UB_ERR_INVAL);
    assert_int_equal(ub_udp_peer_at(&g_udp, 0, host, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_udp_peer_at(&g_udp, -1, host, &port), UB_ERR_INVAL);
    assert_int_equal(ub_udp_peer_at(&g_udp, 0, host, &port), UB_OK);
    assert_string_equal(host, "127.0.0.1");
    assert_int_equal(port, 5000);
    assert_int_equal(ub_udp_service(NULL, NULL, 0), UB_ERR_INVAL);
    assert_int_equal(ub_udp_service(&g_udp, NULL, 0), UB_ERR_INVAL); /* not attached */
    ub_driver_counter_t two[2];
    size_t all = ub_udp_driver.counters(&g_udp, NULL, 0);
    assert_true(all > 2);
    assert_int_equal(ub_udp_driver.counters(&g_udp, NULL, 5), all); /* room asked, nowhere to put it */
    assert_int_equal(ub_udp_driver.counters(&g_udp, two, 2), all);
    /* describe: the JSON of the counters and peers, measured when the buffer is too small (snprintf-like) */
    char d[512], tiny[8];
    int dn = ub_udp_driver.describe(&g_udp, d, sizeof d);
    assert_true(dn > 0 && (size_t)dn < sizeof d);
    assert_non_null(strstr(d, "\"127.0.0.1:5000\"]"));
    assert_int_equal(ub_udp_driver.describe(&g_udp, tiny, sizeof tiny), dn);
    assert_int_equal(ub_udp_driver.notice(&g_udp, "l0", d, sizeof d), 0); /* nothing refused yet */
    /* the accept parameter: one of three words, once */
    ub_port_spec_t spec;
    char err[UB_PORTS_ERR_LEN];
    assert_int_equal(ub_port_spec_parse("udp:bind=127.0.0.1:0,accept=some", &spec, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "use peer"));
    assert_int_equal(ub_port_spec_parse("udp:bind=127.0.0.1:0,accept=any,accept=any", &spec, err, sizeof err),
                     UB_ERR_INVAL);
    assert_non_null(strstr(err, "given twice"));
    struct pollfd fds[1];
    assert_int_equal(ub_udp_driver.pollfds(&g_udp, fds, 0), UB_ERR_NOSPACE);
    ub_udp_close(&g_udp);
    assert_int_equal(ub_udp_fileno(&g_udp), -1);
    /* Without a configured peer, accepting only "the peer" is refused. */
    ub_udp_t alone;
    assert_int_equal(ub_udp_open(&alone, "127.0.0.1", 0, NULL, 0), UB_OK);
    assert_int_equal(ub_udp_set_accept(&alone, UB_UDP_ACCEPT_PEER), UB_ERR_INVAL);
    assert_int_equal(ub_udp_set_accept(&alone, UB_UDP_ACCEPT_LEARN), UB_OK);
    ub_udp_close(&alone);
    assert_int_equal(ub_udp_driver.pollfds(&g_udp, fds, 1), 0); /* closed: nothing to wait on */
    ub_udp_close(NULL);
}

/* ub_serial.h on a real pseudo-terminal: the decoder and foreign-traffic hooks set and removed, NULLs, the
 * driver table's counters and poll set without room, a node it is not attached to. */
static ub_serial_t g_ser;
static size_t on_foreign(void *user, const uint8_t *run, size_t len) {
    (void)user, (void)run;
    return len;
}
static void test_serial_contracts(void **state) {
    (void)state;
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    assert_true(master >= 0);
    assert_int_equal(grantpt(master), 0);
    assert_int_equal(unlockpt(master), 0);
    const char *slave = ptsname(master);
    assert_non_null(slave);
    assert_int_equal(ub_serial_open(&g_ser, slave, 57600), UB_OK);
    assert_int_equal(ub_serial_set_decoder(NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_serial_set_foreign(NULL, on_foreign, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_serial_set_foreign(&g_ser, on_foreign, NULL), UB_OK);
    assert_int_equal(ub_serial_set_foreign(&g_ser, NULL, NULL), UB_OK); /* removed again */
    assert_int_equal(ub_serial_tx_pending(&g_ser), 0);
    assert_false(ub_serial_next_retry(&g_ser, NULL)); /* open, not hung up: nothing to retry */
    assert_int_equal(ub_serial_service(&g_ser, NULL, 0), UB_ERR_INVAL); /* not attached */
    ub_driver_counter_t two[2];
    size_t all = ub_serial_driver.counters(&g_ser, NULL, 0);
    assert_true(all > 2);
    assert_int_equal(ub_serial_driver.counters(&g_ser, two, 2), all);
    struct pollfd fds[1];
    assert_int_equal(ub_serial_driver.pollfds(&g_ser, fds, 0), UB_ERR_NOSPACE);
    assert_int_equal(ub_serial_driver.pollfds(&g_ser, fds, 1), 1);
    assert_int_equal(fds[0].events, POLLIN); /* nothing queued: no POLLOUT */
    ub_serial_close(&g_ser);
    close(master);
}

/* Batched UDP sends between two real sockets: frames share a datagram while they fit, a full queue is sent
 * before the next frame is taken, the poll set asks for POLLOUT while frames wait, turning batching off sends
 * them; a frame above the datagram limit, a sender without a peer and a closed socket are refused. */
static ub_udp_t g_rx, g_tx;
static void test_udp_batching(void **state) {
    (void)state;
    assert_int_equal(ub_udp_open(&g_rx, "127.0.0.1", 0, NULL, 0), UB_OK);
    uint16_t port = 0;
    assert_int_equal(ub_udp_local_port(&g_rx, &port), UB_OK);
    static uint8_t frame[UB_UDP_DATAGRAM_MAX + 1];
    memset(frame, 0x5A, sizeof frame);
    const ub_link_ops_t *ops = ub_udp_driver.link_ops;
    assert_int_equal(ops->send(&g_rx, frame, 10, 0), UB_ERR_NOROUTE); /* no peer yet */
    assert_int_equal(ub_udp_open(&g_tx, "127.0.0.1", 0, "127.0.0.1", port), UB_OK);
    assert_int_equal(ops->send(&g_tx, frame, sizeof frame, 0), UB_ERR_INVAL); /* above the datagram limit */
    assert_int_equal(ub_udp_set_batching(&g_tx, 1), UB_OK);
    assert_int_equal(ops->send(&g_tx, frame, 20, 0), UB_OK);
    assert_int_equal(ops->send(&g_tx, frame, 20, 0), UB_OK); /* shares the first datagram */
    size_t half = UB_UDP_DATAGRAM_MAX / 2 + 1;                /* one datagram each from here */
    for (int i = 0; i < UB_UDP_TX_SLOTS + 2; i++) assert_int_equal(ops->send(&g_tx, frame, half, 0), UB_OK);
    assert_true(ub_udp_tx_pending(&g_tx) > 0);
    struct pollfd fds[1];
    assert_int_equal(ub_udp_driver.pollfds(&g_tx, fds, 1), 1);
    assert_true(fds[0].events & POLLOUT);
    assert_int_equal(ub_udp_set_batching(&g_tx, 0), UB_OK); /* sends what waits */
    assert_int_equal(ub_udp_tx_pending(&g_tx), 0);
    assert_int_equal(ub_udp_flush(NULL), UB_ERR_INVAL);
    ub_udp_close(&g_tx);
    assert_int_equal(ops->send(&g_tx, frame, 10, 0), UB_ERR_CLOSED);
    ub_udp_close(&g_rx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stream_tx_answers),
        cmocka_unit_test(test_sock_helpers),
        cmocka_unit_test(test_tcp_contracts),
        cmocka_unit_test(test_udp_contracts),
        cmocka_unit_test(test_serial_contracts),
        cmocka_unit_test(test_udp_batching),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/*
 * The TCP driver where test_tcp.c does not go (issue #29 item 6), over real 127.0.0.1 sockets:
 *  - foreign traffic on a TCP stream: the application's bytes written between frames reach the other side's
 *    handler byte-exact while the frames are delivered; a reconnection starts the link's own decoder afresh
 *    (the half frame of the old stream counted, not glued to the new one); the handler removed, such bytes
 *    are garbage again;
 *  - batching with a full buffer: the queue goes out before the next frame is taken; against a peer that
 *    stops reading, the refusal is backpressure, counted, and every frame accepted arrives in order;
 *  - a peer that resets the connection: a flush, a send and a service each find it, count the
 *    disconnect and the bytes they discard, and refuse as closed;
 *  - the driver table's hooks: POLLOUT while bytes wait, counters without a place to put them.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "support/ub_test_foreign.h"
#include "support/ub_test_pair.h"
#include "support/ub_test_tcp_pair.h"
#include "ub/ub_tcp.h"

/* Serves both ends (simulated clock `*now`, advanced 1 ms a round) until `cond` holds; at most ~4 s real. */
#define SERVE_UNTIL(t, now, cond)                                                                             \
    do {                                                                                                      \
        for (int i_ = 0; i_ < 2000 && !(cond); i_++) {                                                        \
            struct pollfd f_[3] = {{.fd = ub_tcp_fileno(&(t)->client), .events = POLLIN | POLLOUT},           \
                                   {.fd = ub_tcp_fileno(&(t)->server), .events = POLLIN},                     \
                                   {.fd = ub_tcp_listen_fileno(&(t)->server), .events = POLLIN}};             \
            (void)poll(f_, 3, 2);                                                                             \
            assert_true(ub_tcp_service(&(t)->client, (t)->p->pub_node, (now)) >= 0);                          \
            assert_true(ub_tcp_service(&(t)->server, (t)->p->sub_node, (now)) >= 0);                          \
            (now)++;                                                                                          \
        }                                                                                                     \
        assert_true(cond);                                                                                    \
    } while (0)

#define CONNECTED(t) (ub_tcp_state(&(t)->client) == UB_TCP_UP && ub_tcp_state(&(t)->server) == UB_TCP_UP)

/* A real DATA frame of gpsOut from pub to sub, built by the pub node (captured instead of sent). */
static size_t data_frame(pair_t *p, uint8_t *out) {
    static capture_t cap;
    memset(&cap, 0, sizeof cap);
    const ub_link_ops_t *ops = ub_node_link(p->pub_node, p->pub_link)->ops;
    void *impl = ub_node_link(p->pub_node, p->pub_link)->impl;
    assert_int_equal(ub_node_link_attach(p->pub_node, p->pub_link, &capture_ops, &cap), UB_OK);
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0), 1);
    assert_int_equal(ub_node_link_attach(p->pub_node, p->pub_link, ops, impl), UB_OK); /* back to TCP */
    memcpy(out, cap.frame[0], cap.len[0]);
    return cap.len[0];
}

static void test_foreign_bytes_share_a_tcp_stream(void **state) {
    (void)state;
    tcp_pair_t *t = tcp_pair_new();
    pair_t *p = t->p;
    uint64_t now = 0;
    SERVE_UNTIL(t, now, CONNECTED(t));
    handler_t h = {.len = 0};
    assert_int_equal(ub_tcp_set_foreign(&t->server, on_foreign, &h), UB_OK);
    assert_int_equal(ub_tcp_set_foreign(&t->server, on_foreign, &h), UB_OK); /* again: nothing it held is lost */

    /* client: an NMEA-like line, a frame, another line */
    static const char line1[] = "$GPGGA,1*00\r\n", line2[] = "$GPRMC,2*00\r\n";
    assert_int_equal(ub_tcp_write_foreign(&t->client, (const uint8_t *)line1, strlen(line1), now), UB_OK);
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, now), 1);
    assert_int_equal(ub_tcp_write_foreign(&t->client, (const uint8_t *)line2, strlen(line2), now), UB_OK);
    SERVE_UNTIL(t, now, p->log.n == 1 && h.len == strlen(line1) + strlen(line2));
    assert_memory_equal(h.got, line1, strlen(line1));
    assert_memory_equal(h.got + strlen(line1), line2, strlen(line2));
    assert_memory_equal(&p->gps_dst, &p->gps_src, sizeof p->gps_src);
    assert_int_equal(ub_tcp_stats(&t->client)->foreign_out, 2);
    char d[1024], want[64];
    assert_true(ub_tcp_driver.describe(&t->server, d, sizeof d) > 0);
    snprintf(want, sizeof want, "\"foreign_bytes\":%zu", h.len);
    assert_non_null(strstr(d, want));
    /* the refusals: nothing written, nothing counted */
    uint8_t big[UB_TCP_TX_BUFFER + 1] = {0};
    assert_int_equal(ub_tcp_write_foreign(NULL, big, 1, now), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_write_foreign(&t->client, NULL, 1, now), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_write_foreign(&t->client, big, sizeof big, now), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_set_foreign(NULL, on_foreign, &h), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_stats(&t->client)->foreign_out, 2);

    /* The client goes away after the first 20 bytes of a frame; it comes back: the new stream's first frame
     * is delivered (the 20 old bytes were counted garbage at the new connection, not read as its start). */
    static uint8_t frame[UB_FRAME_MAX];
    size_t flen = data_frame(p, frame);
    assert_int_equal(ub_tcp_write_foreign(&t->client, frame, 20, now), UB_OK);
    SERVE_UNTIL(t, now, ub_decoder_pending(&t->server.own_dec) == 20);
    uint64_t garbage = t->server.own_dec.stats.garbage_bytes;
    ub_tcp_close(&t->client);
    SERVE_UNTIL(t, now, ub_tcp_state(&t->server) == UB_TCP_DOWN);
    ub_tcp_options_t opt = {.backoff_initial_ms = 20, .backoff_max_ms = 160};
    assert_int_equal(ub_tcp_client_init(&t->client, "127.0.0.1", t->port, &opt), UB_OK);
    assert_int_equal(ub_tcp_attach(&t->client, p->pub_node, p->pub_link), UB_OK);
    SERVE_UNTIL(t, now, CONNECTED(t));
    assert_int_equal(ub_decoder_pending(&t->server.own_dec), 0);
    assert_int_equal(t->server.own_dec.stats.garbage_bytes, garbage + 20);
    assert_int_equal(ub_tcp_write_foreign(&t->client, frame, flen, now), UB_OK); /* the whole frame, raw */
    SERVE_UNTIL(t, now, p->log.n == 2);
    assert_int_equal(h.len, strlen(line1) + strlen(line2)); /* the handler got none of it */

    /* The handler removed (twice: the second changes nothing): other bytes are the slot decoder's garbage. */
    assert_int_equal(ub_tcp_set_foreign(&t->server, NULL, NULL), UB_OK);
    assert_int_equal(ub_tcp_set_foreign(&t->server, NULL, NULL), UB_OK);
    const ub_decoder_stats_t *slot = &ub_node_link(p->sub_node, p->sub_link)->decoder.stats;
    uint64_t slot_garbage = slot->garbage_bytes;
    assert_int_equal(ub_tcp_write_foreign(&t->client, (const uint8_t *)line1, strlen(line1), now), UB_OK);
    SERVE_UNTIL(t, now, slot->garbage_bytes == slot_garbage + strlen(line1));
    assert_int_equal(h.len, strlen(line1) + strlen(line2));
    tcp_pair_free(t);
}

static void test_batching_with_a_full_buffer(void **state) {
    (void)state;
    tcp_pair_t *t = tcp_pair_new();
    pair_t *p = t->p;
    uint64_t now = 0;
    SERVE_UNTIL(t, now, CONNECTED(t));
    assert_int_equal(ub_tcp_set_batching(&t->client, 1), UB_OK);
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, now), 1);
    size_t flen = ub_tcp_tx_pending(&t->client);
    assert_true(flen > 0);
    struct pollfd fds[2];
    assert_int_equal(ub_tcp_driver.pollfds(&t->client, fds, 2), 1);
    assert_true(fds[0].events & POLLOUT); /* bytes wait: the loop is woken when they can go */
    while (ub_tcp_tx_pending(&t->client) + flen <= UB_TCP_TX_BUFFER)
        assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, now), 1);
    size_t full = ub_tcp_tx_pending(&t->client);
    uint64_t out = ub_tcp_stats(&t->client)->bytes_out;
    /* the next frame does not fit: the queue goes out first, then the frame is queued */
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, now), 1);
    assert_int_equal(ub_tcp_stats(&t->client)->bytes_out, out + full);
    assert_int_equal(ub_tcp_tx_pending(&t->client), flen);
    size_t sent = full / flen + 1;
    assert_int_equal(ub_tcp_stats(&t->client)->frames_out, sent);

    /* A peer that stops reading (small kernel buffers fill at once): batching still queues while it can,
     * then refuses as backpressure, counted by the driver and the node. */
    int small = 4096;
    assert_int_equal(setsockopt(ub_tcp_fileno(&t->client), SOL_SOCKET, SO_SNDBUF, &small, sizeof small), 0);
    assert_int_equal(setsockopt(ub_tcp_fileno(&t->server), SOL_SOCKET, SO_RCVBUF, &small, sizeof small), 0);
    int refused = 0;
    for (int i = 0; i < 100000 && refused < 3; i++) {
        int rc = ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, now);
        assert_true(rc == 0 || rc == 1);
        if (rc == 1) sent++;
        else refused++;
    }
    assert_int_equal(ub_tcp_stats(&t->client)->backpressure, 3);
    assert_int_equal(ub_node_link(p->pub_node, p->pub_link)->counters.drops[UB_DROP_BACKPRESSURE], 3);
    /* the peer reads again: every frame accepted arrives, in order, none twice */
    SERVE_UNTIL(t, now, p->log.n == sent && ub_tcp_tx_pending(&t->client) == 0);
    for (size_t i = 1; i < p->log.n; i++) assert_true(p->log.d[i].seq > p->log.d[i - 1].seq);
    assert_int_equal(ub_tcp_stats(&t->client)->frames_out, sent);
    /* the driver table's counters: counted without a place to put them */
    assert_int_equal(ub_tcp_driver.counters(&t->client, NULL, 5), ub_tcp_driver.counters(&t->client, NULL, 0));
    tcp_pair_free(t);
}

/* A raw listener stands in for the far end, so the test can reset the connection (SO_LINGER 0: RST). */
typedef struct far_end {
    int lsock, peer;
    uint16_t port;
} far_end_t;

static void far_listen(far_end_t *f) {
    f->lsock = socket(AF_INET, SOCK_STREAM, 0);
    assert_true(f->lsock >= 0);
    struct sockaddr_in a = {.sin_family = AF_INET};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    assert_int_equal(bind(f->lsock, (struct sockaddr *)&a, sizeof a), 0);
    assert_int_equal(listen(f->lsock, 4), 0);
    assert_int_equal(getsockname(f->lsock, (struct sockaddr *)&a, &len), 0);
    f->port = ntohs(a.sin_port);
    f->peer = -1;
}

/* Serves the client until it is connected and the far end accepted it. */
static uint64_t far_connect(far_end_t *f, ub_tcp_t *c, ub_node_t *node, uint64_t now) {
    for (int i = 0; i < 2000 && ub_tcp_state(c) != UB_TCP_UP; i++) {
        (void)poll(&(struct pollfd){.fd = ub_tcp_fileno(c), .events = POLLOUT}, 1, 2);
        assert_true(ub_tcp_service(c, node, now++) >= 0);
    }
    assert_int_equal(ub_tcp_state(c), UB_TCP_UP);
    f->peer = accept(f->lsock, NULL, NULL);
    assert_true(f->peer >= 0);
    return now;
}

/* The far end resets the connection; returns once the client's socket has seen it. */
static void far_reset(far_end_t *f, const ub_tcp_t *c) {
    struct linger lg = {.l_onoff = 1, .l_linger = 0};
    assert_int_equal(setsockopt(f->peer, SOL_SOCKET, SO_LINGER, &lg, sizeof lg), 0);
    close(f->peer);
    f->peer = -1;
    struct pollfd pf = {.fd = ub_tcp_fileno(c), .events = POLLIN};
    assert_int_equal(poll(&pf, 1, 2000), 1);
    assert_true(pf.revents & (POLLERR | POLLHUP));
}

static void test_a_reset_peer_is_found_by_flush_send_and_service(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    far_end_t f;
    far_listen(&f);
    ub_tcp_t *c = calloc(1, sizeof *c);
    assert_non_null(c);
    ub_tcp_options_t opt = {.backoff_initial_ms = 10, .backoff_max_ms = 10};
    assert_int_equal(ub_tcp_client_init(c, "127.0.0.1", f.port, &opt), UB_OK);
    assert_int_equal(ub_tcp_attach(c, p->pub_node, p->pub_link), UB_OK);
    const ub_tcp_stats_t *s = ub_tcp_stats(c);
    const ub_link_counters_t *lc = &ub_node_link(p->pub_node, p->pub_link)->counters;
    uint64_t now = far_connect(&f, c, p->pub_node, 0);

    /* 1. ub_tcp_flush(): the queued frames cannot go; they are discarded and counted */
    assert_int_equal(ub_tcp_set_batching(c, 1), UB_OK);
    for (int i = 0; i < 3; i++) assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, now), 1);
    size_t queued = ub_tcp_tx_pending(c);
    assert_true(queued > 0);
    far_reset(&f, c);
    assert_int_equal(ub_tcp_flush(c, now), UB_ERR_CLOSED);
    assert_int_equal(s->disconnects, 1);
    assert_int_equal(s->tx_discarded, queued);
    assert_int_equal(ub_tcp_state(c), UB_TCP_DOWN);
    assert_int_equal(ub_tcp_tx_pending(c), 0);

    /* 2. a send without batching: refused as closed, the frame counted discarded, the node's drop counted */
    now = far_connect(&f, c, p->pub_node, now + 10);
    assert_int_equal(ub_tcp_set_batching(c, 0), UB_OK);
    far_reset(&f, c);
    uint64_t tx_err = lc->drops[UB_DROP_TX_ERROR], discarded = s->tx_discarded;
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, now), 0);
    assert_int_equal(lc->drops[UB_DROP_TX_ERROR], tx_err + 1);
    assert_int_equal(s->disconnects, 2);
    assert_true(s->tx_discarded > discarded);
    assert_int_equal(ub_tcp_state(c), UB_TCP_DOWN);

    /* 3. the service's flush of what batching queued */
    now = far_connect(&f, c, p->pub_node, now + 10);
    assert_int_equal(s->reconnects, 2);
    assert_int_equal(ub_tcp_set_batching(c, 1), UB_OK);
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, now), 1);
    queued = ub_tcp_tx_pending(c);
    discarded = s->tx_discarded;
    far_reset(&f, c);
    assert_int_equal(ub_tcp_service(c, p->pub_node, now), 0);
    assert_int_equal(s->disconnects, 3);
    assert_int_equal(s->tx_discarded, discarded + queued);
    assert_int_equal(ub_tcp_state(c), UB_TCP_DOWN);
    uint64_t due = 0;
    assert_true(ub_tcp_driver.next_due(c, &due));
    assert_int_equal(due, now + 10);
    /* a service for another node is refused and changes nothing */
    assert_int_equal(ub_tcp_service(c, p->sub_node, due), UB_ERR_INVAL);
    assert_int_equal(s->attempts, 3);

    ub_tcp_close(c);
    free(c);
    close(f.lsock);
    pair_free(p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_foreign_bytes_share_a_tcp_stream),
        cmocka_unit_test(test_batching_with_a_full_buffer),
        cmocka_unit_test(test_a_reset_peer_is_found_by_flush_send_and_service),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

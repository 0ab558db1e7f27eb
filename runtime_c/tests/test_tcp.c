/*
 * The TCP driver over 127.0.0.1: a subscription runs over a client/server
 * connection; the server restarts and the client reconnects on its own;
 * reconnect attempts follow the exponential backoff on the injected clock; a
 * full transmit buffer is reported as backpressure and counted, and every
 * frame accepted arrives.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include "support/ub_test_link_events.h"
#include "support/ub_test_pair.h"
#include "support/ub_test_tcp_pair.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_tcp.h"

/* Waits (real time, at most `wait_ms`) until one of the pair's descriptors has something to do. */
static void wait_ready(tcp_pair_t *t, int wait_ms) {
    struct pollfd fds[3] = {
        {.fd = ub_tcp_fileno(&t->client), .events = POLLIN | (ub_tcp_tx_pending(&t->client) ? POLLOUT : 0)},
        {.fd = ub_tcp_fileno(&t->server), .events = POLLIN | (ub_tcp_tx_pending(&t->server) ? POLLOUT : 0)},
        {.fd = ub_tcp_listen_fileno(&t->server), .events = POLLIN},
    };
    if (ub_tcp_state(&t->client) == UB_TCP_CONNECTING) fds[0].events |= POLLOUT;
    (void)poll(fds, 3, wait_ms);
}

/* One simulated millisecond: tick both nodes, give the sockets a moment, serve both ends. */
static void step(tcp_pair_t *t, uint64_t now_ms) {
    ub_node_tick(t->p->pub_node, now_ms);
    ub_node_tick(t->p->sub_node, now_ms);
    wait_ready(t, 0);
    assert_true(ub_tcp_service(&t->client, t->p->pub_node, now_ms) >= 0);
    assert_true(ub_tcp_service(&t->server, t->p->sub_node, now_ms) >= 0);
}

static void run(tcp_pair_t *t, uint64_t from_ms, uint64_t to_ms) {
    for (uint64_t now = from_ms; now < to_ms; now++) step(t, now);
}

/* Serves until the client is connected (bounded in steps and real time). */
static uint64_t run_until_connected(tcp_pair_t *t, uint64_t now_ms) {
    for (int i = 0; i < 2000 && (ub_tcp_state(&t->client) != UB_TCP_UP || ub_tcp_state(&t->server) != UB_TCP_UP); i++) {
        wait_ready(t, 2);
        step(t, now_ms++);
    }
    assert_int_equal(ub_tcp_state(&t->client), UB_TCP_UP);
    assert_int_equal(ub_tcp_state(&t->server), UB_TCP_UP);
    return now_ms;
}

static void test_two_nodes_exchange_over_tcp(void **state) {
    (void)state;
    tcp_pair_t *t = tcp_pair_new();
    pair_t *p = t->p;
    uint64_t now = run_until_connected(t, 0);
    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, now) >= 0);
    run(t, now, now + 1000);
    size_t got = delivery_count(&p->log, p->sub, TEST_GPS, now, now + 1000);
    assert_in_range(got, 15, 21);
    assert_memory_equal(&p->gps_dst, &p->gps_src, sizeof p->gps_src);
    const ub_link_counters_t *pub = &ub_node_link(p->pub_node, p->pub_link)->counters;
    const ub_link_counters_t *sub = &ub_node_link(p->sub_node, p->sub_link)->counters;
    assert_true(pub->frames_in >= 1);
    assert_int_equal(t->client.stats.bytes_out, pub->bytes_out);
    assert_int_equal(t->server.stats.bytes_in, sub->bytes_in);
    assert_int_equal(t->client.stats.connects, 1);
    assert_int_equal(t->client.stats.reconnects, 0);
    tcp_pair_free(t);
}

static void test_server_restart_client_reconnects(void **state) {
    (void)state;
    tcp_pair_t *t = tcp_pair_new();
    pair_t *p = t->p;
    uint64_t now = run_until_connected(t, 0);
    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, now) >= 0);
    run(t, now, now + 500);
    now += 500;
    size_t before = p->log.n;
    assert_true(before >= 7);

    uint16_t port = t->port;
    ub_tcp_close(&t->server); /* the server process "dies" */
    run(t, now, now + 300);   /* the client notices (EOF) and retries with backoff while nobody listens */
    now += 300;
    assert_int_equal(ub_tcp_stats(&t->client)->disconnects, 1);
    assert_true(ub_tcp_stats(&t->client)->failed_attempts >= 1);
    assert_true(ub_node_link(p->pub_node, p->pub_link)->counters.drops[UB_DROP_TX_ERROR] >= 1); /* counted gap */
    size_t during = p->log.n;

    tcp_pair_open_server(t, port); /* restarted on the same port */
    now = run_until_connected(t, now);
    run(t, now, now + 500);
    assert_int_equal(ub_tcp_stats(&t->client)->reconnects, 1);
    assert_int_equal(ub_tcp_stats(&t->client)->connects, 2);
    size_t after = p->log.n - during;
    assert_true(after >= 7); /* data flows again without anyone touching the client */
    assert_int_equal(delivery_repeats(&p->log), 0);
    tcp_pair_free(t);
}

/* Attempt times against a port nobody listens on: 0, then +20, +40, +80, +160, +160 (capped). */
static void test_reconnect_backoff_follows_the_injected_clock(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_tcp_t probe;
    uint16_t dead_port;
    assert_int_equal(ub_tcp_server_open(&probe, "127.0.0.1", 0, NULL), UB_OK);
    assert_int_equal(ub_tcp_local_port(&probe, &dead_port), UB_OK);
    ub_tcp_close(&probe);

    ub_tcp_t *client = calloc(1, sizeof *client);
    assert_non_null(client);
    ub_tcp_options_t opt = {.backoff_initial_ms = 20, .backoff_max_ms = 160};
    assert_int_equal(ub_tcp_client_init(client, "127.0.0.1", dead_port, &opt), UB_OK);
    assert_int_equal(ub_tcp_attach(client, p->pub_node, p->pub_link), UB_OK);
    uint64_t attempt_at[8];
    size_t n_attempts = 0;
    for (uint64_t now = 0; now <= 600 && n_attempts < 8; now++) {
        uint64_t before = client->stats.attempts;
        /* A refused connect may take a moment of real time to show: wait for it, without advancing the clock. */
        for (int i = 0; i < 200; i++) {
            assert_true(ub_tcp_service(client, p->pub_node, now) >= 0);
            if (ub_tcp_state(client) != UB_TCP_CONNECTING) break;
            struct pollfd fd = {.fd = ub_tcp_fileno(client), .events = POLLOUT};
            (void)poll(&fd, 1, 5);
        }
        assert_int_equal(ub_tcp_state(client), UB_TCP_DOWN);
        if (client->stats.attempts != before) attempt_at[n_attempts++] = now;
    }
    const uint64_t expected[] = {0, 20, 60, 140, 300, 460};
    assert_int_equal(n_attempts, 6);
    assert_memory_equal(attempt_at, expected, sizeof expected);
    assert_int_equal(client->stats.failed_attempts, 6);
    assert_int_equal(client->stats.connects, 0);
    ub_tcp_close(client);
    free(client);
    pair_free(p);
}

static void test_full_transmit_buffer_is_backpressure(void **state) {
    (void)state;
    tcp_pair_t *t = tcp_pair_new();
    pair_t *p = t->p;
    uint64_t now = run_until_connected(t, 0);
    /* Small kernel buffers so the driver's own buffer fills quickly; the server does not read meanwhile. */
    int small = 4096;
    assert_int_equal(setsockopt(ub_tcp_fileno(&t->client), SOL_SOCKET, SO_SNDBUF, &small, sizeof small), 0);
    assert_int_equal(setsockopt(ub_tcp_fileno(&t->server), SOL_SOCKET, SO_RCVBUF, &small, sizeof small), 0);
    int accepted = 0, refused = 0;
    for (int i = 0; i < 100000 && refused < 5; i++) {
        int rc = ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, now);
        assert_true(rc == 0 || rc == 1);
        if (rc == 1) accepted++;
        else refused++;
    }
    assert_int_equal(refused, 5);
    assert_true(accepted > 0);
    assert_true(ub_tcp_tx_pending(&t->client) > 0);
    assert_int_equal(ub_tcp_stats(&t->client)->backpressure, 5);
    assert_int_equal(ub_node_link(p->pub_node, p->pub_link)->counters.drops[UB_DROP_BACKPRESSURE], 5);
    /* Now the server reads: every accepted frame arrives, in order, none twice. */
    for (int i = 0; i < 5000 && p->log.n < (size_t)accepted; i++) {
        wait_ready(t, 2);
        assert_true(ub_tcp_service(&t->client, p->pub_node, now) >= 0);
        assert_true(ub_tcp_service(&t->server, p->sub_node, now) >= 0);
    }
    assert_int_equal(p->log.n, (size_t)accepted);
    assert_int_equal(ub_tcp_tx_pending(&t->client), 0);
    for (size_t i = 1; i < p->log.n; i++) assert_true(p->log.d[i].seq > p->log.d[i - 1].seq);
    assert_int_equal(ub_node_link_bad_frames(p->sub_node, p->sub_link, UB_RX_BAD_CRC), 0);
    tcp_pair_free(t);
}

/* Batching: frames collect in the transmit buffer (nothing written until flush or service), then go
 * out in one write; every one is delivered in order. */
static void test_batching_collects_frames_for_one_write(void **state) {
    (void)state;
    tcp_pair_t *t = tcp_pair_new();
    pair_t *p = t->p;
    uint64_t now = run_until_connected(t, 0);
    assert_int_equal(ub_tcp_set_batching(&t->client, 1), UB_OK);
    uint64_t bytes_before = ub_tcp_stats(&t->client)->bytes_out;
    enum { N = 10 };
    for (int i = 0; i < N; i++) assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, now), 1);
    size_t queued = ub_tcp_tx_pending(&t->client);
    assert_true(queued > 0);
    assert_int_equal(ub_tcp_stats(&t->client)->bytes_out, bytes_before);
    assert_int_equal(ub_tcp_flush(&t->client, now), 0);
    assert_int_equal(ub_tcp_stats(&t->client)->bytes_out, bytes_before + queued);
    run(t, now, now + 50);
    assert_int_equal(delivery_count(&p->log, p->sub, TEST_GPS, 0, now + 50), N);
    assert_int_equal(ub_tcp_set_batching(NULL, 1), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_flush(NULL, 0), UB_ERR_INVAL);
    tcp_pair_free(t);
}

static void test_send_without_connection_is_counted(void **state) {
    (void)state;
    tcp_pair_t *t = tcp_pair_new();
    pair_t *p = t->p;
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0), 0);
    assert_int_equal(ub_tcp_stats(&t->client)->send_closed, 1);
    assert_int_equal(ub_node_link(p->pub_node, p->pub_link)->counters.drops[UB_DROP_TX_ERROR], 1);
    assert_int_equal(ub_tcp_client_init(&t->client, "127.0.0.1", 0, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_client_init(&t->client, "localhost", 1, NULL), UB_ERR_INVAL);
    tcp_pair_free(t);
}

/* Serves the server end until `cond` holds (bounded in steps and real time). */
#define SERVE_SERVER_UNTIL(t, now, cond)                                          \
    for (int i_ = 0; i_ < 2000 && !(cond); i_++) {                                \
        wait_ready(t, 2);                                                         \
        assert_true(ub_tcp_service(&(t)->server, (t)->p->sub_node, (now)++) >= 0); \
    }                                                                             \
    assert_true(cond)

/* A peer that half-closes (shutdown(SHUT_WR) with its socket kept open: it will never send again) in the
 * middle of a frame: the server sees the end of the stream, counts the disconnect and closes its socket at
 * once (nothing left to poll, so no busy loop); the cut frame's bytes stay accounted in the slot's decoder.
 * A client whose server half-closes does the same and reconnects on its backoff. */
static void test_peer_half_close_is_a_lost_connection(void **state) {
    (void)state;
    tcp_pair_t *t = tcp_pair_new();
    uint64_t now = 0;
    int raw = socket(AF_INET, SOCK_STREAM, 0);
    assert_true(raw >= 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons(t->port)};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    assert_int_equal(connect(raw, (struct sockaddr *)&a, sizeof a), 0);
    SERVE_SERVER_UNTIL(t, now, ub_tcp_state(&t->server) == UB_TCP_UP);
    uint8_t frame[UB_FRAME_MAX];
    ub_frame_header_t h = {.hop_limit = 1, .payload_size = 40};
    int n = ub_frame_finish(frame, sizeof frame, &h);
    assert_true(n > 30);
    assert_int_equal(send(raw, frame, 30, 0), 30);
    const ub_link_t *l = ub_node_link(t->p->sub_node, t->p->sub_link);
    SERVE_SERVER_UNTIL(t, now, l->decoder.stats.bytes_in == 30);
    assert_int_equal(shutdown(raw, SHUT_WR), 0);
    SERVE_SERVER_UNTIL(t, now, ub_tcp_stats(&t->server)->disconnects == 1);
    assert_int_equal(ub_tcp_state(&t->server), UB_TCP_DOWN);
    assert_int_equal(ub_tcp_fileno(&t->server), -1);
    assert_true(ub_tcp_listen_fileno(&t->server) >= 0); /* still listening for the next peer */
    const ub_decoder_stats_t *d = &l->decoder.stats;
    assert_int_equal(d->bytes_in, d->bytes_ok + d->garbage_bytes + ub_decoder_pending(&l->decoder));
    close(raw);

    /* The client side: a server that accepts, then half-closes. */
    int lsock = socket(AF_INET, SOCK_STREAM, 0);
    assert_true(lsock >= 0);
    struct sockaddr_in la = {.sin_family = AF_INET};
    la.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof la;
    assert_int_equal(bind(lsock, (struct sockaddr *)&la, sizeof la), 0);
    assert_int_equal(listen(lsock, 1), 0);
    assert_int_equal(getsockname(lsock, (struct sockaddr *)&la, &len), 0);
    ub_tcp_t c;
    ub_tcp_options_t opt = {.backoff_initial_ms = 50, .backoff_max_ms = 400};
    assert_int_equal(ub_tcp_client_init(&c, "127.0.0.1", ntohs(la.sin_port), &opt), UB_OK);
    assert_int_equal(ub_tcp_attach(&c, t->p->pub_node, t->p->pub_link), UB_OK);
    for (int i = 0; i < 2000 && ub_tcp_state(&c) != UB_TCP_UP; i++) {
        (void)poll(&(struct pollfd){.fd = ub_tcp_fileno(&c), .events = POLLOUT}, 1, 2);
        assert_true(ub_tcp_service(&c, t->p->pub_node, now) >= 0);
    }
    assert_int_equal(ub_tcp_state(&c), UB_TCP_UP);
    int peer = accept(lsock, NULL, NULL);
    assert_true(peer >= 0);
    assert_int_equal(shutdown(peer, SHUT_WR), 0);
    for (int i = 0; i < 2000 && ub_tcp_stats(&c)->disconnects == 0; i++) {
        (void)poll(&(struct pollfd){.fd = ub_tcp_fileno(&c), .events = POLLIN}, 1, 2);
        assert_true(ub_tcp_service(&c, t->p->pub_node, now) >= 0);
    }
    assert_int_equal(ub_tcp_stats(&c)->disconnects, 1);
    assert_int_equal(ub_tcp_state(&c), UB_TCP_DOWN);
    assert_int_equal(ub_tcp_fileno(&c), -1);
    /* The next attempt waits for the backoff. */
    uint64_t attempts = ub_tcp_stats(&c)->attempts;
    assert_true(ub_tcp_service(&c, t->p->pub_node, now + 49) >= 0);
    assert_int_equal(ub_tcp_stats(&c)->attempts, attempts);
    assert_true(ub_tcp_service(&c, t->p->pub_node, now + 50) >= 0);
    assert_int_equal(ub_tcp_stats(&c)->attempts, attempts + 1);
    ub_tcp_close(&c);
    close(peer);
    close(lsock);
    tcp_pair_free(t);
}

/* Transport evidence: the peer's close (FIN) or reset reaches the node's services as a link event DOWN on the
 * server's link during the service call that saw it, and the next connection as UP (docs/routing.md,
 * "Transport evidence": the routing engine takes the link down at once instead of after two missed hellos). */
static void test_close_and_reset_are_link_events(void **state) {
    (void)state;
    tcp_pair_t *t = tcp_pair_new();
    link_events_t ev_server, ev_client;
    assert_int_equal(link_events_attach(&ev_server, t->p->sub_node), UB_OK);
    assert_int_equal(link_events_attach(&ev_client, t->p->pub_node), UB_OK);
    uint64_t now = run_until_connected(t, 0);
    assert_true(ev_server.ups >= 1);
    assert_true(ev_client.ups >= 1);
    assert_int_equal(ev_server.downs, 0);
    /* Orderly close by the client: the server hears FIN. */
    ub_tcp_close(&t->client);
    for (int i = 0; i < 2000 && ev_server.downs == 0; i++) {
        wait_ready(t, 2);
        ub_node_tick(t->p->sub_node, now);
        assert_true(ub_tcp_service(&t->server, t->p->sub_node, now++) >= 0);
    }
    assert_int_equal(ev_server.downs, 1);
    assert_int_equal(ev_server.last_link, t->p->sub_link);
    /* A reset: a raw peer that closes with SO_LINGER 0 sends RST. */
    int raw = socket(AF_INET, SOCK_STREAM, 0);
    assert_true(raw >= 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons(t->port)};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    assert_int_equal(connect(raw, (struct sockaddr *)&a, sizeof a), 0);
    for (int i = 0; i < 2000 && ub_tcp_state(&t->server) != UB_TCP_UP; i++) {
        wait_ready(t, 2);
        assert_true(ub_tcp_service(&t->server, t->p->sub_node, now++) >= 0);
    }
    int ups = ev_server.ups;
    assert_true(ups >= 2);
    struct linger lg = {.l_onoff = 1, .l_linger = 0};
    assert_int_equal(setsockopt(raw, SOL_SOCKET, SO_LINGER, &lg, sizeof lg), 0);
    close(raw);
    for (int i = 0; i < 2000 && ev_server.downs == 1; i++) {
        wait_ready(t, 2);
        assert_true(ub_tcp_service(&t->server, t->p->sub_node, now++) >= 0);
    }
    assert_int_equal(ev_server.downs, 2);
    assert_int_equal(ub_tcp_state(&t->server), UB_TCP_DOWN);
    tcp_pair_free(t);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_two_nodes_exchange_over_tcp),
        cmocka_unit_test(test_server_restart_client_reconnects),
        cmocka_unit_test(test_reconnect_backoff_follows_the_injected_clock),
        cmocka_unit_test(test_full_transmit_buffer_is_backpressure),
        cmocka_unit_test(test_batching_collects_frames_for_one_write),
        cmocka_unit_test(test_send_without_connection_is_counted),
        cmocka_unit_test(test_peer_half_close_is_a_lost_connection),
        cmocka_unit_test(test_close_and_reset_are_link_events),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/*
 * The UDP driver over 127.0.0.1: two nodes run a subscription over real
 * sockets (request one way, DATA the other), bad datagrams are counted by
 * reason, datagrams from a stranger are ignored and counted; links that learn
 * their peers from the node's verdict (accept=learn, accept=any).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <arpa/inet.h>
#include <stdlib.h>
#include <stdio.h>
#include <poll.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "support/ub_test_link_events.h"
#include "support/ub_test_pair.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_sec.h"
#include "ub/ub_udp.h"

typedef struct udp_pair {
    pair_t *p;
    ub_udp_t a; /* pub side */
    ub_udp_t b; /* sub side */
    uint16_t port_a, port_b;
} udp_pair_t;

static udp_pair_t *udp_pair_new(void) {
    udp_pair_t *u = calloc(1, sizeof *u);
    assert_non_null(u);
    u->p = pair_new(NULL);
    assert_int_equal(ub_udp_open(&u->a, "127.0.0.1", 0, "127.0.0.1", 9), UB_OK);
    assert_int_equal(ub_udp_open(&u->b, "127.0.0.1", 0, "127.0.0.1", 9), UB_OK);
    assert_int_equal(ub_udp_local_port(&u->a, &u->port_a), UB_OK);
    assert_int_equal(ub_udp_local_port(&u->b, &u->port_b), UB_OK);
    assert_int_equal(ub_udp_set_peer(&u->a, "127.0.0.1", u->port_b), UB_OK);
    assert_int_equal(ub_udp_set_peer(&u->b, "127.0.0.1", u->port_a), UB_OK);
    assert_int_equal(ub_udp_attach(&u->a, u->p->pub_node, u->p->pub_link), UB_OK);
    assert_int_equal(ub_udp_attach(&u->b, u->p->sub_node, u->p->sub_link), UB_OK);
    return u;
}

static void udp_pair_free(udp_pair_t *u) {
    ub_udp_close(&u->a);
    ub_udp_close(&u->b);
    pair_free(u->p);
    free(u);
}

/* One simulated millisecond: tick both nodes, then serve both sockets (loopback UDP delivers within sendto()). */
static void step(udp_pair_t *u, uint64_t now_ms) {
    ub_node_tick(u->p->pub_node, now_ms);
    ub_node_tick(u->p->sub_node, now_ms);
    assert_true(ub_udp_service(&u->a, u->p->pub_node, now_ms) >= 0);
    assert_true(ub_udp_service(&u->b, u->p->sub_node, now_ms) >= 0);
}

static void run(udp_pair_t *u, uint64_t from_ms, uint64_t to_ms) {
    for (uint64_t t = from_ms; t < to_ms; t++) step(u, t);
}

static void test_two_nodes_exchange_over_udp(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    pair_t *p = u->p;
    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, 0) >= 0);
    run(u, 0, 1000);
    /* About 19 DATA frames at 50 ms in the second after the request; allow a few for timing. */
    size_t got = delivery_count(&p->log, p->sub, TEST_GPS, 0, 1000);
    assert_in_range(got, 15, 21);
    assert_memory_equal(&p->gps_dst, &p->gps_src, sizeof p->gps_src);
    const ub_link_counters_t *pub = &ub_node_link(p->pub_node, p->pub_link)->counters;
    const ub_link_counters_t *sub = &ub_node_link(p->sub_node, p->sub_link)->counters;
    assert_true(pub->frames_in >= 1);                  /* the subscription request */
    assert_int_equal(sub->frames_in, pub->frames_out); /* nothing lost on loopback */
    assert_int_equal(u->a.stats.datagrams_out, pub->frames_out);
    assert_int_equal(u->b.stats.datagrams_in, sub->frames_in);
    assert_int_equal(u->b.stats.rejected, 0);
    udp_pair_free(u);
}

static void send_raw(int fd, uint16_t port, const uint8_t *bytes, size_t len) {
    struct sockaddr_in to = {.sin_family = AF_INET, .sin_port = htons(port)};
    assert_int_equal(inet_pton(AF_INET, "127.0.0.1", &to.sin_addr), 1);
    assert_int_equal(sendto(fd, bytes, len, 0, (const struct sockaddr *)&to, sizeof to), (ssize_t)len);
}

static void test_bad_and_foreign_datagrams_are_counted(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    pair_t *p = u->p;
    assert_true(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0) == 1);
    run(u, 0, 20);
    assert_int_equal(p->log.n, 1);
    uint8_t frame[UB_FRAME_MAX];
    const uint8_t dir_id[UB_DIR_ID_LEN] = {0};
    size_t len = make_frame(frame, UB_ADMIN_DATA, dir_id, "pub", "sub", 99, 8, 0, NULL, 0);
    assert_true(len > 0);
    uint8_t bad_crc[UB_FRAME_MAX];
    memcpy(bad_crc, frame, len);
    bad_crc[len - 1] ^= 0x40;
    const uint8_t garbage[] = "hello, not a frame";
    int from_peer = ub_udp_fileno(&u->a); /* the peer's own socket: these pass the source filter */
    send_raw(from_peer, u->port_b, bad_crc, len);
    send_raw(from_peer, u->port_b, garbage, sizeof garbage);
    send_raw(from_peer, u->port_b, frame, len - 3);
    ub_udp_t stranger;
    assert_int_equal(ub_udp_open(&stranger, "127.0.0.1", 0, "127.0.0.1", u->port_b), UB_OK);
    send_raw(ub_udp_fileno(&stranger), u->port_b, frame, len);
    run(u, 20, 60);
    assert_int_equal(ub_node_link_bad_frames(p->sub_node, p->sub_link, UB_RX_BAD_CRC), 1);
    assert_int_equal(ub_node_link_bad_frames(p->sub_node, p->sub_link, UB_RX_BAD_SYNC), 1);
    assert_int_equal(ub_node_link_bad_frames(p->sub_node, p->sub_link, UB_RX_BAD_LENGTH), 1);
    assert_int_equal(u->b.stats.rejected, 3);
    assert_int_equal(u->b.stats.foreign, 1);
    assert_int_equal(p->log.n, 1); /* the stranger's valid frame was not delivered */
    ub_udp_close(&stranger);
    udp_pair_free(u);
}

typedef struct foreign_log {
    uint8_t bytes[256];
    size_t len;
    unsigned runs;
    size_t take; /* bytes taken of each run */
} foreign_log_t;

static size_t collect_foreign(void *user, const uint8_t *run, size_t len) {
    foreign_log_t *f = user;
    assert_true(f->len + len <= sizeof f->bytes);
    memcpy(f->bytes + f->len, run, len);
    f->len += len;
    f->runs++;
    return len < f->take ? len : f->take;
}

/* Foreign traffic on a datagram link (#24): a datagram from the peer that is not uavbus goes to the link's
 * handler whole (not to the node's bad_sync); damaged uavbus datagrams are still the node's; a frame is
 * never handed on; a stranger's datagram is still refused by the peer rule before anything else. */
static void test_non_uavbus_datagrams_go_to_the_foreign_handler(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    pair_t *p = u->p;
    foreign_log_t f = {.take = 10};
    assert_int_equal(ub_udp_set_foreign(&u->b, collect_foreign, &f), UB_OK);
    uint8_t frame[UB_FRAME_MAX];
    const uint8_t dir_id[UB_DIR_ID_LEN] = {0};
    size_t len = make_frame(frame, UB_ADMIN_DATA, dir_id, "pub", "sub", 99, 8, 0, NULL, 0);
    assert_true(len > 0);
    const char gga[] = "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n";
    int from_peer = ub_udp_fileno(&u->a);
    send_raw(from_peer, u->port_b, (const uint8_t *)gga, sizeof gga - 1);
    send_raw(from_peer, u->port_b, frame, len - 3); /* damaged uavbus: the node's */
    send_raw(from_peer, u->port_b, (const uint8_t *)"X", 1);
    ub_udp_t stranger;
    assert_int_equal(ub_udp_open(&stranger, "127.0.0.1", 0, "127.0.0.1", u->port_b), UB_OK);
    send_raw(ub_udp_fileno(&stranger), u->port_b, (const uint8_t *)gga, sizeof gga - 1);
    run(u, 0, 20);
    assert_int_equal(f.runs, 2);
    assert_int_equal(f.len, sizeof gga - 1 + 1);
    assert_memory_equal(f.bytes, gga, sizeof gga - 1);
    assert_int_equal(f.bytes[sizeof gga - 1], 'X');
    assert_int_equal(u->b.stats.foreign_datagrams, 2);
    assert_int_equal(u->b.stats.foreign_refused, (sizeof gga - 1) - 10); /* "X" was taken whole */
    assert_int_equal(u->b.stats.foreign, 1);                              /* the stranger */
    assert_int_equal(ub_node_link_bad_frames(p->sub_node, p->sub_link, UB_RX_BAD_SYNC), 0);
    assert_int_equal(ub_node_link_bad_frames(p->sub_node, p->sub_link, UB_RX_BAD_LENGTH), 1);
    /* Frames still reach the node, never the handler; without a handler, text is bad_sync again. */
    assert_true(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 20) == 1);
    run(u, 20, 40);
    assert_int_equal(p->log.n, 1);
    assert_int_equal(f.runs, 2);
    assert_int_equal(ub_udp_set_foreign(&u->b, NULL, NULL), UB_OK);
    send_raw(from_peer, u->port_b, (const uint8_t *)gga, sizeof gga - 1);
    run(u, 40, 60);
    assert_int_equal(f.runs, 2);
    assert_int_equal(ub_node_link_bad_frames(p->sub_node, p->sub_link, UB_RX_BAD_SYNC), 1);
    assert_int_equal(ub_udp_set_foreign(NULL, NULL, NULL), UB_ERR_INVAL);
    ub_udp_close(&stranger);
    udp_pair_free(u);
}

/* Batching: frames queue (nothing on the wire until a flush or a service), go out coalesced into a
 * few datagrams, and every one of them is delivered; the frame counters tell frames from datagrams. */
static void test_batching_coalesces_frames_into_few_datagrams(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    pair_t *p = u->p;
    assert_int_equal(ub_udp_set_batching(&u->a, 1), UB_OK);
    enum { N = 30 };
    for (int i = 0; i < N; i++) assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0), 1);
    assert_int_equal(ub_udp_tx_pending(&u->a), N);
    assert_int_equal(u->a.stats.datagrams_out, 0);
    assert_int_equal(ub_udp_flush(&u->a), 0);
    assert_int_equal(ub_udp_tx_pending(&u->a), 0);
    run(u, 1, 5);
    assert_int_equal(delivery_count(&p->log, p->sub, TEST_GPS, 0, 5), N);
    assert_int_equal(u->a.stats.frames_out, N);
    assert_true(u->a.stats.datagrams_out >= 2 && u->a.stats.datagrams_out < N / 4);
    assert_true(u->a.stats.tx_calls <= 2);
    assert_int_equal(u->b.stats.datagrams_in, u->a.stats.datagrams_out);
    assert_int_equal(u->b.stats.frames_in, N);
    assert_int_equal(u->b.stats.rejected, 0);
    /* Off again: the next frame is its own datagram, sent at once. */
    assert_int_equal(ub_udp_set_batching(&u->a, 0), UB_OK);
    uint64_t before = u->a.stats.datagrams_out;
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 5), 1);
    assert_int_equal(u->a.stats.datagrams_out, before + 1);
    udp_pair_free(u);
}

/* A multi-frame datagram with a corrupt frame in the middle: the good ones still pass, the bad one is
 * counted by reason, and a tail that is not a whole frame is rejected too. */
static void test_multi_frame_datagram_with_a_bad_frame(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    pair_t *p = u->p;
    const uint8_t dir_id[UB_DIR_ID_LEN] = {0};
    uint8_t dgram[4 * 100];
    size_t a = make_frame(dgram, UB_ADMIN_DATA, dir_id, "pub", "sub", 200, 8, 0, NULL, 0);
    size_t b = make_frame(dgram + a, UB_ADMIN_DATA, dir_id, "pub", "sub", 201, 8, 0, NULL, 0);
    dgram[a + b - 1] ^= 0x01;
    size_t c = make_frame(dgram + a + b, UB_ADMIN_DATA, dir_id, "pub", "sub", 202, 8, 0, NULL, 0);
    memcpy(dgram + a + b + c, "tail", 4);
    send_raw(ub_udp_fileno(&u->a), u->port_b, dgram, a + b + c + 4);
    run(u, 0, 5);
    assert_int_equal(ub_node_link(p->sub_node, p->sub_link)->counters.frames_in, 2);
    assert_int_equal(ub_node_link_bad_frames(p->sub_node, p->sub_link, UB_RX_BAD_CRC), 1);
    assert_int_equal(u->b.stats.datagrams_in, 1);
    assert_int_equal(u->b.stats.frames_in, 4);
    assert_int_equal(u->b.stats.rejected, 2);
    udp_pair_free(u);
}

/* A third socket, not attached to any node, that sends raw frames and counts what it receives. */
static int count_received(ub_udp_t *s) {
    uint8_t buf[2048];
    int n = 0;
    while (recv(ub_udp_fileno(s), buf, sizeof buf, MSG_DONTWAIT) > 0) n++;
    return n;
}

static size_t frame_from_pub(uint8_t *buf, uint32_t seq) {
    const uint8_t dir_id[UB_DIR_ID_LEN] = {0}; /* unknown content: accepted, then dropped unknown_content */
    return make_frame(buf, UB_ADMIN_DATA, dir_id, "pub", "sub", seq, 8, 0, NULL, 0);
}

/* accept=learn: no peer -> sends are no_route; garbage teaches nothing; the first accepted frame's sender
 * becomes the peer; a duplicate from elsewhere does not move it; a new accepted frame from elsewhere does. */
static void test_learn_takes_the_sender_of_accepted_frames(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    pair_t *p = u->p;
    ub_udp_close(&u->b);
    assert_int_equal(ub_udp_open(&u->b, "127.0.0.1", u->port_b, NULL, 0), UB_OK);
    assert_int_equal(ub_udp_set_accept(&u->b, UB_UDP_ACCEPT_LEARN), UB_OK);
    assert_int_equal(ub_udp_attach(&u->b, p->sub_node, p->sub_link), UB_OK);
    /* Nobody to send to yet: refused, counted by the driver and by the node as no_route. */
    assert_int_equal(ub_node_send_data(p->sub_node, p->sub, TEST_GPS, p->pub_id, 0), 0);
    assert_int_equal(u->b.stats.no_peer, 1);
    assert_int_equal(ub_node_link(p->sub_node, p->sub_link)->counters.drops[UB_DROP_NO_ROUTE], 1);

    ub_udp_t c;
    uint16_t port_c;
    assert_int_equal(ub_udp_open(&c, "127.0.0.1", 0, "127.0.0.1", u->port_b), UB_OK);
    assert_int_equal(ub_udp_local_port(&c, &port_c), UB_OK);
    send_raw(ub_udp_fileno(&c), u->port_b, (const uint8_t *)"not a frame", 11);
    run(u, 1, 3);
    char host[16];
    uint16_t port = 0;
    assert_int_equal(ub_udp_peer_at(&u->b, 0, host, &port), UB_ERR_NOTFOUND); /* refused: not learned */

    uint8_t f1[UB_FRAME_MAX], f2[UB_FRAME_MAX];
    size_t n1 = frame_from_pub(f1, 1000), n2 = frame_from_pub(f2, 1001);
    send_raw(ub_udp_fileno(&u->a), u->port_b, f1, n1); /* from a: accepted */
    run(u, 3, 5);
    assert_int_equal(ub_udp_peer_at(&u->b, 0, host, &port), UB_OK);
    assert_int_equal(port, u->port_a);
    assert_int_equal(u->b.stats.peers_learned, 1);
    send_raw(ub_udp_fileno(&c), u->port_b, f1, n1); /* the same frame from c: a duplicate */
    run(u, 5, 7);
    assert_int_equal(ub_udp_peer_at(&u->b, 0, host, &port), UB_OK);
    assert_int_equal(port, u->port_a);
    send_raw(ub_udp_fileno(&c), u->port_b, f2, n2); /* a new frame from c: the peer moves */
    run(u, 7, 9);
    assert_int_equal(ub_udp_peer_at(&u->b, 0, host, &port), UB_OK);
    assert_int_equal(port, port_c);
    assert_int_equal(ub_udp_peer_at(&u->b, 1, host, &port), UB_ERR_NOTFOUND); /* one peer only */
    assert_int_equal(ub_node_send_data(p->sub_node, p->sub, TEST_GPS, p->pub_id, 9), 1);
    assert_int_equal(count_received(&c), 1);
    assert_int_equal(u->b.stats.foreign, 0);
    /* A peer configured now takes the first place; the learned one moves to the next, kept. */
    assert_int_equal(ub_udp_set_peer(&u->b, "127.0.0.1", u->port_a), UB_OK);
    assert_int_equal(ub_udp_peer_at(&u->b, 0, host, &port), UB_OK);
    assert_int_equal(port, u->port_a);
    assert_int_equal(ub_udp_peer_at(&u->b, 1, host, &port), UB_OK);
    assert_int_equal(port, port_c);
    assert_int_equal(ub_udp_set_peer(&u->b, "not-an-address", 5), UB_ERR_INVAL);
    ub_udp_close(&c);
    udp_pair_free(u);
}

/* accept=any: every sender of a genuine frame is a peer and gets every frame; an idle one is forgotten. */
static void test_any_serves_several_peers(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    pair_t *p = u->p;
    ub_udp_close(&u->b);
    assert_int_equal(ub_udp_open(&u->b, "127.0.0.1", u->port_b, NULL, 0), UB_OK); /* any, by default */
    assert_int_equal(ub_udp_attach(&u->b, p->sub_node, p->sub_link), UB_OK);
    ub_udp_t c;
    assert_int_equal(ub_udp_open(&c, "127.0.0.1", 0, "127.0.0.1", u->port_b), UB_OK);
    uint8_t f1[UB_FRAME_MAX];
    size_t n1 = frame_from_pub(f1, 2000);
    send_raw(ub_udp_fileno(&u->a), u->port_b, f1, n1);
    send_raw(ub_udp_fileno(&c), u->port_b, f1, n1); /* a copy (duplicate): genuine, so c is a peer too */
    run(u, 1, 3);
    assert_int_equal(u->b.stats.peers_learned, 2);
    uint64_t out_before = u->b.stats.datagrams_out;
    assert_int_equal(ub_node_send_data(p->sub_node, p->sub, TEST_GPS, p->pub_id, 3), 1);
    assert_int_equal(u->b.stats.datagrams_out, out_before + 2);
    assert_int_equal(count_received(&c), 1);
    /* a keeps talking (the pair's subscription would); c falls silent and is forgotten. */
    uint8_t f2[UB_FRAME_MAX];
    size_t n2 = frame_from_pub(f2, 2001);
    run(u, 3, 4);
    send_raw(ub_udp_fileno(&u->a), u->port_b, f2, n2);
    assert_true(ub_udp_service(&u->b, p->sub_node, UB_UDP_PEER_IDLE_MS - 1) >= 0);
    assert_true(ub_udp_service(&u->b, p->sub_node, UB_UDP_PEER_IDLE_MS + 2) >= 0);
    char host[16];
    uint16_t port = 0;
    assert_int_equal(ub_udp_peer_at(&u->b, 0, host, &port), UB_OK);
    assert_int_equal(port, u->port_a);
    assert_int_equal(ub_udp_peer_at(&u->b, 1, host, &port), UB_ERR_NOTFOUND);
    assert_int_equal(u->b.stats.peers_forgotten, 1);
    ub_udp_close(&c);
    udp_pair_free(u);
}

/* accept=any past UB_UDP_MAX_PEERS senders: the least recently heard peer makes room for the newcomer
 * (counted forgotten), so the table never overflows and the newest sender is served. */
static void test_any_beyond_the_peer_table(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    pair_t *p = u->p;
    ub_udp_close(&u->b);
    assert_int_equal(ub_udp_open(&u->b, "127.0.0.1", u->port_b, NULL, 0), UB_OK);
    assert_int_equal(ub_udp_attach(&u->b, p->sub_node, p->sub_link), UB_OK);
    ub_udp_t s[UB_UDP_MAX_PEERS + 1];
    uint16_t last_port = 0;
    for (int i = 0; i <= UB_UDP_MAX_PEERS; i++) {
        assert_int_equal(ub_udp_open(&s[i], "127.0.0.1", 0, "127.0.0.1", u->port_b), UB_OK);
        assert_int_equal(ub_udp_local_port(&s[i], &last_port), UB_OK);
        uint8_t f[UB_FRAME_MAX];
        size_t n = frame_from_pub(f, 4000u + (uint32_t)i);
        send_raw(ub_udp_fileno(&s[i]), u->port_b, f, n);
        run(u, 1u + 2u * (uint64_t)i, 2u + 2u * (uint64_t)i);
    }
    /* Each eviction counted once: learned - forgotten is what the table holds. Before, an eviction under
     * accept=any was counted twice (in learn() and again in put_learned()): 5 learned, 2 forgotten, 4 held. */
    assert_int_equal(u->b.stats.peers_learned, UB_UDP_MAX_PEERS + 1);
    assert_int_equal(u->b.stats.peers_forgotten, 1);
    char host[16];
    uint16_t port = 0;
    bool newest = false;
    for (int k = 0; ub_udp_peer_at(&u->b, k, host, &port) == UB_OK; k++) newest = newest || port == last_port;
    assert_true(newest);
    for (int i = 0; i <= UB_UDP_MAX_PEERS; i++) ub_udp_close(&s[i]);
    udp_pair_free(u);
}

/* accept=peer (the default with a peer): a stranger's valid frame is refused, counted, and its address
 * kept for the one-time report. */
static void test_refused_sender_is_remembered(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    ub_udp_t stranger;
    uint16_t port_s;
    assert_int_equal(ub_udp_open(&stranger, "127.0.0.1", 0, "127.0.0.1", u->port_b), UB_OK);
    assert_int_equal(ub_udp_local_port(&stranger, &port_s), UB_OK);
    uint8_t f[UB_FRAME_MAX];
    size_t n = frame_from_pub(f, 3000);
    send_raw(ub_udp_fileno(&stranger), u->port_b, f, n);
    send_raw(ub_udp_fileno(&stranger), u->port_b, f, n);
    run(u, 0, 3);
    assert_int_equal(u->b.stats.foreign, 2);
    assert_int_equal(ntohs(u->b.refused_from.sin_port), port_s);
    assert_int_equal(u->b.stats.peers_learned, 0);
    /* The one-time notice names the sender, the peer and what to do. */
    char notice[512], want[32];
    assert_int_equal(ub_udp_driver.notice(&u->b, "subPort", notice, sizeof notice), 1);
    snprintf(want, sizeof want, "127.0.0.1:%u", (unsigned)port_s);
    assert_non_null(strstr(notice, want));
    assert_non_null(strstr(notice, "accept=any"));
    ub_udp_close(&stranger);
    udp_pair_free(u);
}

/* ---- signed links: provisional peers ---------------------------------------------------------- */

static const uint8_t FLEET_KEY[UB_SEC_KEY_LEN] = {7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7,
                                                  7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 1};

/* A signed frame (a key holder's, or a captured one) from entity "ghost", whose freshness `to` has not seen. */
static size_t ghost_frame(ub_sec_t *sec, const uint8_t to[UB_ENTITY_ID_LEN], uint8_t *out) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dest_id, to, UB_ENTITY_ID_LEN);
    memcpy(h.src_id, "ghost", 5);
    h.admin = UB_ADMIN_DATA;
    h.hop_limit = 8;
    h.payload_size = 4;
    h.flags = UB_FRAME_FLAG_SIGNED;
    h.key_id = 1;
    h.seq = 77;
    h.counter_hi = 3;
    static const uint8_t payload[4] = {1, 2, 3, 4};
    int n = ub_sec_protect(sec, &h, payload, out, UB_FRAME_MAX);
    assert_true(n > 0);
    return (size_t)n;
}

/*
 * A link that requires signed frames and learns its peers: the first frame of a new sender is unverified
 * (its source gets a challenge), so the sender becomes a provisional peer -- the challenge must reach it --
 * and is confirmed by its first accepted frame. An address that proves nothing (here: an authentic frame
 * of a source that never answers its challenge) is forgotten after UB_UDP_PROVISIONAL_MS, and never takes
 * a confirmed peer's place.
 */
static void test_signed_link_learns_provisional_peers(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    pair_t *p = u->p;
    static ub_sec_t sa, sb, sx;
    test_sec_on(&sa, p->pub_node, FLEET_KEY, 1000, true);
    test_sec_on(&sb, p->sub_node, FLEET_KEY, 5000, true);
    test_sec_on(&sx, NULL, FLEET_KEY, 9000, true);
    ub_udp_close(&u->a); /* the publisher ("vehicle") learns its peers: accept=any */
    assert_int_equal(ub_udp_open(&u->a, "127.0.0.1", u->port_a, NULL, 0), UB_OK);
    assert_int_equal(ub_udp_attach(&u->a, p->pub_node, p->pub_link), UB_OK);
    assert_true(ub_node_link_requires_signed(p->pub_node, p->pub_link));

    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, 0) >= 0);
    run(u, 0, 3);
    char host[16];
    uint16_t port = 0;
    assert_int_equal(ub_udp_peer_at(&u->a, 0, host, &port), UB_OK);
    assert_int_equal(port, u->port_b);
    assert_true(u->a.peers[0].provisional_until_ms != 0);           /* unverified first frame */
    assert_int_equal(ub_node_link(p->pub_node, p->pub_link)->counters.drops[UB_DROP_UNVERIFIED], 1);
    run(u, 3, 2500);
    assert_int_equal(u->a.peers[0].provisional_until_ms, 0);        /* confirmed by an accepted frame */
    assert_true(delivery_count(&p->log, p->sub, TEST_GPS, 0, 2500) >= 10);

    /* A stranger with an authentic frame of a source that never proves its freshness. */
    ub_udp_t c;
    uint16_t port_c;
    assert_int_equal(ub_udp_open(&c, "127.0.0.1", 0, "127.0.0.1", u->port_a), UB_OK);
    assert_int_equal(ub_udp_local_port(&c, &port_c), UB_OK);
    uint8_t f[UB_FRAME_MAX];
    size_t n = ghost_frame(&sx, p->pub_id, f);
    send_raw(ub_udp_fileno(&c), u->port_a, f, n);
    run(u, 2500, 2502);
    assert_int_equal(ub_udp_peer_at(&u->a, 1, host, &port), UB_OK);
    assert_int_equal(port, port_c);
    assert_true(u->a.peers[1].provisional_until_ms != 0);
    uint64_t forgotten = u->a.stats.peers_forgotten;
    run(u, 2502, 2502 + UB_UDP_PROVISIONAL_MS + 2);
    assert_int_equal(ub_udp_peer_at(&u->a, 1, host, &port), UB_ERR_NOTFOUND);
    assert_int_equal(u->a.stats.peers_forgotten, forgotten + 1);
    assert_int_equal(ub_udp_peer_at(&u->a, 0, host, &port), UB_OK); /* the confirmed peer stays */
    assert_int_equal(port, u->port_b);

    /* accept=learn: one peer; an unverified stranger does not take the confirmed one's place. */
    assert_int_equal(ub_udp_set_accept(&u->a, UB_UDP_ACCEPT_LEARN), UB_OK);
    send_raw(ub_udp_fileno(&c), u->port_a, f, n);
    run(u, 4600, 4602);
    assert_int_equal(ub_udp_peer_at(&u->a, 0, host, &port), UB_OK);
    assert_int_equal(port, u->port_b);
    assert_int_equal(ub_udp_peer_at(&u->a, 1, host, &port), UB_ERR_NOTFOUND);
    ub_udp_close(&c);
    udp_pair_free(u);
}

static void test_argument_errors(void **state) {
    (void)state;
    ub_udp_t u;
    assert_int_equal(ub_udp_open(&u, "not an address", 0, "127.0.0.1", 1), UB_ERR_INVAL);
    assert_int_equal(ub_udp_open(&u, "127.0.0.1", 0, "127.0.0.1", 0), UB_ERR_INVAL); /* peer port 0 */
    assert_int_equal(ub_udp_fileno(&u), -1);
    assert_int_equal(ub_udp_open(&u, "127.0.0.1", 0, NULL, 0), UB_OK); /* no peer: learns them */
    assert_int_equal(u.accept, UB_UDP_ACCEPT_ANY);
    assert_int_equal(ub_udp_set_accept(&u, UB_UDP_ACCEPT_PEER), UB_ERR_INVAL); /* no peer to keep to */
    assert_int_equal(ub_udp_set_accept(&u, (ub_udp_accept_t)7), UB_ERR_INVAL);
    char host[16];
    uint16_t port;
    assert_int_equal(ub_udp_peer_at(&u, 0, host, &port), UB_ERR_NOTFOUND);
    ub_udp_close(&u);
    assert_int_equal(ub_udp_open(&u, "127.0.0.1", 0, "127.0.0.1", 1), UB_OK);
    assert_int_equal(ub_udp_service(&u, NULL, 0), UB_ERR_INVAL); /* not attached */
    ub_udp_close(&u);
    ub_udp_close(&u);
    assert_int_equal(ub_udp_fileno(&u), -1);
}

/* Transport evidence: the peer's socket is gone, so the kernel answers our datagram with ICMP "port unreachable";
 * it surfaces as ECONNREFUSED on the next receive (IP_RECVERR) and reaches the node's services as a link event
 * DOWN on the link, counted `refused` -- where before only two missed hellos said so. */
static void test_icmp_unreachable_is_a_link_event(void **state) {
    (void)state;
    udp_pair_t *u = udp_pair_new();
    pair_t *p = u->p;
    link_events_t ev;
    assert_int_equal(link_events_attach(&ev, p->pub_node), UB_OK);
    assert_true(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0) == 1);
    run(u, 0, 5);
    assert_int_equal(ev.downs, 0); /* a live peer: no evidence */
    ub_udp_close(&u->b);
    assert_true(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 5) == 1);
    for (uint64_t now = 5; now < 2000 && ev.downs == 0; now++) {
        (void)poll(&(struct pollfd){.fd = ub_udp_fileno(&u->a), .events = POLLIN}, 1, 1);
        ub_node_tick(p->pub_node, now);
        assert_true(ub_udp_service(&u->a, p->pub_node, now) >= 0);
    }
    assert_true(ev.downs >= 1);
    assert_int_equal(ev.last_link, p->pub_link);
    assert_true(u->a.stats.refused >= 1);
    ub_udp_close(&u->a);
    pair_free(u->p);
    free(u);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_two_nodes_exchange_over_udp),
        cmocka_unit_test(test_bad_and_foreign_datagrams_are_counted),
        cmocka_unit_test(test_non_uavbus_datagrams_go_to_the_foreign_handler),
        cmocka_unit_test(test_batching_coalesces_frames_into_few_datagrams),
        cmocka_unit_test(test_multi_frame_datagram_with_a_bad_frame),
        cmocka_unit_test(test_learn_takes_the_sender_of_accepted_frames),
        cmocka_unit_test(test_any_serves_several_peers),
        cmocka_unit_test(test_any_beyond_the_peer_table),
        cmocka_unit_test(test_refused_sender_is_remembered),
        cmocka_unit_test(test_signed_link_learns_provisional_peers),
        cmocka_unit_test(test_argument_errors),
        cmocka_unit_test(test_icmp_unreachable_is_a_link_event),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

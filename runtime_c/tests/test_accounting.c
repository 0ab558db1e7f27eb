/*
 * Exact accounting (issue #17, item 4). Every byte a link receives ends up in exactly one place:
 *
 *   link bytes_in == decoder bytes_in + bytes of datagrams, and
 *   decoder bytes_in == bytes_ok + garbage_bytes + pending,
 *
 * and it stays so across every re-attach of the slot: a TCP reconnect, a serial reopen, a software switch
 * (rebind). Before, a re-attach dropped the decoder's partial-frame bytes without counting them (the
 * invariant broke by exactly those bytes). And every datagram that is not a frame is one rejection: before,
 * 2,000 garbage datagrams were counted as 2,029 rejections, because a random msg_size inside the garbage
 * was taken as the boundary of a batched frame and split it.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "support/ub_test_pair.h"
#include "test_frame_util.h"
#include "ub/ub_ports.h"
#include "ub/ub_tcp.h"
#include "ub/ub_udp.h"

static void assert_invariant(const ub_node_t *node, int link_id) {
    const ub_link_t *l = ub_node_link(node, link_id);
    const ub_decoder_stats_t *d = &l->decoder.stats;
    assert_int_equal(d->bytes_in, d->bytes_ok + d->garbage_bytes + ub_decoder_pending(&l->decoder));
}

static int dummy_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)impl;
    (void)frame;
    (void)len;
    (void)now_ms;
    return UB_OK;
}

static const ub_link_ops_t k_dummy_ops = {.kind = "dummy", .send = dummy_send};

/* The slot itself: bytes held at re-attach become garbage, counted; ub_node_link_set_transport (a
 * decorator, the same stream) keeps them. */
static void test_attach_counts_the_bytes_the_decoder_held(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_node_t *n = p->sub_node;
    int l = p->sub_link;
    test_rng_t rng = {42};
    uint8_t frame[UB_FRAME_MAX];
    size_t len = random_frame(&rng, frame, 100);
    assert_int_equal(ub_node_link_attach(n, l, &k_dummy_ops, NULL), UB_OK);
    assert_true(ub_node_rx(n, l, frame, len, 0) >= 0); /* one whole frame */
    assert_true(ub_node_rx(n, l, frame, 40, 0) >= 0);  /* and the start of the next */
    const ub_decoder_t *dec = &ub_node_link(n, l)->decoder;
    assert_int_equal(ub_decoder_pending(dec), 40);
    assert_int_equal(ub_node_link_set_transport(n, l, &k_dummy_ops, NULL), UB_OK);
    assert_int_equal(ub_decoder_pending(dec), 40); /* same stream: kept */
    assert_int_equal(ub_node_link_attach(n, l, &k_dummy_ops, NULL), UB_OK);
    assert_int_equal(ub_decoder_pending(dec), 0);
    assert_int_equal(dec->stats.garbage_bytes, 40);
    assert_int_equal(dec->stats.bytes_in, len + 40);
    assert_int_equal(dec->stats.frames_ok, 1);
    assert_invariant(n, l);
    pair_free(p);
}

/* Real reconnects: a TCP server slot served by successive clients, each sending whole frames and leaving
 * a frame cut in the middle when it goes away. */
static void test_invariant_holds_across_tcp_reconnects(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_tcp_t server;
    uint16_t port = 0;
    assert_int_equal(ub_tcp_server_open(&server, "127.0.0.1", 0, NULL), UB_OK);
    assert_int_equal(ub_tcp_local_port(&server, &port), UB_OK);
    assert_int_equal(ub_tcp_attach(&server, p->sub_node, p->sub_link), UB_OK);
    const ub_link_t *l = ub_node_link(p->sub_node, p->sub_link);
    test_rng_t rng = {7};
    uint64_t now = 0, sent = 0, cut = 0, frames = 0;
    for (int round = 0; round < 8; round++) {
        int c = socket(AF_INET, SOCK_STREAM, 0);
        assert_true(c >= 0);
        struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons(port)};
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        assert_int_equal(connect(c, (struct sockaddr *)&a, sizeof a), 0);
        uint8_t buf[4 * UB_FRAME_MAX];
        size_t n = 0;
        for (int k = 0; k < 3; k++) n += random_frame(&rng, buf + n, (uint16_t)rng_below(&rng, 200));
        size_t partial = 1 + rng_below(&rng, 60); /* a frame cut by the lost connection */
        n += partial;
        random_frame(&rng, buf + n - partial, 100);
        assert_int_equal(send(c, buf, n, 0), (ssize_t)n);
        close(c);
        sent += n;
        cut += partial;
        frames += 3;
        uint64_t disconnects = ub_tcp_stats(&server)->disconnects;
        for (int i = 0; i < 2000 && (l->counters.bytes_in < sent || ub_tcp_stats(&server)->disconnects == disconnects);
             i++) {
            (void)poll(&(struct pollfd){.fd = ub_tcp_listen_fileno(&server), .events = POLLIN}, 1, 1);
            (void)poll(&(struct pollfd){.fd = ub_tcp_fileno(&server), .events = POLLIN}, 1, 1);
            assert_true(ub_tcp_service(&server, p->sub_node, now++) >= 0);
        }
        assert_int_equal(l->counters.bytes_in, sent);
        assert_int_equal(l->decoder.stats.bytes_in, sent);
        assert_invariant(p->sub_node, p->sub_link);
    }
    /* The cut frames of the first seven connections were counted when the next one re-attached the slot;
     * the last one's are still held. */
    const ub_decoder_stats_t *d = &l->decoder.stats;
    assert_int_equal(d->frames_ok, frames);
    assert_int_equal(d->garbage_bytes + ub_decoder_pending(&l->decoder), cut);
    assert_int_equal(ub_tcp_stats(&server)->connects, 8);
    ub_tcp_close(&server);
    pair_free(p);
}

/* The software switch (ub_ports rebind) with a partial frame held: counted too. */
static void test_invariant_holds_across_a_rebind(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_ports_t *ports = calloc(1, sizeof *ports);
    assert_non_null(ports);
    assert_int_equal(ub_ports_init(ports, p->sub_node), UB_OK);
    char err[UB_PORTS_ERR_LEN];
    assert_int_equal(ub_ports_open_text(ports, "subPort", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9", 0, err, sizeof err),
                     UB_OK);
    test_rng_t rng = {9};
    uint8_t frame[UB_FRAME_MAX];
    size_t len = random_frame(&rng, frame, 50);
    assert_true(ub_node_rx(p->sub_node, p->sub_link, frame, len - 10, 0) >= 0);
    assert_int_equal(ub_ports_open_text(ports, "subPort", "tcp:listen=127.0.0.1:0", 0, err, sizeof err), UB_OK);
    const ub_link_t *l = ub_node_link(p->sub_node, p->sub_link);
    assert_int_equal(l->decoder.stats.garbage_bytes, len - 10);
    assert_invariant(p->sub_node, p->sub_link);
    ub_ports_close_all(ports);
    free(ports);
    pair_free(p);
}

/* Garbage datagrams: exactly one rejection each, whatever their bytes (some start with the sync word and
 * carry a plausible msg_size), and the valid frames of batched datagrams still arrive. */
static void test_each_garbage_datagram_is_one_rejection(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_udp_t udp;
    uint16_t port = 0;
    assert_int_equal(ub_udp_open(&udp, "127.0.0.1", 0, "127.0.0.1", 9), UB_OK);
    assert_int_equal(ub_udp_local_port(&udp, &port), UB_OK);
    int s = socket(AF_INET, SOCK_DGRAM, 0);
    assert_true(s >= 0);
    struct sockaddr_in me = {.sin_family = AF_INET};
    me.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t mlen = sizeof me;
    assert_int_equal(bind(s, (struct sockaddr *)&me, sizeof me), 0);
    assert_int_equal(getsockname(s, (struct sockaddr *)&me, &mlen), 0);
    assert_int_equal(ub_udp_set_peer(&udp, "127.0.0.1", ntohs(me.sin_port)), UB_OK);
    assert_int_equal(ub_udp_attach(&udp, p->sub_node, p->sub_link), UB_OK);
    struct sockaddr_in to = {.sin_family = AF_INET, .sin_port = htons(port)};
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    test_rng_t rng = {2000};
    const int garbage = 2000;
    uint64_t now = 0;
    for (int i = 0; i < garbage; i++) {
        uint8_t d[1400];
        size_t n = 1 + rng_below(&rng, sizeof d);
        rng_fill(&rng, d, n);
        if (i % 4 == 0 && n > 8) { /* a sync word and a msg_size pointing inside the datagram */
            d[0] = UB_SYNC0;
            d[1] = UB_SYNC1;
            d[UB_FRAME_OFF_MSG_SIZE] = (uint8_t)(64 + rng_below(&rng, 100));
            d[UB_FRAME_OFF_MSG_SIZE + 1] = 0;
        }
        assert_int_equal(sendto(s, d, n, 0, (struct sockaddr *)&to, sizeof to), (ssize_t)n);
        if (i % 32 == 31) assert_true(ub_udp_service(&udp, p->sub_node, now++) >= 0);
    }
    /* Three valid frames batched in one datagram, then one whose middle frame's payload is damaged: the
     * frames around it still arrive (its header is sound, so its size can be trusted). */
    uint8_t batch[3 * 200];
    size_t n = 0, sizes[3];
    for (int k = 0; k < 3; k++) n += sizes[k] = random_frame(&rng, batch + n, 60);
    assert_int_equal(sendto(s, batch, n, 0, (struct sockaddr *)&to, sizeof to), (ssize_t)n);
    batch[sizes[0] + UB_FRAME_HEADER_LEN + 5] ^= 0x20;
    assert_int_equal(sendto(s, batch, n, 0, (struct sockaddr *)&to, sizeof to), (ssize_t)n);
    for (int i = 0; i < 200; i++) assert_true(ub_udp_service(&udp, p->sub_node, now++) >= 0);
    const ub_link_t *l = ub_node_link(p->sub_node, p->sub_link);
    uint64_t rejected = 0;
    for (int r = 0; r < UB_RX_REASON_COUNT; r++) rejected += l->counters.bad_datagrams[r];
    print_message("%d garbage datagrams: %llu rejections\n", garbage, (unsigned long long)rejected);
    assert_int_equal(udp.stats.datagrams_in, garbage + 2);
    assert_int_equal(rejected, garbage + 1);
    assert_int_equal(udp.stats.rejected, garbage + 1);
    assert_int_equal(l->counters.frames_in, 5);
    ub_udp_close(&udp);
    close(s);
    pair_free(p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_attach_counts_the_bytes_the_decoder_held),
        cmocka_unit_test(test_invariant_holds_across_tcp_reconnects),
        cmocka_unit_test(test_invariant_holds_across_a_rebind),
        cmocka_unit_test(test_each_garbage_datagram_is_one_rejection),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

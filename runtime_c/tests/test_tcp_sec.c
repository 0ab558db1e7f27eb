/*
 * TCP takeover over 127.0.0.1 with signing required (and, issue 29, the client hello and the candidate
 * slots an outsider cannot hold). An attacker who connects to the server's
 * listening port — silent, with garbage, with unsigned or forged frames, or replaying frames it
 * captured — is held as a candidate and never displaces the established peer; extra connections
 * are refused; the legitimate stream keeps every frame. The legitimate client reconnecting after a
 * half-open connection is adopted once its old connection has been silent for idle_ms. Every
 * outcome is counted by the driver and, for frames, by the node under its drop reason.
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
#include <time.h>
#include <unistd.h>

#include "support/ub_test_pair.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_sec.h"
#include "ub/ub_tcp.h"

static const uint8_t KEY[UB_SEC_KEY_LEN] = {9, 8, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6,
                                            7, 8, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4};

typedef struct rig {
    pair_t *p;
    ub_tcp_t client; /* pub side */
    ub_tcp_t client2;
    ub_tcp_t server; /* sub side */
    uint16_t port;
    ub_sec_t sa, sb;
    uint64_t now;
    ub_node_t *server_node, *client_node;
} rig_t;

static void sec_up(ub_sec_t *s) {
    assert_int_equal(ub_sec_init(s, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(s, 1, KEY), UB_OK);
    assert_int_equal(ub_sec_set_tx_key(s, 1), UB_OK);
    assert_int_equal(ub_sec_start(s, 0, 1000), UB_OK);
}

/* `listener_publishes` = 0: the publishing node connects out (its frames prove it); 1: the publishing node
 * listens and the subscriber, which has nothing to send, connects (only its hello can prove it). */
static rig_t *rig_new_roles(int listener_publishes) {
    rig_t *r = calloc(1, sizeof *r);
    assert_non_null(r);
    r->p = pair_new(NULL);
    sec_up(&r->sa);
    sec_up(&r->sb);
    assert_int_equal(ub_node_set_security(r->p->pub_node, &r->sa), UB_OK);
    assert_int_equal(ub_node_set_security(r->p->sub_node, &r->sb), UB_OK);
    assert_int_equal(ub_node_set_require_signed(r->p->pub_node, true), UB_OK);
    assert_int_equal(ub_node_set_require_signed(r->p->sub_node, true), UB_OK);
    ub_tcp_options_t so = {.idle_ms = 300, .candidate_ms = 500};
    ub_node_t *server_node = listener_publishes ? r->p->pub_node : r->p->sub_node;
    ub_node_t *client_node = listener_publishes ? r->p->sub_node : r->p->pub_node;
    assert_int_equal(ub_tcp_server_open(&r->server, "127.0.0.1", 0, &so), UB_OK);
    assert_int_equal(ub_tcp_local_port(&r->server, &r->port), UB_OK);
    assert_int_equal(ub_tcp_attach(&r->server, server_node, listener_publishes ? r->p->pub_link : r->p->sub_link),
                     UB_OK);
    r->server_node = server_node;
    r->client_node = client_node;
    ub_tcp_options_t co = {.backoff_initial_ms = 20, .backoff_max_ms = 160};
    assert_int_equal(ub_tcp_client_init(&r->client, "127.0.0.1", r->port, &co), UB_OK);
    assert_int_equal(ub_tcp_attach(&r->client, client_node, listener_publishes ? r->p->sub_link : r->p->pub_link),
                     UB_OK);
    return r;
}

static rig_t *rig_new(void) { return rig_new_roles(0); }

static void rig_free(rig_t *r) {
    ub_tcp_close(&r->client);
    ub_tcp_close(&r->client2);
    ub_tcp_close(&r->server);
    pair_free(r->p);
    free(r);
}

/* One simulated ms: tick both nodes, serve the client(s) and the server. `serve_old` = 0 leaves the
 * first client unserved (its connection half-open: it neither reads nor writes any more). */
static void step(rig_t *r, int serve_old) {
    struct pollfd fds[2] = {{.fd = ub_tcp_listen_fileno(&r->server), .events = POLLIN},
                            {.fd = ub_tcp_fileno(&r->server), .events = POLLIN}};
    (void)poll(fds, 2, 0);
    ub_node_tick(r->p->pub_node, r->now);
    ub_node_tick(r->p->sub_node, r->now);
    if (serve_old) assert_true(ub_tcp_service(&r->client, r->client_node, r->now) >= 0);
    if (r->client2.node != NULL) assert_true(ub_tcp_service(&r->client2, r->client_node, r->now) >= 0);
    assert_true(ub_tcp_service(&r->server, r->server_node, r->now) >= 0);
    r->now++;
}

static void run(rig_t *r, uint64_t ms, int serve_old) {
    for (uint64_t i = 0; i < ms; i++) {
        step(r, serve_old);
        if (i % 8 == 0) { /* let the loopback deliver */
            struct timespec ts = {0, 200000};
            nanosleep(&ts, NULL);
        }
    }
}

/* A raw attacker connection to the server's port from 127.0.0.`host` (any 127/8 address is local). */
static int attacker_connect_from(uint16_t port, uint8_t host) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    assert_true(fd >= 0);
    struct sockaddr_in me = {.sin_family = AF_INET, .sin_port = 0};
    me.sin_addr.s_addr = htonl(0x7F000000u | host);
    assert_int_equal(bind(fd, (struct sockaddr *)&me, sizeof me), 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons(port)};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    assert_int_equal(connect(fd, (struct sockaddr *)&a, sizeof a), 0);
    return fd;
}

static int attacker_connect(uint16_t port) { return attacker_connect_from(port, 1); }

/* Frames the legitimate client sent (captured off the wire by "the attacker"). */
typedef struct tape {
    size_t len;
    uint8_t bytes[16384];
} tape_t;

static void record_tx(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)link_id;
    (void)now_ms;
    tape_t *t = user;
    if (dir == UB_TAP_TX && t->len + len <= sizeof t->bytes) {
        memcpy(t->bytes + t->len, frame, len);
        t->len += len;
    }
}

static uint64_t drops(const ub_node_t *n, ub_drop_reason_t why) { return ub_node_counters(n)->drops[why]; }

static void test_signed_link_comes_up_and_resists_takeover(void **state) {
    (void)state;
    rig_t *r = rig_new();
    pair_t *p = r->p;
    static tape_t tape;
    memset(&tape, 0, sizeof tape);
    ub_node_set_tap(p->pub_node, record_tx, &tape);
    assert_true(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 10, 0) >= 0);
    /* 1. first contact: no established peer, but signing is required: adopted on its first authentic frame */
    run(r, 800, 1);
    const ub_tcp_stats_t *s = ub_tcp_stats(&r->server);
    assert_int_equal(ub_tcp_state(&r->server), UB_TCP_UP);
    assert_int_equal(s->candidates, 1);
    assert_int_equal(s->adopted, 1);
    assert_int_equal(s->replaced, 0);
    assert_true(ub_sec_stats(&r->sb)->challenges_completed == 1);
    ub_node_set_tap(p->pub_node, NULL, NULL);
    size_t d0 = p->log.n;
    assert_true(d0 > 30);
    /* 2. the attacks: a silent connection, garbage, unsigned and forged frames, replayed captured frames */
    int silent = attacker_connect(r->port);
    int noisy = attacker_connect(r->port);
    run(r, 5, 1);
    int third = attacker_connect(r->port); /* its address holds its bound of unproven ones: evicts the oldest */
    run(r, 5, 1);
    assert_int_equal(s->candidates_evicted, 1);
    assert_int_equal(s->candidates_refused, 0);
    assert_int_equal(ub_tcp_candidates(&r->server), UB_TCP_CANDIDATES_PER_ADDR);
    uint8_t junk[300];
    for (size_t i = 0; i < sizeof junk; i++) junk[i] = (uint8_t)(i * 37u);
    assert_int_equal(write(noisy, junk, sizeof junk), (ssize_t)sizeof junk);
    uint8_t f[UB_FRAME_MAX], payload[UB_MAX_PAYLOAD] = {0};
    size_t n = make_frame(f, UB_ADMIN_DATA, ub_test_cat.instances[TEST_GPS].id, "pub", "sub", 0x7FFFFFF0u, 8,
                          ub_test_cat.instances[TEST_GPS].type->fingerprint, payload,
                          (uint16_t)ub_test_cat.instances[TEST_GPS].type->packed_size);
    assert_int_equal(write(noisy, f, n), (ssize_t)n); /* unsigned */
    f[UB_FRAME_OFF_VERSION] = 0x11; /* "signed" without a trailer, CRC fixed up: the length gives it away */
    assert_int_equal(ub_frame_set_hop_limit(f, n, 8), UB_OK);
    assert_int_equal(write(noisy, f, n), (ssize_t)n);
    static ub_sec_t guess; /* signed with a guessed key */
    uint8_t wrong[UB_SEC_KEY_LEN] = {1};
    assert_int_equal(ub_sec_init(&guess, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(&guess, 1, wrong), UB_OK);
    ub_frame_header_t h;
    size_t first = (size_t)(tape.bytes[UB_FRAME_OFF_MSG_SIZE] | tape.bytes[UB_FRAME_OFF_MSG_SIZE + 1] << 8);
    assert_int_equal(ub_frame_parse(tape.bytes, first, &h), UB_OK);
    h.seq += 1000;
    int fn = ub_sec_protect(&guess, &h, tape.bytes + UB_FRAME_HEADER_LEN, f, sizeof f);
    assert_true(fn > 0);
    assert_int_equal(write(noisy, f, (size_t)fn), fn);
    assert_int_equal(write(noisy, tape.bytes, tape.len), (ssize_t)tape.len); /* the captured genuine frames */
    size_t before_attack = p->log.n;
    run(r, 1000, 1);
    /* nothing of it was accepted, the established peer stayed, the stream kept flowing */
    assert_int_equal(ub_tcp_state(&r->server), UB_TCP_UP);
    assert_int_equal(s->replaced, 0);
    assert_int_equal(s->adopted, 1);
    assert_int_equal(s->candidates_expired, 2); /* noisy and third: not adopted within candidate_ms */
    assert_int_equal(ub_tcp_candidates(&r->server), 0);
    assert_int_equal(drops(p->sub_node, UB_DROP_UNSIGNED), 1);
    assert_int_equal(drops(p->sub_node, UB_DROP_BAD_TAG), 1);
    assert_true(drops(p->sub_node, UB_DROP_REPLAY) + drops(p->sub_node, UB_DROP_DUPLICATE) >= 30);
    assert_true(s->candidate_rejected >= 1); /* the lying "signed" frame, and sync bytes inside the junk */
    assert_true(s->candidate_garbage >= 100);
    size_t during = p->log.n - before_attack;
    assert_in_range(during, 95, 101); /* 10 ms publication for 1 s: nothing lost to the attack */
    assert_int_equal(delivery_repeats(&p->log), 0);
    close(silent);
    close(noisy);
    close(third);
    rig_free(r);
}

static void test_reconnect_after_half_open_is_adopted_when_the_old_peer_is_silent(void **state) {
    (void)state;
    rig_t *r = rig_new();
    pair_t *p = r->p;
    assert_true(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 10, 0) >= 0);
    run(r, 600, 1);
    assert_int_equal(ub_tcp_state(&r->server), UB_TCP_UP);
    size_t d0 = p->log.n;
    assert_true(d0 > 30);
    /* the client's connection goes half-open (no FIN reaches the server) and it reconnects */
    ub_tcp_options_t co = {.backoff_initial_ms = 20, .backoff_max_ms = 160};
    assert_int_equal(ub_tcp_client_init(&r->client2, "127.0.0.1", r->port, &co), UB_OK);
    assert_int_equal(ub_tcp_attach(&r->client2, p->pub_node, p->pub_link), UB_OK);
    uint64_t t0 = r->now;
    run(r, 1000, 0);
    const ub_tcp_stats_t *s = ub_tcp_stats(&r->server);
    assert_int_equal(s->candidates, 2);
    assert_int_equal(s->adopted, 2);
    assert_int_equal(s->replaced, 1); /* the silent old connection, after idle_ms */
    /* data flows again over the new connection: the outage is about idle_ms */
    size_t after = delivery_count(&p->log, p->sub, TEST_GPS, t0 + 400, r->now);
    assert_in_range(after, 55, 61);
    assert_int_equal(drops(p->sub_node, UB_DROP_REPLAY), 0);
    rig_free(r);
}

/* The issue-29 deadlock: the listener publishes, the client has nothing to send. The client's hello on
 * connecting proves it, so the listener adopts the connection and the stream flows at its rate. */
static void test_a_listener_that_only_publishes_is_adopted_by_the_client_hello(void **state) {
    (void)state;
    rig_t *r = rig_new_roles(1);
    pair_t *p = r->p;
    assert_true(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 10, 0) >= 0);
    run(r, 50, 1);
    const ub_tcp_stats_t *s = ub_tcp_stats(&r->server);
    assert_int_equal(ub_tcp_stats(&r->client)->hellos, 1);
    assert_int_equal(ub_tcp_state(&r->server), UB_TCP_UP);
    assert_int_equal(s->adopted, 1);
    assert_int_equal(drops(r->server_node, UB_DROP_BAD_PAYLOAD), 0); /* the hello is taken, not dropped */
    uint64_t t0 = r->now;
    run(r, 1000, 1);
    /* 10 ms publication for 1 s, minus the first frames dropped `unverified` while the subscriber's
     * challenge of the publisher runs (one round trip) */
    size_t got = delivery_count(&p->log, p->sub, TEST_GPS, t0, r->now);
    assert_in_range(got, 95, 101);
    assert_int_equal(s->candidates_expired, 0);
    rig_free(r);
}

/* Plain connections hold every candidate slot, from several addresses, and reconnect before they expire:
 * the genuine client still gets a slot at once (evicting the oldest unproven) and proves itself. */
static void test_plain_connections_renewed_before_expiry_cannot_keep_the_client_out(void **state) {
    (void)state;
    rig_t *r = rig_new_roles(1);
    pair_t *p = r->p;
    assert_true(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 10, 0) >= 0);
    r->client.next_attempt_ms = UINT64_MAX; /* the client stays away while the attacker moves in */
    int held[UB_TCP_MAX_CANDIDATES];
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES; i++) {
        held[i] = attacker_connect_from(r->port, (uint8_t)(2 + i / UB_TCP_CANDIDATES_PER_ADDR));
        run(r, 100, 1);
    }
    assert_int_equal(ub_tcp_candidates(&r->server), UB_TCP_MAX_CANDIDATES);
    for (int round = 0; round < 8; round++) { /* renew the oldest every 100 ms: the slots never empty */
        int i = round % UB_TCP_MAX_CANDIDATES;
        close(held[i]);
        held[i] = attacker_connect_from(r->port, (uint8_t)(2 + i / UB_TCP_CANDIDATES_PER_ADDR));
        run(r, 100, 1);
        assert_int_equal(ub_tcp_candidates(&r->server), UB_TCP_MAX_CANDIDATES);
    }
    const ub_tcp_stats_t *s = ub_tcp_stats(&r->server);
    assert_int_equal(s->adopted, 0);
    uint64_t evicted = s->candidates_evicted;
    r->client.next_attempt_ms = r->now; /* the genuine client (re)starts */
    uint64_t t0 = r->now;
    run(r, 20, 1);
    assert_int_equal(ub_tcp_state(&r->server), UB_TCP_UP);
    assert_int_equal(s->adopted, 1);
    assert_int_equal(s->candidates_evicted, evicted + 1);
    assert_int_equal(s->candidates_refused, 0);
    run(r, 980, 1);
    size_t got = delivery_count(&p->log, p->sub, TEST_GPS, t0, r->now);
    assert_in_range(got, 95, 101);
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES; i++) close(held[i]);
    rig_free(r);
}

/* A proven candidate is never evicted by connections that prove nothing; with every slot proven, a new
 * connection is refused. */
static void test_a_proven_candidate_is_not_evicted(void **state) {
    (void)state;
    rig_t *r = rig_new();
    assert_true(ub_pubsub_publish(r->p->pub_node, r->p->pub, TEST_GPS, r->p->sub_id, 10, 0) >= 0);
    run(r, 100, 1);
    assert_int_equal(ub_tcp_state(&r->server), UB_TCP_UP);
    /* a second genuine connection (the same node, e.g. after a half-open one): proven, held while the
     * established peer is alive */
    ub_tcp_options_t co = {.backoff_initial_ms = 20, .backoff_max_ms = 160};
    assert_int_equal(ub_tcp_client_init(&r->client2, "127.0.0.1", r->port, &co), UB_OK);
    assert_int_equal(ub_tcp_attach(&r->client2, r->client_node, r->p->pub_link), UB_OK);
    run(r, 20, 1);
    assert_int_equal(ub_tcp_stats(&r->client2)->hellos, 1);
    assert_int_equal(ub_tcp_candidates(&r->server), 1);
    int fds[UB_TCP_MAX_CANDIDATES + 2];
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES + 2; i++) {
        fds[i] = attacker_connect_from(r->port, (uint8_t)(10 + i));
        run(r, 5, 1);
    }
    const ub_tcp_stats_t *s = ub_tcp_stats(&r->server);
    assert_int_equal(ub_tcp_candidates(&r->server), UB_TCP_MAX_CANDIDATES);
    assert_int_equal(s->candidates_evicted, 3); /* 3 free slots, 6 newcomers: the 3 oldest plain ones went */
    assert_int_equal(s->candidates_lost + s->candidates_expired, 0);
    int proven = 0;
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES; i++) proven += r->server.cand[i].fd >= 0 && r->server.cand[i].proven;
    assert_int_equal(proven, 1);
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES + 2; i++) close(fds[i]);
    rig_free(r);
}

/* Every slot holds a proven candidate (genuine connections of the client's node, each proven by its hello,
 * while the established peer is alive and keeps its place): a newcomer finds nothing it may evict and is
 * closed at once, counted `candidates_refused`; the proven ones and the established peer stay. */
static void test_every_slot_proven_refuses_a_newcomer(void **state) {
    (void)state;
    rig_t *r = rig_new();
    assert_true(ub_pubsub_publish(r->p->pub_node, r->p->pub, TEST_GPS, r->p->sub_id, 10, 0) >= 0);
    run(r, 100, 1);
    assert_int_equal(ub_tcp_state(&r->server), UB_TCP_UP);
    static ub_tcp_t extra[UB_TCP_MAX_CANDIDATES];
    ub_tcp_options_t co = {.backoff_initial_ms = 20, .backoff_max_ms = 160};
    const ub_tcp_stats_t *s = ub_tcp_stats(&r->server);
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES; i++) {
        assert_int_equal(ub_tcp_client_init(&extra[i], "127.0.0.1", r->port, &co), UB_OK);
        assert_int_equal(ub_tcp_attach(&extra[i], r->client_node, r->p->pub_link), UB_OK);
        for (int k = 0; k < 2000 && (ub_tcp_stats(&extra[i])->hellos == 0 || ub_tcp_candidates(&r->server) <= i ||
                                     !r->server.cand[i].proven);
             k++) {
            (void)poll(&(struct pollfd){.fd = ub_tcp_fileno(&extra[i]), .events = POLLOUT}, 1, 1);
            assert_true(ub_tcp_service(&extra[i], r->client_node, r->now) >= 0);
            step(r, 1);
        }
        assert_int_equal(ub_tcp_stats(&extra[i])->hellos, 1);
    }
    int proven = 0;
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES; i++) proven += r->server.cand[i].fd >= 0 && r->server.cand[i].proven;
    assert_int_equal(proven, UB_TCP_MAX_CANDIDATES);
    assert_int_equal(s->adopted, 1); /* the established peer is alive: nobody was adopted in its place */
    int newcomer = attacker_connect_from(r->port, 42);
    for (int k = 0; k < 200 && s->candidates_refused == 0; k++) step(r, 1);
    assert_int_equal(s->candidates_refused, 1);
    assert_int_equal(s->candidates_evicted, 0);
    assert_int_equal(ub_tcp_candidates(&r->server), UB_TCP_MAX_CANDIDATES);
    assert_int_equal(ub_tcp_state(&r->server), UB_TCP_UP);
    uint8_t b;
    struct pollfd pf = {.fd = newcomer, .events = POLLIN};
    assert_int_equal(poll(&pf, 1, 2000), 1);
    assert_int_equal(read(newcomer, &b, 1), 0); /* closed by the server: end of stream */
    close(newcomer);
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES; i++) ub_tcp_close(&extra[i]);
    rig_free(r);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_signed_link_comes_up_and_resists_takeover),
        cmocka_unit_test(test_reconnect_after_half_open_is_adopted_when_the_old_peer_is_silent),
        cmocka_unit_test(test_a_listener_that_only_publishes_is_adopted_by_the_client_hello),
        cmocka_unit_test(test_plain_connections_renewed_before_expiry_cannot_keep_the_client_out),
        cmocka_unit_test(test_a_proven_candidate_is_not_evicted),
        cmocka_unit_test(test_every_slot_proven_refuses_a_newcomer),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

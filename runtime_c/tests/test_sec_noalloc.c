/*
 * No allocation after init with security on — libsodium included. test_noalloc counts through
 * -Wl,--wrap, which sees only calls from objects linked into the program; libsodium is a shared
 * library, so this program defines malloc/calloc/realloc/free itself (glibc lets the executable's
 * definitions interpose for every library) and forwards them to glibc's. After set-up, a signed and
 * encrypted stream with a challenge handshake, forwarder conversion, forged frames, a key rotation and
 * a receiver restart must not allocate once. (Not built under ASan, which owns the allocator.)
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_ident.h"
#include "support/ub_test_pair.h"
#include "support/ub_test_store.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_revoke.h"
#include "ub/ub_sec.h"

extern void *__libc_malloc(size_t size);
extern void *__libc_calloc(size_t n, size_t size);
extern void *__libc_realloc(void *p, size_t size);
extern void __libc_free(void *p);

static volatile size_t heap_calls;

void *malloc(size_t size) {
    heap_calls++;
    return __libc_malloc(size);
}
void *calloc(size_t n, size_t size) {
    heap_calls++;
    return __libc_calloc(n, size);
}
void *realloc(void *p, size_t size) {
    heap_calls++;
    return __libc_realloc(p, size);
}
void free(void *p) {
    heap_calls++;
    __libc_free(p);
}

static void test_interposition_counts(void **state) {
    (void)state;
    size_t before = heap_calls;
    void *volatile p = malloc(16);
    free(p);
    assert_int_equal(heap_calls - before, 2);
    /* and calls made inside another shared object (here libc's stdio) are counted too */
    before = heap_calls;
    FILE *f = fopen("/dev/null", "r");
    assert_non_null(f);
    fclose(f);
    assert_true(heap_calls - before >= 1);
}

static const uint8_t K1[UB_SEC_KEY_LEN] = {7, 1, 2, 3};
static const uint8_t K2[UB_SEC_KEY_LEN] = {7, 4, 5, 6};

typedef struct rig {
    pair_t *p;
    ub_sec_t a, b;
    store_t sa, sb;
} rig_t;

static void sec_up(ub_sec_t *s, store_t *st) {
    ub_sec_options_t o = {.reserve = store_reserve, .reserve_user = st, .reserve_block = 16};
    assert_int_equal(ub_sec_init(s, &o), UB_OK);
    assert_int_equal(ub_sec_add_key(s, 1, K1), UB_OK);
    assert_int_equal(ub_sec_set_tx_key(s, 1), UB_OK);
    assert_int_equal(ub_sec_start(s, st->mark, 100), UB_OK);
}

static void test_signed_and_encrypted_traffic_does_not_allocate(void **state) {
    (void)state;
    rig_t *r = calloc(1, sizeof *r);
    assert_non_null(r);
    r->p = pair_new(NULL);
    pair_t *p = r->p;
    sec_up(&r->a, &r->sa);
    sec_up(&r->b, &r->sb);
    assert_int_equal(ub_node_set_security(p->pub_node, &r->a), UB_OK);
    assert_int_equal(ub_node_set_security(p->sub_node, &r->b), UB_OK);
    assert_int_equal(ub_node_set_require_signed(p->sub_node, true), UB_OK);
    assert_int_equal(ub_node_link_set_security(p->pub_node, p->pub_link, -1, true), UB_OK);
    assert_int_equal(ub_node_link_set_security(p->sub_node, p->sub_link, 1, true), UB_OK);
    static uint8_t forged[UB_FRAME_MAX];
    size_t n = make_frame(forged, UB_ADMIN_DATA, ub_test_cat.instances[TEST_GPS].id, "pub", "sub", 5, 8,
                          ub_test_cat.instances[TEST_GPS].type->fingerprint, NULL, 0);

    size_t before = heap_calls;
    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 10, 0) >= 0);
    world_run(p->w, 500, 1);                                       /* challenge, then ENCRYPTED flow */
    assert_int_equal(ub_node_rx_frame(p->sub_node, p->sub_link, forged, n, 500), UB_OK); /* refused */
    assert_int_equal(ub_sec_add_key(&r->a, 2, K2), UB_OK);          /* rotation */
    assert_int_equal(ub_sec_add_key(&r->b, 2, K2), UB_OK);
    assert_int_equal(ub_sec_set_tx_key(&r->a, 2), UB_OK);
    assert_int_equal(ub_sec_set_tx_key(&r->b, 2), UB_OK);
    assert_int_equal(ub_sec_remove_key(&r->a, 1), UB_OK);
    assert_int_equal(ub_sec_remove_key(&r->b, 1), UB_OK);
    world_run(p->w, 1000, 1);
    uint64_t completed = ub_sec_stats(&r->b)->challenges_completed;
    sec_up(&r->b, &r->sb);                                         /* the receiver's context restarts */
    assert_int_equal(ub_sec_add_key(&r->b, 2, K2), UB_OK);
    assert_int_equal(ub_sec_set_tx_key(&r->b, 2), UB_OK);
    world_run(p->w, 1500, 1);
    size_t during = heap_calls - before;

    assert_int_equal(during, 0);
    assert_true(delivery_count(&p->log, p->sub, TEST_GPS, 0, 1501) > 100);
    assert_true(ub_sec_stats(&r->a)->encrypted_out > 100);
    assert_true(completed >= 1);
    assert_int_equal(ub_node_counters(p->sub_node)->drops[UB_DROP_UNSIGNED], 1);
    pair_free(p);
    free(r);
}

/* Identity per entity: certificates verified into a store, lookups, a revocation spread by the revocation
 * service between two nodes, certificates announced and learned: no allocation, Ed25519 included. */
typedef struct ident_rig {
    pair_t *p;
    test_authority_t auth;
    test_entity_t pub, sub, victim;
    ub_ident_store_t sa, sb;
    ub_revoke_t ra, rb;
    uint8_t rec[UB_REVOCATION_LEN];
} ident_rig_t;

static uint64_t rig_clock(void *user) {
    (void)user;
    return 1790000100u;
}

static void test_identities_and_revocation_do_not_allocate(void **state) {
    (void)state;
    ident_rig_t *r = calloc(1, sizeof *r);
    assert_non_null(r);
    r->p = pair_new(NULL);
    pair_t *p = r->p;
    assert_int_equal(test_authority(&r->auth, "noalloc authority"), UB_OK);
    assert_int_equal(test_issue(&r->pub, &r->auth, "pub", UB_ROLE_VEHICLE, 1, 1790000000u, 1790086400u), UB_OK);
    assert_int_equal(test_issue(&r->sub, &r->auth, "sub", UB_ROLE_ADMIN, 2, 1790000000u, 1790086400u), UB_OK);
    assert_int_equal(test_issue(&r->victim, &r->auth, "lost1", UB_ROLE_VEHICLE, 3, 1790000000u, 1790086400u), UB_OK);
    assert_int_equal(test_revoke_record(r->rec, &r->auth, "lost1", 3, 1790000050u), UB_OK);
    ub_ident_store_init(&r->sa);
    ub_ident_store_init(&r->sb);
    ub_revoke_options_t opt = {.clock_s = rig_clock};

    size_t before = heap_calls;
    assert_int_equal(ub_ident_set_authority(&r->sa, r->auth.pk), UB_OK);
    assert_int_equal(ub_ident_set_authority(&r->sb, r->auth.pk), UB_OK);
    assert_int_equal(ub_ident_set_self(&r->sa, &r->pub.cert, r->pub.sign_sk, r->pub.kx_sk, 1790000100u, NULL), UB_OK);
    assert_int_equal(ub_ident_set_self(&r->sb, &r->sub.cert, r->sub.sign_sk, r->sub.kx_sk, 1790000100u, NULL), UB_OK);
    assert_int_equal(ub_ident_add_peer(&r->sb, r->victim.cert_bytes, UB_CERT_LEN, 1790000100u, NULL), UB_OK);
    assert_int_equal(ub_revoke_init(&r->ra, p->pub_node, &r->sa, &opt, NULL, NULL), UB_OK);
    assert_int_equal(ub_revoke_init(&r->rb, p->sub_node, &r->sb, &opt, NULL, NULL), UB_OK);
    assert_int_equal(ub_revoke_spread_certificates(&r->ra, NULL, NULL, 0), UB_OK);
    assert_int_equal(ub_revoke_spread_certificates(&r->rb, NULL, NULL, 0), UB_OK);
    world_run(p->w, 100, 1);                                        /* certificates announced and learned */
    assert_int_equal(ub_revoke_submit(&r->ra, r->rec, sizeof r->rec, 100), UB_OK);
    world_run(p->w, 2000, 1);                                       /* the revocation reaches the other node */
    uint8_t pk[32];
    int pub_from_sub = ub_ident_peer_kx_key(&r->sb, r->pub.cert.entity, 1790000100u, pk);
    int victim_at_sub = ub_ident_peer_kx_key(&r->sb, r->victim.cert.entity, 1790000100u, pk);
    size_t during = heap_calls - before;

    assert_int_equal(during, 0);
    assert_int_equal(pub_from_sub, UB_OK);
    assert_int_equal(victim_at_sub, UB_ERR_AUTH);
    assert_int_equal(r->rb.stats.accepted, 1);
    pair_free(p);
    free(r);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_interposition_counts),
        cmocka_unit_test(test_signed_and_encrypted_traffic_does_not_allocate),
        cmocka_unit_test(test_identities_and_revocation_do_not_allocate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

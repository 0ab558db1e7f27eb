/*
 * No allocation after init, shown at run time: this program is linked with
 * -Wl,--wrap=malloc,calloc,realloc,free (tests/router.cmake), so every call to
 * them from the library or this file goes through the counters below. The
 * whole Figure 9 system is set up and run (pub/sub, admin table, memlinks
 * with faults) in memory allocated before counting starts; the count must stay 0. So is the
 * authorization world (ub_test_authz.h): a policy parsed from a config, attacks refused, rows evicted.
 * (ub_noalloc_nm complements this: libub.a references no allocator at all.)
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>

#include "support/ub_test_authz.h"
#include "support/ub_test_fig9.h"
#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"

void *__real_malloc(size_t size);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *p, size_t size);
void __real_free(void *p);

/* Test-program counter (volatile: the compiler assumes malloc leaves user variables alone). */
static volatile size_t heap_calls;

void *__wrap_malloc(size_t size) {
    heap_calls++;
    return __real_malloc(size);
}
void *__wrap_calloc(size_t n, size_t size) {
    heap_calls++;
    return __real_calloc(n, size);
}
void *__wrap_realloc(void *p, size_t size) {
    heap_calls++;
    return __real_realloc(p, size);
}
void __wrap_free(void *p) {
    heap_calls++;
    __real_free(p);
}

/* The wrapping must be live, or the real test below would prove nothing. */
static void test_wrapping_counts(void **state) {
    (void)state;
    size_t before = heap_calls;
    void *volatile p = malloc(16); /* volatile: the optimiser may not elide the pair */
    free(p);
    assert_int_equal(heap_calls - before, 2);
}

static void test_init_and_run_do_not_allocate(void **state) {
    (void)state;
    fig9_t *f = calloc(1, sizeof *f);
    world_t *w = calloc(1, sizeof *w);
    assert_non_null(f);
    assert_non_null(w);
    static const ub_memlink_faults_t faults = {.loss_ppm = 100000, .duplicate_ppm = 50000, .reorder_ppm = 50000};
    size_t before = heap_calls;

    fig9_init(f, w, &faults, 5);
    int row = fig9_admin_row(f, UB_ADMIN_ROW_SUBSCRIPTION);
    world_run(w, 3000, 1);
    assert_int_equal(ub_admin_set_active(&f->admin, row, false, w->now_ms), UB_OK);
    world_run(w, 6000, 1);

    size_t during = heap_calls - before;
    assert_true(f->log.n > 0); /* the run did real work */
    free(w);
    free(f);
    assert_int_equal(during, 0);
}

static void test_policy_and_attacks_do_not_allocate(void **state) {
    (void)state;
    authz_t *a = calloc(1, sizeof *a);
    ub_nodecfg_t *cfg = calloc(1, sizeof *cfg);
    assert_non_null(a);
    assert_non_null(cfg);
    authz_init(a, 1); /* builds the test catalogue once (its qsort may allocate): before counting */
    static const char text[] =
        "{\"entities\": [{\"name\": \"gcs1\"}, {\"name\": \"veh1\"}], \"hosts\": [\"veh1\"],\n"
        " \"security\": {\"administrators\": [\"gcs1\"], \"read\": {\"*\": [{\"from\": \"*\", \"content\": \"*\"}]},\n"
        "  \"write\": {\"veh1\": [{\"from\": [\"gcs1\"], \"content\": [\"cell*\"]}]}, \"limits\": {\"max_rows\": 8}}}";
    char err[UB_NODECFG_ERR_LEN];
    size_t before = heap_calls;

    authz_init(a, 3);
    assert_int_equal(ub_nodecfg_parse(cfg, text, sizeof text - 1, "noalloc.json", err, sizeof err), UB_OK);
    ub_node_set_policy(a->veh, &cfg->policy);
    uint32_t gps = authz_instance(a, "gpsOut");
    int row = -1;
    for (int i = 0; i < 3; i++) {
        authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "mallory", "mallory", 1, 0, 1);        /* LIMIT */
        authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "mallory", "mallory", 100, 0, 2);      /* lease clamped */
        authz_request(a, UB_ADMIN_SUB_REQUEST, gps, "mallory", "obs1", 100, 0, 3);         /* NOT_AUTHORIZED */
        authz_stop(a, UB_ADMIN_PUB_STOP, gps, "mallory", "obs1", 4);                       /* NOT_AUTHORIZED */
        authz_reply(a, true, gps, "mallory", "gcs1", 5, UB_ADMIN_PUB_REQUEST, 4);         /* unmatched */
        authz_data(a, gps, "mallory", (const uint8_t *)"012345678901234567890123");     /* not_allowed */
        for (uint32_t c = 0; c < AUTHZ_CELLS; c++)
            authz_request(a, UB_ADMIN_PUB_REQUEST, c, c % 2 ? "m1" : "m2", c % 2 ? "m1" : "m2", 1000, 3000, c);
        if (row < 0) {
            ub_admin_row_spec_t spec = {.instance = gps, .period_ms = 100, .type = UB_ADMIN_ROW_SUBSCRIPTION};
            test_eid("veh1", spec.source);
            test_eid("gcs1", spec.destination);
            row = ub_admin_add_row(&a->admin, &spec);
            assert_int_equal(ub_admin_set_active(&a->admin, row, true, a->w.now_ms), UB_OK);
        }
        world_run(&a->w, a->w.now_ms + 1000, 1);
    }

    size_t during = heap_calls - before;
    assert_true(a->gcs_log.n > 0);                                       /* the run did real work */
    assert_true(ub_node_counters(a->veh)->drops[UB_DROP_NOT_AUTHORIZED] > 0); /* and refused the attacks */
    assert_true(ub_node_counters(a->veh)->drops[UB_DROP_NOT_ALLOWED] > 0);
    free(cfg);
    free(a);
    assert_int_equal(during, 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_wrapping_counts),
        cmocka_unit_test(test_init_and_run_do_not_allocate),
        cmocka_unit_test(test_policy_and_attacks_do_not_allocate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/*
 * No allocation after init, shown at run time: this program is linked with
 * -Wl,--wrap=malloc,calloc,realloc,free (tests/router.cmake), so every call to
 * them from the library or this file goes through the counters below. The
 * whole Figure 9 system is set up and run (pub/sub, admin table, memlinks
 * with faults) in memory allocated before counting starts; the count must stay 0.
 * (ub_noalloc_nm complements this: libub.a references no allocator at all.)
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>

#include "support/ub_test_fig9.h"
#include "ub/ub_node.h"

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

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_wrapping_counts),
        cmocka_unit_test(test_init_and_run_do_not_allocate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/* ub_rxring.h: the delivery ring loses nothing and keeps order under a burst larger than the ring (the
 * overflow goes to the spill hook, counted; without one it is dropped, counted), wraps, and carries the
 * wire image of each delivery; ub_send_many() sends N publications from one call. Two nodes on a memlink
 * (tests/support/ub_test_pair.c). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_pair.h"
#include "ub/ub_rxring.h"

#define STRIDE (UB_RXREC_HEADER + 64u)
#define CAP 16u
#define BURST 60u /* < UB_MEMLINK_DEPTH: one pump delivers it all in one C call, more than the ring holds */

static uint32_t rec_seq(const uint8_t *r) {
    uint32_t v;
    memcpy(&v, r + 12, sizeof v);
    return v;
}

typedef struct fixture {
    pair_t *p;
    uint8_t mem[CAP * STRIDE];
    uint8_t out[BURST * STRIDE];
    ub_rxring_t ring;
} fixture_t;

static fixture_t *setup_ring(int with_spill) {
    fixture_t *f = calloc(1, sizeof *f);
    assert_non_null(f);
    f->p = pair_new(NULL);
    assert_int_equal(ub_rxring_init(&f->ring, f->mem, sizeof f->mem, STRIDE), 0);
    assert_int_equal(f->ring.capacity, CAP);
    /* The pair's delivery log is the spill hook: the "per-delivery path" of a binding. */
    assert_int_equal(ub_rxring_attach(&f->ring, f->p->sub_node, with_spill ? delivery_log_hook : NULL,
                                      with_spill ? &f->p->log : NULL), 0);
    return f;
}

static void burst(fixture_t *f, unsigned n) {
    for (unsigned i = 0; i < n; i++) {
        f->p->gps_src.fix = 1000u + i; /* tells the images apart */
        assert_int_equal(ub_node_send_data(f->p->pub_node, f->p->pub, TEST_GPS, f->p->sub_id, f->p->w->now_ms), 1);
    }
    assert_int_equal(ub_memlink_pump(f->p->ml, f->p->w->now_ms), (int)n);
}

static void burst_larger_than_the_ring_loses_nothing_and_keeps_order(void **state) {
    (void)state;
    fixture_t *f = setup_ring(1);
    burst(f, BURST);
    ub_rxring_counters_t c = ub_rxring_get_counters(&f->ring);
    assert_int_equal(c.recorded, CAP);
    assert_int_equal(c.spilled, BURST - CAP); /* reported, never silent */
    assert_int_equal(c.dropped, 0);
    assert_int_equal(c.high_water, CAP);
    /* Drain in two calls (max smaller than what is held), then the spilled ones: one ordered stream. */
    size_t n = ub_rxring_drain(&f->ring, f->out, 5);
    n += ub_rxring_drain(&f->ring, f->out + n * STRIDE, BURST);
    assert_int_equal(n, CAP);
    assert_int_equal(f->p->log.n, BURST - CAP);
    uint32_t first = rec_seq(f->out);
    for (size_t i = 0; i < n; i++) {
        const uint8_t *r = f->out + i * STRIDE;
        assert_int_equal(rec_seq(r), first + i);
        uint32_t instance;
        uint16_t len;
        memcpy(&instance, r + 8, 4);
        memcpy(&len, r + 20, 2);
        assert_int_equal(instance, TEST_GPS);
        assert_int_equal(len, ub_test_cat.instances[TEST_GPS].type->packed_size);
        assert_memory_equal(r + 24, f->p->pub_id, UB_ENTITY_ID_LEN);
        assert_memory_equal(r + 36, f->p->sub_id, UB_ENTITY_ID_LEN);
        /* The image is this delivery's, not the storage's latest. */
        struct test_gps g;
        assert_true(ub_test_cat.instances[TEST_GPS].type->unpack(&g, r + UB_RXREC_HEADER, len) > 0);
        assert_int_equal(g.fix, 1000u + i);
    }
    for (size_t i = 0; i < f->p->log.n; i++) assert_int_equal(f->p->log.d[i].seq, first + CAP + i);
    /* Drained: the next delivery goes to the ring again (the spill ended with the drain). */
    burst(f, 3);
    c = ub_rxring_get_counters(&f->ring);
    assert_int_equal(c.recorded, CAP + 3);
    assert_int_equal(c.spilled, BURST - CAP);
    assert_int_equal(ub_rxring_drain(&f->ring, f->out, BURST), 3);
    assert_int_equal(rec_seq(f->out), first + BURST);
    pair_free(f->p);
    free(f);
}

static void without_spill_the_overflow_is_dropped_and_counted(void **state) {
    (void)state;
    fixture_t *f = setup_ring(0);
    burst(f, BURST);
    ub_rxring_counters_t c = ub_rxring_get_counters(&f->ring);
    assert_int_equal(c.recorded, CAP);
    assert_int_equal(c.dropped, BURST - CAP);
    assert_int_equal(c.recorded + c.dropped, BURST); /* every delivery accounted for */
    pair_free(f->p);
    free(f);
}

static void ring_wraps_in_order(void **state) {
    (void)state;
    fixture_t *f = setup_ring(1);
    uint32_t expect = 0;
    for (int round = 0; round < 7; round++) { /* 7 x 11 records through 16 slots: every wrap position */
        burst(f, 11);
        size_t n = ub_rxring_drain(&f->ring, f->out, BURST);
        assert_int_equal(n, 11);
        if (round == 0) expect = rec_seq(f->out);
        for (size_t i = 0; i < n; i++) assert_int_equal(rec_seq(f->out + i * STRIDE), expect++);
    }
    assert_int_equal(ub_rxring_get_counters(&f->ring).spilled, 0);
    assert_int_equal(ub_rxring_pending(&f->ring), 0);
    pair_free(f->p);
    free(f);
}

static void send_many_sends_each_value_in_order(void **state) {
    (void)state;
    fixture_t *f = setup_ring(1);
    uint32_t fixes[12];
    for (unsigned i = 0; i < 12; i++) fixes[i] = 500u + 7u * i;
    long sent = ub_send_many(f->p->pub_node, f->p->pub, TEST_GPS, f->p->sub_id, 0, offsetof(struct test_gps, fix),
                             sizeof(uint32_t), (const uint8_t *)fixes, 12);
    assert_int_equal(sent, 12);
    assert_int_equal(ub_memlink_pump(f->p->ml, 0), 12);
    assert_int_equal(ub_rxring_drain(&f->ring, f->out, BURST), 12);
    for (unsigned i = 0; i < 12; i++) {
        struct test_gps g;
        assert_true(ub_test_cat.instances[TEST_GPS].type->unpack(&g, f->out + i * STRIDE + UB_RXREC_HEADER, 64) > 0);
        assert_int_equal(g.fix, fixes[i]);
        assert_true(g.lat == 33.78); /* the rest of the storage as bound */
    }
    /* A field beyond the storage, an unbound instance: refused before anything is sent. */
    assert_int_equal(ub_send_many(f->p->pub_node, f->p->pub, TEST_GPS, f->p->sub_id, 0, sizeof(struct test_gps), 1,
                                  (const uint8_t *)fixes, 1), UB_ERR_INVAL);
    assert_int_equal(ub_send_many(f->p->pub_node, f->p->pub, TEST_IMU, f->p->sub_id, 0, 0, 4, (const uint8_t *)fixes, 1),
                     UB_ERR_INVAL);
    assert_int_equal(ub_rxring_init(&f->ring, f->mem, STRIDE - 1, STRIDE), UB_ERR_INVAL);
    assert_int_equal(ub_rxring_init(&f->ring, f->mem, sizeof f->mem, STRIDE + 4), UB_ERR_INVAL);
    pair_free(f->p);
    free(f);
}

/* Every argument refusal, a record too small for the image (each delivery dropped, counted), detaching
 * (deliveries no longer recorded) and send_many's edge cases (issue #29 item 6). */
static void refusals_small_records_and_detach(void **state) {
    (void)state;
    fixture_t *f = setup_ring(0);
    ub_rxring_t r2;
    assert_int_equal(ub_rxring_init(NULL, f->mem, sizeof f->mem, STRIDE), UB_ERR_INVAL);
    assert_int_equal(ub_rxring_init(&r2, NULL, sizeof f->mem, STRIDE), UB_ERR_INVAL);
    assert_int_equal(ub_rxring_init(&r2, f->mem, sizeof f->mem, UB_RXREC_HEADER), UB_ERR_INVAL);
    assert_int_equal(ub_rxring_attach(NULL, f->p->sub_node, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_rxring_attach(&r2, NULL, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_rxring_drain(NULL, f->out, 4), 0);
    assert_int_equal(ub_rxring_drain(&f->ring, NULL, 4), 0);
    assert_int_equal(ub_rxring_pending(NULL), 0);
    assert_int_equal(ub_rxring_get_counters(NULL).recorded, 0);

    /* A stride whose image room (8 bytes) is smaller than gpsOut's image: each delivery dropped, counted. */
    assert_int_equal(ub_rxring_init(&f->ring, f->mem, sizeof f->mem, UB_RXREC_HEADER + 8u), 0);
    assert_int_equal(ub_rxring_attach(&f->ring, f->p->sub_node, NULL, NULL), 0);
    burst(f, 3);
    ub_rxring_counters_t c = ub_rxring_get_counters(&f->ring);
    assert_int_equal(c.recorded, 0);
    assert_int_equal(c.dropped, 3);
    assert_int_equal(ub_rxring_pending(&f->ring), 0);

    /* Detached: the node delivers as before, the ring records nothing. */
    ub_rxring_detach(&f->ring);
    burst(f, 2);
    assert_int_equal(ub_rxring_get_counters(&f->ring).dropped, 3);
    ub_rxring_detach(&f->ring); /* twice: nothing */
    ub_rxring_detach(NULL);

    uint32_t v = 7;
    assert_int_equal(ub_send_many(NULL, f->p->pub, TEST_GPS, f->p->sub_id, 0, 0, 4, (const uint8_t *)&v, 1), UB_ERR_INVAL);
    assert_int_equal(ub_send_many(f->p->pub_node, f->p->pub, TEST_GPS, NULL, 0, 0, 4, (const uint8_t *)&v, 1), UB_ERR_INVAL);
    assert_int_equal(ub_send_many(f->p->pub_node, f->p->pub, TEST_GPS, f->p->sub_id, 0, 0, 4, NULL, 1), UB_ERR_INVAL);
    assert_int_equal(ub_send_many(f->p->pub_node, f->p->pub, 99, f->p->sub_id, 0, 0, 4, (const uint8_t *)&v, 1),
                     UB_ERR_NOTFOUND);
    assert_int_equal(ub_send_many(f->p->pub_node, f->p->pub, TEST_GPS, f->p->sub_id, 0, 0, 4, (const uint8_t *)&v, 0), 0);
    /* size 0: the storage as it is, sent n times */
    assert_int_equal(ub_send_many(f->p->pub_node, f->p->pub, TEST_GPS, f->p->sub_id, 0, 0, 0, NULL, 2), 2);
    assert_int_equal(ub_memlink_pump(f->p->ml, 0), 2);
    /* A send the node refuses (an entity that is not local) ends the loop with its code. */
    assert_true(ub_send_many(f->p->pub_node, 99, TEST_GPS, f->p->sub_id, 0, 0, 4, (const uint8_t *)&v, 3) < 0);
    pair_free(f->p);
    free(f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(burst_larger_than_the_ring_loses_nothing_and_keeps_order),
        cmocka_unit_test(without_spill_the_overflow_is_dropped_and_counted),
        cmocka_unit_test(ring_wraps_in_order),
        cmocka_unit_test(send_many_sends_each_value_in_order),
        cmocka_unit_test(refusals_small_records_and_detach),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

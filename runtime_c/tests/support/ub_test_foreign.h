/* An application's handler of foreign bytes (ub_serial_set_foreign, ub_tcp_set_foreign) that takes every run
 * whole and keeps it, so a test compares what the driver handed over with what the far end wrote. Shared by
 * test_serial_edges and test_tcp_edges. Header-only, included after <cmocka.h>; each test file has its own copy. */
#ifndef UB_TEST_FOREIGN_H
#define UB_TEST_FOREIGN_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

typedef struct handler {
    uint8_t got[512];
    size_t len;
} handler_t;

/* Appends the run to h->got (the test fails if more arrives than it holds); takes all of it. */
static inline size_t on_foreign(void *user, const uint8_t *run, size_t len) {
    handler_t *h = user;
    assert_true(h->len + len <= sizeof h->got);
    memcpy(h->got + h->len, run, len);
    h->len += len;
    return len;
}

#endif /* UB_TEST_FOREIGN_H */

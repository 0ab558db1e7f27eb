/* A durable store for a security context's counter mark, in memory ("the counter file" of the security
 * tests): ub_sec_options_t.reserve = store_reserve, reserve_user = &store; set `fail` to make storing fail. */
#ifndef UB_TEST_STORE_H
#define UB_TEST_STORE_H

#include <stdint.h>

#include "ub/ub_error.h"

typedef struct store {
    uint64_t mark;
    int fail;
    int calls;
} store_t;

static inline int store_reserve(void *user, uint64_t mark) {
    store_t *s = user;
    s->calls++;
    if (s->fail) return UB_ERR_IO;
    s->mark = mark;
    return UB_OK;
}

#endif /* UB_TEST_STORE_H */

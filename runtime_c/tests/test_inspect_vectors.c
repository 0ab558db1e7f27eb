/* Conformance: the remote-inspection payloads (INSPECT request, INSPECT_VALUE head, LIST records) built
 * by the C encoders from tests/vectors/inspect.json's fields match the independent Python reference
 * (tests/vectors/make_inspect_vectors.py) byte for byte. Python's decoder reads the same file back
 * (tests/unit/test_vectors_inspect.py). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_inspect.h"
#include "ub_inspect_vectors.h" /* generated from tests/vectors/inspect.json (inspect.cmake) */

static size_t build(const inspect_vector_t *v, uint8_t *out, size_t cap) {
    const uint32_t *n = v->n;
    if (strcmp(v->kind, "request") == 0) {
        ub_inspect_spec_t s;
        memset(&s, 0, sizeof s);
        s.op = (uint8_t)n[1];
        s.arg = (uint8_t)n[2];
        s.offset = (uint16_t)n[3];
        s.value = n[4];
        if (s.op == UB_INSPECT_WRITE) {
            s.len = (uint16_t)v->blob_len[0];
            memcpy(s.data, v->blob[0], v->blob_len[0]);
        } else if (s.op == UB_INSPECT_SET_MASK) {
            assert_int_equal(v->blob_len[0], UB_ENTITY_ID_LEN);
            memcpy(s.subject, v->blob[0], UB_ENTITY_ID_LEN);
        } else {
            assert_int_equal(v->blob_len[0], 0); /* nothing follows the fixed part */
        }
        /* too small a buffer is refused, never overrun */
        assert_int_equal(ub_inspect_put_request(out, v->len - 1, n[0], &s), 0);
        return ub_inspect_put_request(out, cap, n[0], &s);
    }
    if (strcmp(v->kind, "value") == 0) {
        ub_inspect_put_value_head(out, n[0], (uint8_t)n[1], (uint8_t)n[2], (uint16_t)n[3], (uint16_t)n[4],
                                  (uint16_t)n[5]);
        memcpy(out + UB_INSPECT_VAL_DATA, v->blob[0], v->blob_len[0]);
        return UB_INSPECT_VAL_DATA + v->blob_len[0];
    }
    if (strcmp(v->kind, "entity") == 0) {
        ub_inspect_entity_rec_t r = {.local = (uint8_t)n[0], .mask = (uint8_t)n[1], .pinned = (uint8_t)n[2]};
        memcpy(r.id, v->blob[0], UB_ENTITY_ID_LEN);
        ub_inspect_put_entity_rec(out, &r);
        return UB_INSPECT_ENTITY_REC;
    }
    if (strcmp(v->kind, "link") == 0) {
        ub_inspect_link_rec_t r = {.index = (uint8_t)n[0], .attached = (uint8_t)n[1], .frames_in = n[2],
                                   .frames_out = n[3], .bytes_in = n[4], .bytes_out = n[5], .drops = n[6],
                                   .accepted = n[7]};
        memset(r.name, 'X', sizeof r.name); /* only the name's bytes up to its NUL may travel */
        memcpy(r.name, v->blob[0], v->blob_len[0]);
        r.name[v->blob_len[0]] = '\0';
        ub_inspect_put_link_rec(out, &r);
        return UB_INSPECT_LINK_REC;
    }
    if (strcmp(v->kind, "pubsub") == 0) {
        ub_inspect_pubsub_rec_t r = {.row = (uint16_t)n[0], .kind = (uint8_t)n[1], .state = (uint8_t)n[2],
                                     .period_ms = n[3], .frames = n[4]};
        memcpy(r.dir_id, v->blob[0], UB_DIR_ID_LEN);
        memcpy(r.peer, v->blob[1], UB_ENTITY_ID_LEN);
        memcpy(r.owner, v->blob[2], UB_ENTITY_ID_LEN);
        ub_inspect_put_pubsub_rec(out, &r);
        return UB_INSPECT_PUBSUB_REC;
    }
    assert_string_equal(v->kind, "admin");
    ub_inspect_admin_rec_t r = {.row = (uint16_t)n[0], .type = (uint8_t)n[1], .status = (uint8_t)n[2],
                                .period_ms = n[3], .active = (uint8_t)n[4], .nack_reason = (uint8_t)n[5]};
    memcpy(r.dir_id, v->blob[0], UB_DIR_ID_LEN);
    memcpy(r.source, v->blob[1], UB_ENTITY_ID_LEN);
    memcpy(r.destination, v->blob[2], UB_ENTITY_ID_LEN);
    ub_inspect_put_admin_rec(out, &r);
    return UB_INSPECT_ADMIN_REC;
}

static void test_c_encoders_match_reference_byte_for_byte(void **state) {
    (void)state;
    assert_true(INSPECT_VECTOR_COUNT >= 14);
    for (size_t i = 0; i < INSPECT_VECTOR_COUNT; i++) {
        const inspect_vector_t *v = &inspect_vectors[i];
        uint8_t out[UB_MAX_PAYLOAD];
        memset(out, 0xEE, sizeof out); /* reserved bytes must be written as 0, not left */
        print_message("vector %s (%s, %zu bytes)\n", v->name, v->kind, v->len);
        assert_int_equal(build(v, out, sizeof out), v->len);
        assert_memory_equal(out, v->bytes, v->len);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_c_encoders_match_reference_byte_for_byte),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

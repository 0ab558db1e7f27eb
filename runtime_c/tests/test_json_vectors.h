/* Reading a shared vector file (a tests/vectors JSON file) in a C vector test, with the runtime's own JSON reader
 * (codec/ub_json.h): the document, its root, and the member look-ups every vector test makes. Header-only, for
 * one test program each (its state is the including file's: `vec_doc`, `vec_root`). */
#ifndef TEST_JSON_VECTORS_H
#define TEST_JSON_VECTORS_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codec/ub_json.h"

static char *vec_text;
static ub_json_doc_t vec_doc;
static ub_json_value_t vec_root;

/* Reads and checks `path` (relative to the source tree: ctest runs there). @return 0, or -1. */
static inline int vec_load(const char *path) {
    FILE *fp = fopen(path, "rb");
    if (fp == NULL) return -1;
    fseek(fp, 0, SEEK_END);
    long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    vec_text = malloc((size_t)n + 1);
    if (vec_text == NULL || fread(vec_text, 1, (size_t)n, fp) != (size_t)n) {
        fclose(fp);
        return -1;
    }
    fclose(fp);
    uint32_t line;
    char msg[128];
    return ub_json_parse(&vec_doc, vec_text, (size_t)n, &vec_root, &line, msg, sizeof msg) != 0 ? -1 : 0;
}

static inline void vec_free(void) {
    free(vec_text);
    vec_text = NULL;
}

static inline bool member(const ub_json_value_t *obj, const char *key, ub_json_value_t *out) {
    ub_json_iter_t it;
    ub_json_value_t k, v;
    char name[64];
    ub_json_iter_begin(&it, &vec_doc, obj);
    while (ub_json_iter_next(&it, &k, &v)) {
        ub_json_string(&vec_doc, &k, name, sizeof name);
        if (strcmp(name, key) == 0) {
            *out = v;
            return true;
        }
    }
    return false;
}

static inline ub_json_value_t get(const ub_json_value_t *obj, const char *key) {
    ub_json_value_t v;
    if (!member(obj, key, &v)) fail_msg("missing key %s", key);
    return v;
}

static inline long long num(const ub_json_value_t *obj, const char *key) {
    ub_json_value_t v = get(obj, key);
    return strtoll(vec_doc.text + v.start, NULL, 10);
}

static inline size_t str(const ub_json_value_t *obj, const char *key, char *out, size_t cap) {
    ub_json_value_t v = get(obj, key);
    return ub_json_string(&vec_doc, &v, out, cap);
}

/* A hex text into bytes; asserts it is hex of even length that fits. @return the byte count. */
static inline size_t unhex(const char *text, size_t n, uint8_t *out, size_t cap) {
    assert_true(n % 2 == 0 && n / 2 <= cap);
    for (size_t i = 0; i < n / 2; i++) {
        unsigned b = 0;
        assert_int_equal(sscanf(text + 2 * i, "%2x", &b), 1);
        out[i] = (uint8_t)b;
    }
    return n / 2;
}

static inline size_t hex(const ub_json_value_t *obj, const char *key, uint8_t *out, size_t cap) {
    static char buf[8192];
    size_t n = str(obj, key, buf, sizeof buf);
    assert_true(n < sizeof buf);
    return unhex(buf, n, out, cap);
}

#endif /* TEST_JSON_VECTORS_H */

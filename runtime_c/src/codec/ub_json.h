/**
 * @file ub_json.h
 * @brief Private, allocation-free JSON reader used by the node-config loader.
 *
 * Not a public header: it lives next to its .c file in runtime_c/src/.
 *
 * Usage: ub_json_parse() checks the whole document once (RFC 8259 grammar,
 * nesting at most UB_JSON_MAX_DEPTH) and returns the root value. Values are
 * (kind, byte range, line) views into the caller's text; nothing is copied.
 * Containers are then walked with ub_json_iter_begin()/ub_json_iter_next(),
 * which re-scan the already-checked text and therefore cannot fail. Strings are
 * decoded (escapes, \\u surrogate pairs to UTF-8) on demand into caller buffers.
 *
 * Error messages start with "invalid JSON: " and carry no file name or line;
 * the line is returned separately so the caller can prefix "file:line: ".
 * runtime_py/uavbus/config.py reproduces these messages word for word.
 */
#ifndef UB_JSON_H
#define UB_JSON_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** Deepest nesting of objects/arrays accepted; bounds the checker's recursion. */
#define UB_JSON_MAX_DEPTH 32

typedef enum ub_json_kind {
    UB_JSON_OBJECT = 1,
    UB_JSON_ARRAY,
    UB_JSON_STRING,
    UB_JSON_NUMBER,
    UB_JSON_TRUE,
    UB_JSON_FALSE,
    UB_JSON_NULL
} ub_json_kind_t;

/** A value inside the document: text[start, end) including quotes or brackets. */
typedef struct ub_json_value {
    ub_json_kind_t kind;
    size_t start;
    size_t end;
    uint32_t line; /**< 1-based line of the value's first byte */
} ub_json_value_t;

/** The checked document: a view of the caller's text, which must outlive it. */
typedef struct ub_json_doc {
    const char *text;
    size_t len;
} ub_json_doc_t;

/** Cursor over the members of an object or the elements of an array. */
typedef struct ub_json_iter {
    const ub_json_doc_t *doc;
    size_t pos;
    uint32_t line;
    bool is_object;
} ub_json_iter_t;

/**
 * Checks `text[0, len)` as one JSON document and returns its root value.
 * @return 0, or UB_ERR_CONFIG with `*err_line` and `msg` (NUL-terminated,
 *         truncated to `msg_cap`) describing the first syntax error.
 */
int ub_json_parse(ub_json_doc_t *doc, const char *text, size_t len, ub_json_value_t *root,
                  uint32_t *err_line, char *msg, size_t msg_cap);

/** Starts iterating `container` (an object or array of a checked document). */
void ub_json_iter_begin(ub_json_iter_t *it, const ub_json_doc_t *doc, const ub_json_value_t *container);

/**
 * Advances to the next member. For objects `key` receives the key string
 * value; for arrays `key` may be NULL and is left untouched.
 * @return true if a member was produced, false at the end of the container.
 */
bool ub_json_iter_next(ub_json_iter_t *it, ub_json_value_t *key, ub_json_value_t *value);

/**
 * Decodes string value `v` into `out` (always NUL-terminated when cap > 0).
 * @return the full decoded length in bytes; the text fits iff result < cap.
 *         An escaped NUL (\\u0000) is decoded as a 0 byte, so callers that need
 *         C strings compare the result with strlen(out).
 */
size_t ub_json_string(const ub_json_doc_t *doc, const ub_json_value_t *v, char *out, size_t cap);

#ifdef __cplusplus
}
#endif
#endif /* UB_JSON_H */

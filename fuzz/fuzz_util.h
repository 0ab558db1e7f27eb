/*
 * Shared by the fuzz harnesses (fuzz/README.md): a cursor over the fuzzer's input, and FUZZ_CHECK, which
 * turns a broken property into a crash the fuzzer reports (and the replay test fails on). Harnesses keep
 * their large state in statics: a harness is a program, not library code.
 */
#ifndef UB_FUZZ_UTIL_H
#define UB_FUZZ_UTIL_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* A property the harness asserts: reported with where and what, then abort() (a crash for libFuzzer). */
#define FUZZ_CHECK(cond, ...)                                                             \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            fprintf(stderr, "%s:%d: property failed: %s: ", __FILE__, __LINE__, #cond);   \
            fprintf(stderr, __VA_ARGS__);                                                 \
            fputc('\n', stderr);                                                          \
            abort();                                                                      \
        }                                                                                 \
    } while (0)

/* A result the harness does not look at (any error code is a fine outcome for hostile input); gcc does not
 * let a (void) cast silence warn_unused_result. */
static inline void fuzz_ignore(int rc) { (void)rc; }

typedef struct fuzz_in {
    const uint8_t *p;
    size_t left;
} fuzz_in_t;

static inline uint8_t fuzz_u8(fuzz_in_t *in) {
    if (in->left == 0) return 0;
    in->left--;
    return *in->p++;
}

static inline uint16_t fuzz_u16(fuzz_in_t *in) {
    uint16_t lo = fuzz_u8(in);
    return (uint16_t)(lo | (uint16_t)fuzz_u8(in) << 8);
}

/* Up to `want` bytes (fewer at the end of the input); *got says how many. */
static inline const uint8_t *fuzz_bytes(fuzz_in_t *in, size_t want, size_t *got) {
    const uint8_t *p = in->p;
    *got = want < in->left ? want : in->left;
    in->p += *got;
    in->left -= *got;
    return p;
}

/* Writes a seed input file `dir/name` (the harnesses' --seed mode, fuzz/replay_main.c). */
static inline void fuzz_write_seed(const char *dir, const char *name, const void *data, size_t len) {
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (f == NULL || fwrite(data, 1, len, f) != len || fclose(f) != 0) {
        fprintf(stderr, "%s: cannot write the seed\n", path);
        exit(1);
    }
}

#endif /* UB_FUZZ_UTIL_H */

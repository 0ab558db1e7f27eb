/*
 * A main() for the fuzz harnesses without libFuzzer (any compiler, e.g. gcc with coverage or ASan):
 *
 *   fuzz_X FILE|DIR...     runs every input (directories: every regular file in them) once, in order;
 *                          a broken property aborts, so `ctest` fails on a corpus file that crashes
 *   fuzz_X --seed DIR      writes the harness's seed inputs into DIR (made with our own encoders)
 *   fuzz_X --known DIR     (fuzz_codecs) checks that every recorded known issue still reproduces
 *
 * libFuzzer builds link the same harness with -fsanitize=fuzzer instead of this file.
 */
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerInitialize(int *argc, char ***argv);
void ub_fuzz_write_seeds(const char *dir);
/* Only fuzz_codecs has it: 0 when a known issue's reproducer still fails, else 1 (see fuzz_codecs.c). */
__attribute__((weak)) int ub_fuzz_known_still_fail(const uint8_t *data, size_t size);

static int (*g_run)(const uint8_t *, size_t) = LLVMFuzzerTestOneInput;
static int g_failures;

static size_t run_file(const char *path) {
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        fprintf(stderr, "%s: cannot open\n", path);
        exit(1);
    }
    static uint8_t buf[1 << 22];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    /* A copy of exactly n bytes, so ASan sees reads past the input as what they are. */
    uint8_t *copy = malloc(n > 0 ? n : 1);
    if (copy == NULL) exit(1);
    memcpy(copy, buf, n);
    g_failures += g_run(copy, n) != 0;
    free(copy);
    return 1;
}

static int by_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

static size_t run_path(const char *path) {
    struct stat st;
    if (stat(path, &st) != 0) {
        fprintf(stderr, "%s: no such file or directory\n", path);
        exit(1);
    }
    if (!S_ISDIR(st.st_mode)) return run_file(path);
    DIR *d = opendir(path);
    if (d == NULL) exit(1);
    char **names = NULL;
    size_t n = 0, cap = 0;
    for (struct dirent *e = readdir(d); e != NULL; e = readdir(d)) {
        if (e->d_name[0] == '.') continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            names = realloc(names, cap * sizeof *names);
            if (names == NULL) exit(1);
        }
        size_t len = strlen(path) + strlen(e->d_name) + 2;
        names[n] = malloc(len);
        if (names[n] == NULL) exit(1);
        snprintf(names[n++], len, "%s/%s", path, e->d_name);
    }
    closedir(d);
    qsort(names, n, sizeof *names, by_name); /* the same order on every machine */
    size_t runs = 0;
    for (size_t i = 0; i < n; i++) {
        struct stat fst;
        if (stat(names[i], &fst) == 0 && S_ISREG(fst.st_mode)) runs += run_file(names[i]);
        free(names[i]);
    }
    free(names);
    return runs;
}

int main(int argc, char **argv) {
    if (argc == 3 && strcmp(argv[1], "--seed") == 0) {
        ub_fuzz_write_seeds(argv[2]);
        return 0;
    }
    if (argc < 2) {
        fprintf(stderr, "usage: %s FILE|DIR... | --seed DIR\n", argv[0]);
        return 2;
    }
    (void)LLVMFuzzerInitialize(&argc, &argv);
    int first = 1;
    if (strcmp(argv[1], "--known") == 0) {
        if (ub_fuzz_known_still_fail == NULL) {
            fprintf(stderr, "%s: this harness records no known issues\n", argv[0]);
            return 2;
        }
        g_run = ub_fuzz_known_still_fail;
        first = 2;
    }
    size_t runs = 0;
    for (int i = first; i < argc; i++) runs += run_path(argv[i]);
    if (g_failures > 0) {
        fprintf(stderr, "%s: %d of %zu known issues no longer reproduce as recorded\n", argv[0], g_failures, runs);
        return 1;
    }
    printf("%s: %zu inputs replayed%s\n", argv[0], runs, first == 2 ? ", every known issue still reproduces" : ", no property broken");
    return 0;
}

/* cffi cdef for runtime_c/include/ub/ub_secfile.h: key files and the counter file (POSIX, in C). */

#define UB_SECFILE_ERR_LEN ...

/* Opaque here: its size comes from the compiler; the mark is read with ub_counter_file_mark(). */
struct ub_counter_file {
    ...;
};

int ub_keyfile_parse(const char *text, size_t len, const char *source, uint8_t *id, uint8_t key[], char *err,
                     size_t err_cap);
int ub_keyfile_load(const char *path, uint8_t *id, uint8_t key[], char *err, size_t err_cap);
int ub_keyfile_write(const char *path, uint8_t id, const uint8_t key[], char *err, size_t err_cap);
int ub_keyfile_new(const char *path, uint8_t id, uint8_t *id_out, char *err, size_t err_cap);
int ub_counter_file_open(ub_counter_file_t *cf, const char *path, uint64_t *mark, char *err, size_t err_cap);
int ub_counter_file_reserve(void *user, uint64_t mark);
uint64_t ub_counter_file_mark(const ub_counter_file_t *cf);

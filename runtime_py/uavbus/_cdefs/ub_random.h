/* cffi cdef for runtime_c/include/ub/ub_random.h: the POSIX source of request ids, which Node passes to
 * every node it creates (ub_random_fn itself is declared in ub_node.h, which loads first). */

int ub_random_os(void *user, uint8_t *out, size_t len);

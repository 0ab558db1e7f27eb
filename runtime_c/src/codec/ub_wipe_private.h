/*
 * Erasing secrets (keys, seeds, derived pair keys) from caller-owned memory, one definition for every
 * file that holds one (ub_sec.c, ub_ident.c, ub_identfile.c, ub_secfile.c, ub_origin.c). With libsodium,
 * sodium_memzero(); without it, a byte loop through a volatile pointer, which the compiler may not drop
 * as a dead store. Not installed.
 */
#ifndef UB_WIPE_PRIVATE_H
#define UB_WIPE_PRIVATE_H

#include <stddef.h>
#include <stdint.h>

#if defined(UB_SECURITY) && UB_SECURITY
#include <sodium.h>
#endif

static inline void ub_priv_wipe(void *p, size_t n) {
#if defined(UB_SECURITY) && UB_SECURITY
    sodium_memzero(p, n);
#else
    volatile uint8_t *v = p;
    while (n--) *v++ = 0;
#endif
}

#endif

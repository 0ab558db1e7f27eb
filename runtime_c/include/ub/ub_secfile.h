/**
 * @file ub_secfile.h
 * @brief Security files (POSIX): key files, and the counter file that makes
 *        a node's freshness counter survive restarts (docs/security.md).
 *
 * **Key file**: text, one key per file, written mode 0600:
 *
 *     # uavbus key (docs/security.md). Secret: keep mode 0600, never commit it.
 *     uavbus-key 1 id=7 5c445aed55e5ed68e0a7cdabd0c8ec221fd43b69310bd79099874807c8d53a71
 *
 * `uavbus-key`, the format version 1, `id=` 1..255, then 64 hex digits (32
 * bytes). Blank lines and lines starting with `#` are ignored. A file that
 * group or others may read (or write) is refused before it is read, as ssh
 * does: "FILE: ... (chmod 600 FILE)". Every other problem is reported as
 * "FILE:LINE: what is wrong (what to do)".
 *
 * **Counter file**: "uavbus-counter 1 <mark>\n". ub_counter_file_reserve() is
 * a ub_sec_reserve_fn: it writes the new mark to "<path>.tmp", fsyncs it,
 * renames it over the file and fsyncs the directory, so after a crash the
 * file holds either the old or the new mark, never a torn one.
 *
 * Everything here uses open/read/write (no stdio, no allocation).
 */
#ifndef UB_SECFILE_H
#define UB_SECFILE_H

#include <stddef.h>
#include <stdint.h>

#include "ub_error.h"
#include "ub_sec.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Recommended size of the error buffers passed here. */
#define UB_SECFILE_ERR_LEN 320
/** Longest path kept (a counter file's path, with ".tmp"). */
#define UB_SECFILE_PATH_MAX 256
/** Largest key file read. */
#define UB_KEYFILE_MAX 4096

/**
 * Parses key-file text `text[0, len)`; `source` names it in messages.
 * @return UB_OK (`*id`, `key` set); UB_ERR_CONFIG ("source:line: ..." in `err`);
 *         UB_ERR_INVAL (NULL argument).
 */
UB_CHECK int ub_keyfile_parse(const char *text, size_t len, const char *source, uint8_t *id,
                              uint8_t key[UB_SEC_KEY_LEN], char *err, size_t err_cap);

/**
 * Reads and parses the key file `path`, refusing one that is not a regular
 * file or that group or others can access.
 * @return UB_OK; UB_ERR_CONFIG (permissions or content; `err` says what to
 *         do); UB_ERR_IO (cannot open or read); UB_ERR_INVAL.
 */
UB_CHECK int ub_keyfile_load(const char *path, uint8_t *id, uint8_t key[UB_SEC_KEY_LEN], char *err, size_t err_cap);

/**
 * Writes a new key file, mode 0600. Never overwrites: an existing `path` is
 * UB_ERR_EXISTS. Data and file are fsync'ed before returning.
 * @return UB_OK; UB_ERR_EXISTS; UB_ERR_IO; UB_ERR_INVAL (NULL, id 0).
 */
UB_CHECK int ub_keyfile_write(const char *path, uint8_t id, const uint8_t key[UB_SEC_KEY_LEN], char *err,
                              size_t err_cap);

/**
 * Makes a new random key (libsodium) and writes it with ub_keyfile_write().
 * `id` 0 picks a random id 1..255; the id used is returned in `*id_out`.
 * @return as ub_keyfile_write(), or UB_ERR_UNSUPPORTED (built without security).
 */
UB_CHECK int ub_keyfile_new(const char *path, uint8_t id, uint8_t *id_out, char *err, size_t err_cap);

/** A counter file. Caller-owned; treat the fields as private. */
typedef struct ub_counter_file {
    char path[UB_SECFILE_PATH_MAX];
    uint64_t mark;       /**< last mark read or stored */
    uint64_t writes;     /**< marks stored */
    uint64_t failures;   /**< marks that could not be stored */
    int last_errno;      /**< errno of the last failure */
} ub_counter_file_t;

/**
 * Opens counter file `path` and reads its mark into `*mark` (0 when the file
 * does not exist yet: a first start). Nothing is created until the first
 * reservation.
 * @return UB_OK; UB_ERR_CONFIG (unreadable content: "path:1: ..."); UB_ERR_IO;
 *         UB_ERR_RANGE (path too long); UB_ERR_INVAL.
 */
UB_CHECK int ub_counter_file_open(ub_counter_file_t *cf, const char *path, uint64_t *mark, char *err,
                                  size_t err_cap);

/** ub_sec_reserve_fn over a ub_counter_file_t (`user`): stores `mark` durably. @return UB_OK or UB_ERR_IO. */
int ub_counter_file_reserve(void *user, uint64_t mark);

/** @return the last mark read or stored (0: none yet, or NULL). */
uint64_t ub_counter_file_mark(const ub_counter_file_t *cf);

#ifdef __cplusplus
}
#endif
#endif /* UB_SECFILE_H */

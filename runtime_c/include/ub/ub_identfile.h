/**
 * @file ub_identfile.h
 * @brief Identity files (POSIX): an entity's identity (certificate + secret keys), the fleet
 *        authority's key pair, and the revocations file a node persists (docs/security.md,
 *        "Identity per entity"; byte layouts in docs/wire-format.md#identity-files).
 *
 * All four are small binary files with an 8-byte header: a 4-byte magic, the format version (1) and
 * three zero bytes.
 *
 * | file | magic | after the header | mode |
 * |---|---|---|---|
 * | identity (`uavbus keys issue`) | `UBID` | certificate (176 B), Ed25519 seed (32 B), X25519 secret (32 B) | 0600, enforced |
 * | authority secret (`uavbus keys authority create`) | `UBAK` | Ed25519 seed (32 B) | 0600, enforced |
 * | authority public | `UBAP` | Ed25519 public key (32 B) | any |
 * | revocations | `UBRV` | revocation records (104 B each), 0 or more | any (records are signed) |
 * | certificates | `UBCS` | certificates (176 B each), one per entity: the fleet's public half | any (signed) |
 *
 * A secret file that group or others may access is refused before it is read, as key files are
 * (ub_secfile.h). Messages are one line, "FILE: what is wrong (what to do)": binary files have no
 * lines. Nothing here allocates; open/read/write/fsync/rename only.
 */
#ifndef UB_IDENTFILE_H
#define UB_IDENTFILE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_error.h"
#include "ub_ident.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Recommended size of the error buffers passed here. */
#define UB_IDENTFILE_ERR_LEN 320
#define UB_IDENTFILE_HEADER_LEN 8u
/** Identity file: header, certificate, Ed25519 seed, X25519 secret key. */
#define UB_IDENTFILE_LEN (UB_IDENTFILE_HEADER_LEN + UB_CERT_LEN + UB_IDENT_SEED_LEN + UB_IDENT_KX_SK_LEN)
/** Authority files (secret and public): header + 32 bytes. */
#define UB_AUTHFILE_LEN (UB_IDENTFILE_HEADER_LEN + 32u)
/** Certificates one certificates file holds (one per entity). */
#ifndef UB_CERTFILE_MAX_CERTS
#define UB_CERTFILE_MAX_CERTS 128
#endif
/** Largest certificates file read. */
#define UB_CERTFILE_MAX (UB_IDENTFILE_HEADER_LEN + UB_CERTFILE_MAX_CERTS * UB_CERT_LEN)
/** Largest revocations file read. */
#define UB_REVFILE_MAX (UB_IDENTFILE_HEADER_LEN + UB_IDENT_MAX_REVOCATIONS * UB_REVOCATION_LEN)

/**
 * Writes an identity file, mode 0600: never over an existing file unless `force` (then atomically:
 * a temporary file renamed over it). fsync'ed.
 * @return UB_OK; UB_ERR_EXISTS; UB_ERR_IO; UB_ERR_INVAL.
 */
UB_CHECK int ub_identfile_write(const char *path, const ub_cert_t *cert, const uint8_t sign_seed[UB_IDENT_SEED_LEN],
                                const uint8_t kx_sk[UB_IDENT_KX_SK_LEN], bool force, char *err, size_t err_cap);

/**
 * Reads an identity file: refused when group/other-accessible, of the wrong size or magic, when the
 * certificate does not decode, or when the secret keys are not the certificate's. The authority's
 * signature and the validity period are checked by ub_ident_set_self() (ub_identfile_load_store()).
 * @return UB_OK; UB_ERR_CONFIG (`err` says what to do); UB_ERR_IO; UB_ERR_INVAL; UB_ERR_UNSUPPORTED.
 */
UB_CHECK int ub_identfile_load(const char *path, ub_cert_t *cert, uint8_t sign_sk[UB_IDENT_SIGN_SK_LEN],
                               uint8_t kx_sk[UB_IDENT_KX_SK_LEN], char *err, size_t err_cap);

/** Writes the authority's secret file (0600, never overwriting). @return as ub_identfile_write(). */
UB_CHECK int ub_authfile_write_secret(const char *path, const uint8_t seed[UB_IDENT_SEED_LEN], char *err,
                                      size_t err_cap);

/** Writes the authority's public file (never overwriting unless `force`). @return as ub_identfile_write(). */
UB_CHECK int ub_authfile_write_public(const char *path, const uint8_t pk[UB_IDENT_SIGN_PK_LEN], bool force,
                                      char *err, size_t err_cap);

/** Reads the authority's secret file (mode checked) into libsodium's 64-byte secret key.
 *  @return UB_OK; UB_ERR_CONFIG; UB_ERR_IO; UB_ERR_INVAL; UB_ERR_UNSUPPORTED. */
UB_CHECK int ub_authfile_load_secret(const char *path, uint8_t sk[UB_IDENT_SIGN_SK_LEN], char *err, size_t err_cap);

/** Reads the authority's public file. @return UB_OK; UB_ERR_CONFIG; UB_ERR_IO; UB_ERR_INVAL. */
UB_CHECK int ub_authfile_load_public(const char *path, uint8_t pk[UB_IDENT_SIGN_PK_LEN], char *err, size_t err_cap);

/**
 * Adds every record of revocations file `path` to `store` (its authority set first). A missing file
 * is an empty list (a first start). A record that does not verify under the store's authority makes
 * the whole file refused ("FILE: record N ..."), as does a size that is not a whole number of records.
 * @return the number of records read (>= 0); UB_ERR_CONFIG; UB_ERR_IO; UB_ERR_INVAL; UB_ERR_FULL.
 */
UB_CHECK int ub_revfile_load(const char *path, ub_ident_store_t *store, char *err, size_t err_cap);

/**
 * Reads the records of revocations file `path` without judging them (an operator's file handed to a
 * node: ub_revoke_submit() verifies each): header and whole records checked, at most `cap` records.
 * @return the number of records copied to `records` (UB_REVOCATION_LEN bytes each); UB_ERR_CONFIG;
 *         UB_ERR_IO (also a missing file); UB_ERR_INVAL.
 */
UB_CHECK int ub_revfile_read(const char *path, uint8_t *records, size_t cap, char *err, size_t err_cap);

/** Writes every record of `store` to `path` atomically (temporary file, fsync, rename, directory fsync).
 *  @return UB_OK; UB_ERR_IO; UB_ERR_INVAL. */
UB_CHECK int ub_revfile_save(const char *path, const ub_ident_store_t *store, char *err, size_t err_cap);

/**
 * Puts certificate `cert` (UB_CERT_LEN bytes, decodable) into certificates file `path`, replacing the one
 * of the same entity, creating the file if needed; atomically. `uavbus keys issue` does it for every
 * identity it issues, so the file is the fleet's directory of public certificates.
 * @return UB_OK; UB_ERR_CONFIG (the file or the certificate is not one); UB_ERR_FULL; UB_ERR_IO; UB_ERR_INVAL.
 */
UB_CHECK int ub_certfile_put(const char *path, const uint8_t *cert, size_t len, char *err, size_t err_cap);

/**
 * Adds the certificates of file `path` to `store` (its authority set first): the peers a node knows. A
 * certificate of another authority, or that does not verify, makes the file refused ("FILE: certificate N
 * ..."); expired, not yet valid and revoked ones are skipped (counted in the store's stats: a directory
 * naturally holds them until it is reissued).
 * @return the number of certificates taken (>= 0); UB_ERR_CONFIG; UB_ERR_IO; UB_ERR_FULL; UB_ERR_INVAL.
 */
UB_CHECK int ub_certfile_load(const char *path, ub_ident_store_t *store, uint64_t now_s, char *err, size_t err_cap);

/** ub_revoke_persist_fn (ub_revoke.h) over ub_revfile_save(): `user` is the path (a NUL-terminated string). */
int ub_revfile_persist(void *user, const ub_ident_store_t *store);

/** The wall clock in unix seconds (time(NULL)), for ub_revoke_options_t.clock_s (`user` unused). */
uint64_t ub_identfile_unix_s(void *user);

/**
 * A routing destination filter (ub_route_options_t.accept_dest) over an identity store: `user` is the
 * `ub_ident_store_t`; accepts `dest` only if the store holds a valid, unrevoked certificate for it at the wall
 * clock (ub_identfile_unix_s()). An insider then cannot make a node learn entities that do not exist; it does
 * not stop false metrics for certified ones (docs/security.md, "Routing from insiders"). Used by
 * `uavbus_node --route certified=1` and Python's `node.routing.enable(certified=True)`.
 */
bool ub_identfile_route_certified(void *user, const uint8_t dest[UB_ENTITY_ID_LEN],
                                  const uint8_t neighbour[UB_ENTITY_ID_LEN], uint16_t metric);

/** ub_revoke_persist_cert_fn (ub_revoke.h) over ub_certfile_put(): `user` is the path. */
int ub_certfile_persist(void *user, const uint8_t *cert, size_t len);

/**
 * ub_policy_roles_fn (ub_policy.h) over a ub_ident_store_t (`store`) at the wall clock (time(NULL)):
 * ub_ident_peer_roles() for a node whose certificates are judged in real unix time.
 */
int ub_ident_roles_now(void *store, const uint8_t id[UB_ENTITY_ID_LEN], uint16_t *roles);

/**
 * Adds one of this node's identities from identity file `identity_path` (ub_identfile_load(), then
 * ub_ident_set_self()), refusing one that is expired, not yet valid, revoked (`revocations_path`, may be
 * NULL, only names the file in the message), of another authority or with a bad signature.
 * @return UB_OK; UB_ERR_CONFIG / UB_ERR_IO (`err`: "FILE: ..."); UB_ERR_INVAL; UB_ERR_UNSUPPORTED.
 */
UB_CHECK int ub_identfile_load_self(ub_ident_store_t *store, const char *identity_path, const char *revocations_path,
                                    uint64_t now_s, char *err, size_t err_cap);

/**
 * A node's identity set-up in one call: sets the authority from `authority_path` (public file),
 * loads the revocations (`revocations_path`, may be NULL), then this node's identity from
 * `identity_path` (may be NULL: a store that only verifies others), refusing one that is expired,
 * not yet valid, revoked, of another authority or with a bad signature, with what to do.
 * @return UB_OK; UB_ERR_CONFIG / UB_ERR_IO (`err`: "FILE: ..."); UB_ERR_INVAL; UB_ERR_UNSUPPORTED.
 */
UB_CHECK int ub_identfile_load_store(ub_ident_store_t *store, const char *identity_path, const char *authority_path,
                                     const char *revocations_path, uint64_t now_s, char *err, size_t err_cap);

#ifdef __cplusplus
}
#endif
#endif /* UB_IDENTFILE_H */

/* Identity files (contracts in ub/ub_identfile.h). POSIX open/read/write/fsync/rename only, like
 * ub_secfile.c: stdio may allocate, and the runtime never touches the heap. */
#include "ub/ub_identfile.h"
#include "codec/ub_wipe_private.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "ub/ub_wire.h"

#define MAGIC_IDENTITY "UBID"
#define MAGIC_AUTH_SECRET "UBAK"
#define MAGIC_AUTH_PUBLIC "UBAP"
#define MAGIC_REVOCATIONS "UBRV"
#define MAGIC_CERTIFICATES "UBCS"
#define PATH_CAP 512

#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
static int failf(char *err, size_t cap, int rc, const char *fmt, ...) {
    if (err != NULL && cap > 0) {
        va_list ap;
        va_start(ap, fmt);
        (void)vsnprintf(err, cap, fmt, ap);
        va_end(ap);
    }
    return rc;
}

static void put_header(uint8_t *out, const char *magic) {
    memcpy(out, magic, 4);
    out[4] = 1;
    out[5] = out[6] = out[7] = 0;
}

/* 0: the header is `magic` version 1; otherwise a message was written. */
static int check_header(const char *path, const uint8_t *buf, size_t len, const char *magic, const char *what,
                        const char *make, char *err, size_t cap) {
    if (len < UB_IDENTFILE_HEADER_LEN || memcmp(buf, magic, 4) != 0)
        return failf(err, cap, UB_ERR_CONFIG, "%s: not a uavbus %s file (make one with: %s)", path, what, make);
    if (buf[4] != 1 || buf[5] != 0 || buf[6] != 0 || buf[7] != 0)
        return failf(err, cap, UB_ERR_CONFIG,
                     "%s: %s file format %u is not supported (this build reads format 1; use a matching uavbus)", path,
                     what, (unsigned)buf[4]);
    return UB_OK;
}

/* Reads at most `cap` bytes of `path`; `secret`: refuse a file group or others may access, before reading. */
static int read_file(const char *path, uint8_t *buf, size_t cap, size_t *len, bool secret, bool missing_ok,
                     const char *what, char *err, size_t err_cap) {
    *len = 0;
    int fd = open(path, O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0 && errno == ENOENT && missing_ok) return 1;
    if (fd < 0) return failf(err, err_cap, UB_ERR_IO, "%s: cannot open the %s file: %s", path, what, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) < 0) {
        int e = errno;
        close(fd);
        return failf(err, err_cap, UB_ERR_IO, "%s: cannot stat the %s file: %s", path, what, strerror(e));
    }
    if (!S_ISREG(st.st_mode)) {
        close(fd);
        return failf(err, err_cap, UB_ERR_CONFIG, "%s: not a regular file (give the %s file itself)", path, what);
    }
    if (secret && (st.st_mode & 077) != 0) {
        close(fd);
        return failf(err, err_cap, UB_ERR_CONFIG,
                     "%s: mode %03o lets group or others access the %s file's secret keys; refusing it (chmod 600 %s)",
                     path, (unsigned)(st.st_mode & 0777), what, path);
    }
    for (;;) {
        ssize_t n = read(fd, buf + *len, cap - *len);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) {
            int e = errno;
            close(fd);
            return failf(err, err_cap, UB_ERR_IO, "%s: cannot read the %s file: %s", path, what, strerror(e));
        }
        if (n == 0) break;
        *len += (size_t)n;
        if (*len == cap) {
            uint8_t extra;
            ssize_t more = read(fd, &extra, 1);
            close(fd);
            if (more > 0)
                return failf(err, err_cap, UB_ERR_CONFIG, "%s: larger than %lu bytes: not a uavbus %s file", path,
                             (unsigned long)cap, what);
            return UB_OK;
        }
    }
    close(fd);
    return UB_OK;
}

static int write_all(int fd, const uint8_t *buf, size_t len) {
    size_t done = 0;
    while (done < len) {
        ssize_t n = write(fd, buf + done, len - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return UB_ERR_IO;
        done += (size_t)n;
    }
    return UB_OK;
}

static int fsync_dir(const char *path) {
    char dir[PATH_CAP];
    const char *slash = strrchr(path, '/');
    if (slash == NULL) {
        dir[0] = '.';
        dir[1] = '\0';
    } else {
        size_t n = slash == path ? 1 : (size_t)(slash - path);
        if (n >= sizeof dir) return UB_ERR_IO;
        memcpy(dir, path, n);
        dir[n] = '\0';
    }
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return UB_ERR_IO;
    int rc = fsync(fd) < 0 ? UB_ERR_IO : UB_OK;
    close(fd);
    return rc;
}

/* Writes `data` to `path` with `mode`: O_EXCL unless `replace`, then through "<path>.tmp" and rename. */
static int write_file(const char *path, const uint8_t *data, size_t len, mode_t mode, bool replace, const char *what,
                      const char *exists_hint, char *err, size_t cap) {
    char tmp[PATH_CAP];
    const char *target = path;
    int flags = O_WRONLY | O_CREAT | O_CLOEXEC | O_NOFOLLOW;
    if (replace) {
        if (strlen(path) + 5 > sizeof tmp) return failf(err, cap, UB_ERR_IO, "%s: path too long", path);
        (void)snprintf(tmp, sizeof tmp, "%s.tmp", path);
        target = tmp;
        flags |= O_TRUNC;
    } else {
        flags |= O_EXCL;
    }
    int fd = open(target, flags, mode);
    if (fd < 0 && errno == EEXIST)
        return failf(err, cap, UB_ERR_EXISTS, "%s: already exists (%s)", path, exists_hint);
    if (fd < 0) return failf(err, cap, UB_ERR_IO, "%s: cannot create the %s file: %s", path, what, strerror(errno));
    /* fchmod as well: a default ACL must not add permissions to a secret. */
    int rc = fchmod(fd, mode) < 0 || write_all(fd, data, len) != UB_OK || fsync(fd) < 0 ? UB_ERR_IO : UB_OK;
    int e = errno;
    if (close(fd) < 0 && rc == UB_OK) {
        rc = UB_ERR_IO;
        e = errno;
    }
    if (rc == UB_OK && replace && rename(tmp, path) < 0) {
        rc = UB_ERR_IO;
        e = errno;
    }
    if (rc == UB_OK) (void)fsync_dir(path);
    if (rc != UB_OK) {
        (void)unlink(target);
        return failf(err, cap, UB_ERR_IO, "%s: cannot write the %s file: %s", path, what, strerror(e));
    }
    return UB_OK;
}

/* ---- identity ---- */

int ub_identfile_write(const char *path, const ub_cert_t *cert, const uint8_t sign_seed[UB_IDENT_SEED_LEN],
                       const uint8_t kx_sk[UB_IDENT_KX_SK_LEN], bool force, char *err, size_t err_cap) {
    if (path == NULL || cert == NULL || sign_seed == NULL || kx_sk == NULL) return UB_ERR_INVAL;
    uint8_t buf[UB_IDENTFILE_LEN];
    put_header(buf, MAGIC_IDENTITY);
    int rc = ub_cert_encode(cert, buf + UB_IDENTFILE_HEADER_LEN);
    if (rc != UB_OK) return rc;
    memcpy(buf + UB_IDENTFILE_HEADER_LEN + UB_CERT_LEN, sign_seed, UB_IDENT_SEED_LEN);
    memcpy(buf + UB_IDENTFILE_HEADER_LEN + UB_CERT_LEN + UB_IDENT_SEED_LEN, kx_sk, UB_IDENT_KX_SK_LEN);
    rc = write_file(path, buf, sizeof buf, 0600, force, "identity",
                    "an identity is never overwritten: revoke the old one first, then issue with --force", err,
                    err_cap);
    ub_priv_wipe(buf, sizeof buf);
    return rc;
}

int ub_identfile_load(const char *path, ub_cert_t *cert, uint8_t sign_sk[UB_IDENT_SIGN_SK_LEN],
                      uint8_t kx_sk[UB_IDENT_KX_SK_LEN], char *err, size_t err_cap) {
    if (path == NULL || cert == NULL || sign_sk == NULL || kx_sk == NULL) return UB_ERR_INVAL;
    uint8_t buf[UB_IDENTFILE_LEN];
    size_t len;
    int rc = read_file(path, buf, sizeof buf, &len, true, false, "identity", err, err_cap);
    if (rc == UB_OK)
        rc = check_header(path, buf, len, MAGIC_IDENTITY, "identity", "uavbus keys issue ENTITY", err, err_cap);
    if (rc == UB_OK && len != UB_IDENTFILE_LEN)
        rc = failf(err, err_cap, UB_ERR_CONFIG, "%s: %lu bytes, an identity file has %u (damaged? issue it again: "
                   "uavbus keys issue ENTITY --force)", path, (unsigned long)len, (unsigned)UB_IDENTFILE_LEN);
    if (rc == UB_OK && ub_cert_decode(cert, buf + UB_IDENTFILE_HEADER_LEN, UB_CERT_LEN) != UB_OK)
        rc = failf(err, err_cap, UB_ERR_CONFIG,
                   "%s: the certificate is malformed (damaged? issue it again: uavbus keys issue ENTITY --force)", path);
    if (rc == UB_OK) {
        const uint8_t *seed = buf + UB_IDENTFILE_HEADER_LEN + UB_CERT_LEN;
        uint8_t pk[UB_IDENT_SIGN_PK_LEN], kx_pk[UB_IDENT_KX_PK_LEN];
        memcpy(kx_sk, seed + UB_IDENT_SEED_LEN, UB_IDENT_KX_SK_LEN);
        rc = ub_ident_sign_keypair(seed, pk, sign_sk);
        if (rc == UB_ERR_UNSUPPORTED)
            rc = failf(err, err_cap, rc, "%s: this build has no security (UAVBUS_SECURITY=OFF): identities need libsodium",
                       path);
        else if (rc != UB_OK || ub_ident_kx_public(kx_sk, kx_pk) != UB_OK ||
                 memcmp(pk, cert->sign_pk, sizeof pk) != 0 || memcmp(kx_pk, cert->kx_pk, sizeof kx_pk) != 0)
            rc = failf(err, err_cap, UB_ERR_CONFIG,
                       "%s: the secret keys are not the certificate's (a file put together from two identities? issue "
                       "it again: uavbus keys issue ENTITY --force)", path);
    }
    if (rc != UB_OK) {
        ub_priv_wipe(sign_sk, UB_IDENT_SIGN_SK_LEN);
        ub_priv_wipe(kx_sk, UB_IDENT_KX_SK_LEN);
    }
    ub_priv_wipe(buf, sizeof buf);
    return rc;
}

/* ---- authority ---- */

int ub_authfile_write_secret(const char *path, const uint8_t seed[UB_IDENT_SEED_LEN], char *err, size_t err_cap) {
    if (path == NULL || seed == NULL) return UB_ERR_INVAL;
    uint8_t buf[UB_AUTHFILE_LEN];
    put_header(buf, MAGIC_AUTH_SECRET);
    memcpy(buf + UB_IDENTFILE_HEADER_LEN, seed, UB_IDENT_SEED_LEN);
    int rc = write_file(path, buf, sizeof buf, 0600, false, "authority",
                        "an authority key is never overwritten: every identity it issued depends on it", err, err_cap);
    ub_priv_wipe(buf, sizeof buf);
    return rc;
}

int ub_authfile_write_public(const char *path, const uint8_t pk[UB_IDENT_SIGN_PK_LEN], bool force, char *err,
                             size_t err_cap) {
    if (path == NULL || pk == NULL) return UB_ERR_INVAL;
    uint8_t buf[UB_AUTHFILE_LEN];
    put_header(buf, MAGIC_AUTH_PUBLIC);
    memcpy(buf + UB_IDENTFILE_HEADER_LEN, pk, UB_IDENT_SIGN_PK_LEN);
    return write_file(path, buf, sizeof buf, 0644, force, "authority public key",
                      "choose another file name, or remove it first", err, err_cap);
}

int ub_authfile_load_secret(const char *path, uint8_t sk[UB_IDENT_SIGN_SK_LEN], char *err, size_t err_cap) {
    if (path == NULL || sk == NULL) return UB_ERR_INVAL;
    uint8_t buf[UB_AUTHFILE_LEN], pk[UB_IDENT_SIGN_PK_LEN];
    size_t len;
    int rc = read_file(path, buf, sizeof buf, &len, true, false, "authority", err, err_cap);
    if (rc == UB_OK)
        rc = check_header(path, buf, len, MAGIC_AUTH_SECRET, "authority secret key", "uavbus keys authority create",
                          err, err_cap);
    if (rc == UB_OK && len != UB_AUTHFILE_LEN)
        rc = failf(err, err_cap, UB_ERR_CONFIG, "%s: %lu bytes, an authority key file has %u (damaged: restore it from "
                   "its backup)", path, (unsigned long)len, (unsigned)UB_AUTHFILE_LEN);
    if (rc == UB_OK) {
        rc = ub_ident_sign_keypair(buf + UB_IDENTFILE_HEADER_LEN, pk, sk);
        if (rc != UB_OK) rc = failf(err, err_cap, rc, "%s: cannot derive the authority key (%s)", path, ub_strerror(rc));
    }
    ub_priv_wipe(buf, sizeof buf);
    return rc;
}

int ub_authfile_load_public(const char *path, uint8_t pk[UB_IDENT_SIGN_PK_LEN], char *err, size_t err_cap) {
    if (path == NULL || pk == NULL) return UB_ERR_INVAL;
    uint8_t buf[UB_AUTHFILE_LEN];
    size_t len;
    int rc = read_file(path, buf, sizeof buf, &len, false, false, "authority public key", err, err_cap);
    if (rc == UB_OK)
        rc = check_header(path, buf, len, MAGIC_AUTH_PUBLIC, "authority public key", "uavbus keys authority create",
                          err, err_cap);
    if (rc == UB_OK && len != UB_AUTHFILE_LEN)
        rc = failf(err, err_cap, UB_ERR_CONFIG, "%s: %lu bytes, an authority public key file has %u (copy it again "
                   "from the authority)", path, (unsigned long)len, (unsigned)UB_AUTHFILE_LEN);
    if (rc == UB_OK) memcpy(pk, buf + UB_IDENTFILE_HEADER_LEN, UB_IDENT_SIGN_PK_LEN);
    return rc;
}

/* ---- revocations ---- */

int ub_revfile_load(const char *path, ub_ident_store_t *store, char *err, size_t err_cap) {
    if (path == NULL || store == NULL) return UB_ERR_INVAL;
    uint8_t buf[UB_REVFILE_MAX];
    size_t len;
    int rc = read_file(path, buf, sizeof buf, &len, false, true, "revocations", err, err_cap);
    if (rc == 1) return 0; /* no file yet: nothing revoked */
    if (rc != UB_OK) return rc;
    if (len == 0) return 0;
    rc = check_header(path, buf, len, MAGIC_REVOCATIONS, "revocations", "uavbus keys revoke ENTITY", err, err_cap);
    if (rc != UB_OK) return rc;
    size_t body = len - UB_IDENTFILE_HEADER_LEN;
    if (body % UB_REVOCATION_LEN != 0)
        return failf(err, err_cap, UB_ERR_CONFIG,
                     "%s: %lu bytes after the header is not a whole number of %u-byte records (damaged: restore it, or "
                     "remove it and let the fleet spread the revocations again)",
                     path, (unsigned long)body, (unsigned)UB_REVOCATION_LEN);
    size_t n = body / UB_REVOCATION_LEN;
    for (size_t i = 0; i < n; i++) {
        ub_ident_status_t why;
        int r = ub_ident_add_revocation(store, buf + UB_IDENTFILE_HEADER_LEN + i * UB_REVOCATION_LEN,
                                        UB_REVOCATION_LEN, &why);
        if (r == UB_ERR_FULL)
            return failf(err, err_cap, UB_ERR_FULL, "%s: record %lu: more revoked entities than this build holds (%u, "
                         "UB_IDENT_MAX_REVOCATIONS in ub_ident.h)", path, (unsigned long)i + 1u,
                         (unsigned)UB_IDENT_MAX_REVOCATIONS);
        if (r == UB_ERR_AUTH)
            return failf(err, err_cap, UB_ERR_CONFIG, "%s: record %lu is %s (%s); this file is not this fleet's "
                         "revocations: check the authority file, or remove the record",
                         path, (unsigned long)i + 1u, ub_ident_status_name(why),
                         why == UB_IDENT_WRONG_AUTHORITY ? "signed by another authority" : "refused");
        if (r < 0 && r != UB_ERR_EXISTS) return failf(err, err_cap, r, "%s: record %lu: %s", path, (unsigned long)i + 1u,
                                                      ub_strerror(r));
    }
    return (int)n;
}

int ub_revfile_read(const char *path, uint8_t *records, size_t cap, char *err, size_t err_cap) {
    if (path == NULL || (records == NULL && cap > 0)) return UB_ERR_INVAL;
    uint8_t buf[UB_REVFILE_MAX];
    size_t len;
    int rc = read_file(path, buf, sizeof buf, &len, false, false, "revocations", err, err_cap);
    if (rc != UB_OK) return rc;
    rc = check_header(path, buf, len, MAGIC_REVOCATIONS, "revocations", "uavbus keys revoke ENTITY", err, err_cap);
    if (rc != UB_OK) return rc;
    size_t body = len - UB_IDENTFILE_HEADER_LEN;
    if (body % UB_REVOCATION_LEN != 0)
        return failf(err, err_cap, UB_ERR_CONFIG, "%s: %lu bytes after the header is not a whole number of %u-byte "
                     "records (damaged: write it again with uavbus keys revoke ENTITY)",
                     path, (unsigned long)body, (unsigned)UB_REVOCATION_LEN);
    size_t n = body / UB_REVOCATION_LEN;
    if (n > cap) n = cap;
    if (n > 0) memcpy(records, buf + UB_IDENTFILE_HEADER_LEN, n * UB_REVOCATION_LEN); /* records may be NULL with cap 0 */
    return (int)n;
}

int ub_revfile_save(const char *path, const ub_ident_store_t *store, char *err, size_t err_cap) {
    if (path == NULL || store == NULL) return UB_ERR_INVAL;
    uint8_t buf[UB_REVFILE_MAX];
    put_header(buf, MAGIC_REVOCATIONS);
    size_t n = ub_ident_revocation_count(store), len = UB_IDENTFILE_HEADER_LEN;
    for (size_t i = 0; i < n; i++, len += UB_REVOCATION_LEN) {
        int rc = ub_ident_revocation_at(store, i, buf + len);
        if (rc != UB_OK) return rc;
    }
    return write_file(path, buf, len, 0644, true, "revocations", "", err, err_cap);
}

/* ---- certificates ---- */

static int read_certs(const char *path, uint8_t *buf, size_t *n, bool missing_ok, char *err, size_t err_cap) {
    size_t len;
    *n = 0;
    int rc = read_file(path, buf, UB_CERTFILE_MAX, &len, false, missing_ok, "certificates", err, err_cap);
    if (rc == 1) return UB_OK;
    if (rc != UB_OK) return rc;
    rc = check_header(path, buf, len, MAGIC_CERTIFICATES, "certificates", "uavbus keys issue ENTITY", err, err_cap);
    if (rc != UB_OK) return rc;
    if ((len - UB_IDENTFILE_HEADER_LEN) % UB_CERT_LEN != 0)
        return failf(err, err_cap, UB_ERR_CONFIG, "%s: not a whole number of %u-byte certificates (damaged: copy it "
                     "again from the authority)", path, (unsigned)UB_CERT_LEN);
    *n = (len - UB_IDENTFILE_HEADER_LEN) / UB_CERT_LEN;
    return UB_OK;
}

int ub_certfile_put(const char *path, const uint8_t *cert, size_t len, char *err, size_t err_cap) {
    if (path == NULL || cert == NULL) return UB_ERR_INVAL;
    ub_cert_t c, old;
    if (ub_cert_decode(&c, cert, len) != UB_OK)
        return failf(err, err_cap, UB_ERR_CONFIG, "%s: the certificate to add is malformed", path);
    uint8_t buf[UB_CERTFILE_MAX];
    size_t n;
    int rc = read_certs(path, buf, &n, true, err, err_cap);
    if (rc != UB_OK) return rc;
    size_t at = n;
    for (size_t i = 0; i < n; i++) {
        const uint8_t *b = buf + UB_IDENTFILE_HEADER_LEN + i * UB_CERT_LEN;
        if (ub_cert_decode(&old, b, UB_CERT_LEN) == UB_OK && memcmp(old.entity, c.entity, UB_ENTITY_ID_LEN) == 0) at = i;
    }
    if (at == n) {
        if (n == UB_CERTFILE_MAX_CERTS)
            return failf(err, err_cap, UB_ERR_FULL, "%s: holds %u certificates already (UB_CERTFILE_MAX_CERTS)", path,
                         (unsigned)UB_CERTFILE_MAX_CERTS);
        n++;
    }
    put_header(buf, MAGIC_CERTIFICATES);
    memcpy(buf + UB_IDENTFILE_HEADER_LEN + at * UB_CERT_LEN, cert, UB_CERT_LEN);
    return write_file(path, buf, UB_IDENTFILE_HEADER_LEN + n * UB_CERT_LEN, 0644, true, "certificates", "", err,
                      err_cap);
}

int ub_certfile_load(const char *path, ub_ident_store_t *store, uint64_t now_s, char *err, size_t err_cap) {
    if (path == NULL || store == NULL) return UB_ERR_INVAL;
    uint8_t buf[UB_CERTFILE_MAX];
    size_t n;
    int rc = read_certs(path, buf, &n, false, err, err_cap);
    if (rc != UB_OK) return rc;
    int taken = 0;
    for (size_t i = 0; i < n; i++) {
        ub_ident_status_t why;
        rc = ub_ident_add_peer(store, buf + UB_IDENTFILE_HEADER_LEN + i * UB_CERT_LEN, UB_CERT_LEN, now_s, &why);
        if (rc == UB_OK) {
            taken++;
            continue;
        }
        if (rc == UB_ERR_FULL)
            return failf(err, err_cap, UB_ERR_FULL, "%s: certificate %lu: more peers than this build holds (%u, "
                         "UB_IDENT_MAX_PEERS in ub_ident.h)", path, (unsigned long)i + 1u, (unsigned)UB_IDENT_MAX_PEERS);
        if (why == UB_IDENT_EXPIRED || why == UB_IDENT_NOT_YET_VALID || why == UB_IDENT_REVOKED) continue;
        return failf(err, err_cap, UB_ERR_CONFIG, "%s: certificate %lu is %s; this is not this fleet's certificates "
                     "file: check the authority file, or issue the entity again", path, (unsigned long)i + 1u,
                     ub_ident_status_name(why));
    }
    return taken;
}

uint64_t ub_identfile_unix_s(void *user) {
    (void)user;
    time_t now = time(NULL);
    return now > 0 ? (uint64_t)now : 0u;
}

bool ub_identfile_route_certified(void *user, const uint8_t dest[UB_ENTITY_ID_LEN],
                                  const uint8_t neighbour[UB_ENTITY_ID_LEN], uint16_t metric) {
    (void)neighbour;
    (void)metric;
    return ub_ident_peer_status((const ub_ident_store_t *)user, dest, ub_identfile_unix_s(NULL)) == UB_IDENT_VALID;
}

int ub_certfile_persist(void *user, const uint8_t *cert, size_t len) {
    return ub_certfile_put((const char *)user, cert, len, NULL, 0);
}

int ub_ident_roles_now(void *store, const uint8_t id[UB_ENTITY_ID_LEN], uint16_t *roles) {
    time_t now = time(NULL);
    return ub_ident_peer_roles(store, id, now > 0 ? (uint64_t)now : 0u, roles);
}

int ub_revfile_persist(void *user, const ub_ident_store_t *store) {
    return ub_revfile_save((const char *)user, store, NULL, 0);
}

/* ---- a node's set-up ---- */

int ub_identfile_load_self(ub_ident_store_t *store, const char *identity_path, const char *revocations_path,
                           uint64_t now_s, char *err, size_t err_cap) {
    if (store == NULL || identity_path == NULL) return UB_ERR_INVAL;
    int rc;
    ub_cert_t cert;
    uint8_t sign_sk[UB_IDENT_SIGN_SK_LEN], kx_sk[UB_IDENT_KX_SK_LEN];
    rc = ub_identfile_load(identity_path, &cert, sign_sk, kx_sk, err, err_cap);
    if (rc != UB_OK) return rc;
    ub_ident_status_t why;
    rc = ub_ident_set_self(store, &cert, sign_sk, kx_sk, now_s, &why);
    ub_priv_wipe(sign_sk, sizeof sign_sk);
    ub_priv_wipe(kx_sk, sizeof kx_sk);
    if (rc == UB_OK) return UB_OK;
    if (rc == UB_ERR_FULL)
        return failf(err, err_cap, rc, "%s: this node holds %u identities already (UB_MAX_LOCAL_ENTITIES)", identity_path,
                     (unsigned)UB_MAX_LOCAL_ENTITIES);
    if (rc == UB_ERR_UNSUPPORTED || rc == UB_ERR_NOTFOUND)
        return failf(err, err_cap, rc, "%s: %s (identities need libsodium and the authority's public key)",
                     identity_path, ub_strerror(rc));
    char name[UB_ENTITY_ID_LEN + 1];
    for (size_t i = 0; i < UB_ENTITY_ID_LEN; i++) name[i] = cert.entity[i] >= 0x20 && cert.entity[i] < 0x7f ? (char)cert.entity[i] : (cert.entity[i] == 0 ? '\0' : '?');
    name[UB_ENTITY_ID_LEN] = '\0';
    switch (why) {
    case UB_IDENT_EXPIRED:
        return failf(err, err_cap, UB_ERR_CONFIG,
                     "%s: the certificate of '%s' expired %llu s ago (not_after %llu); issue a new one: uavbus keys "
                     "issue %s --force", identity_path, name, (unsigned long long)(now_s - cert.not_after),
                     (unsigned long long)cert.not_after, name);
    case UB_IDENT_NOT_YET_VALID:
        return failf(err, err_cap, UB_ERR_CONFIG,
                     "%s: the certificate of '%s' is valid only from unix time %llu (now %llu): check this node's clock",
                     identity_path, name, (unsigned long long)cert.not_before, (unsigned long long)now_s);
    case UB_IDENT_REVOKED:
        return failf(err, err_cap, UB_ERR_CONFIG,
                     "%s: the identity of '%s' (serial %llu) is revoked (%s); the entity needs a new identity: uavbus "
                     "keys issue %s --force", identity_path, name, (unsigned long long)cert.serial,
                     revocations_path != NULL ? revocations_path : "revocations", name);
    case UB_IDENT_WRONG_AUTHORITY:
        return failf(err, err_cap, UB_ERR_CONFIG,
                     "%s: issued by another authority than this node's (give this fleet's authority file, or issue the "
                     "identity with it)", identity_path);
    case UB_IDENT_BAD_SIGNATURE:
        return failf(err, err_cap, UB_ERR_CONFIG,
                     "%s: the authority's signature does not verify (the certificate was altered: issue it again)",
                     identity_path);
    default:
        return failf(err, err_cap, UB_ERR_CONFIG, "%s: refused (%s): issue it again: uavbus keys issue %s --force",
                     identity_path, ub_ident_status_name(why), name);
    }
}

int ub_identfile_load_store(ub_ident_store_t *store, const char *identity_path, const char *authority_path,
                            const char *revocations_path, uint64_t now_s, char *err, size_t err_cap) {
    if (store == NULL || authority_path == NULL) return UB_ERR_INVAL;
    ub_ident_store_init(store);
    uint8_t pk[UB_IDENT_SIGN_PK_LEN];
    int rc = ub_authfile_load_public(authority_path, pk, err, err_cap);
    if (rc != UB_OK) return rc;
    rc = ub_ident_set_authority(store, pk);
    if (rc == UB_ERR_UNSUPPORTED)
        return failf(err, err_cap, rc, "%s: this build has no security (UAVBUS_SECURITY=OFF): identities need libsodium",
                     authority_path);
    if (rc != UB_OK) return failf(err, err_cap, rc, "%s: %s", authority_path, ub_strerror(rc));
    if (revocations_path != NULL) {
        rc = ub_revfile_load(revocations_path, store, err, err_cap);
        if (rc < 0) return rc;
    }
    if (identity_path == NULL) return UB_OK;
    return ub_identfile_load_self(store, identity_path, revocations_path, now_s, err, err_cap);
}

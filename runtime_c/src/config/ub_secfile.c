/* Key files and counter files (contracts in ub/ub_secfile.h). POSIX open/read/write/fsync/rename
 * only: stdio's FILE may allocate, and nothing in the runtime touches the heap. */
#include "ub/ub_secfile.h"
#include "codec/ub_wipe_private.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define KEY_SHAPE "expected 'uavbus-key 1 id=<1..255> <64 hex digits>'"
#define KEY_MAKE "make one with: uavbus keys new FILE"

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

static int hex_value(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* Splits text[0, len) at spaces and tabs into at most `max` tokens; returns the count (max + 1 if more). */
static size_t tokens(const char *text, size_t len, const char **tok, size_t *tok_len, size_t max) {
    size_t n = 0, i = 0;
    while (i < len) {
        while (i < len && (text[i] == ' ' || text[i] == '\t')) i++;
        if (i == len) break;
        size_t start = i;
        while (i < len && text[i] != ' ' && text[i] != '\t') i++;
        if (n == max) return max + 1;
        tok[n] = text + start;
        tok_len[n] = i - start;
        n++;
    }
    return n;
}

static bool token_is(const char *t, size_t n, const char *word) { return strlen(word) == n && memcmp(t, word, n) == 0; }

static int parse_key_line(const char *line, size_t len, const char *source, uint32_t lineno, uint8_t *id,
                          uint8_t key[UB_SEC_KEY_LEN], char *err, size_t cap) {
    const char *tok[4];
    size_t tl[4];
    size_t n = tokens(line, len, tok, tl, 4);
    if (n < 1 || !token_is(tok[0], tl[0], "uavbus-key"))
        return failf(err, cap, UB_ERR_CONFIG, "%s:%lu: not a uavbus key line: " KEY_SHAPE " (" KEY_MAKE ")", source,
                     (unsigned long)lineno);
    if (n != 4)
        return failf(err, cap, UB_ERR_CONFIG, "%s:%lu: %s " KEY_SHAPE, source, (unsigned long)lineno,
                     n < 4 ? "too few fields:" : "too many fields:");
    if (!token_is(tok[1], tl[1], "1"))
        return failf(err, cap, UB_ERR_CONFIG,
                     "%s:%lu: key file format '%.*s' is not supported (this build reads format 1)", source,
                     (unsigned long)lineno, (int)(tl[1] > 8 ? 8 : tl[1]), tok[1]);
    unsigned value = 0;
    bool ok = tl[2] > 3 && tl[2] <= 6 && memcmp(tok[2], "id=", 3) == 0;
    for (size_t i = 3; ok && i < tl[2]; i++) {
        if (tok[2][i] < '0' || tok[2][i] > '9') ok = false;
        else value = value * 10u + (unsigned)(tok[2][i] - '0');
    }
    if (!ok || value < 1 || value > 255)
        return failf(err, cap, UB_ERR_CONFIG, "%s:%lu: the key id must be written id=<1..255>, e.g. id=7", source,
                     (unsigned long)lineno);
    if (tl[3] != 2u * UB_SEC_KEY_LEN)
        return failf(err, cap, UB_ERR_CONFIG, "%s:%lu: the key must be 64 hex digits (32 bytes), not %lu characters",
                     source, (unsigned long)lineno, (unsigned long)tl[3]);
    for (size_t i = 0; i < UB_SEC_KEY_LEN; i++) {
        int hi = hex_value(tok[3][2 * i]), lo = hex_value(tok[3][2 * i + 1]);
        if (hi < 0 || lo < 0) {
            ub_priv_wipe(key, UB_SEC_KEY_LEN);
            return failf(err, cap, UB_ERR_CONFIG, "%s:%lu: the key has a character that is not a hex digit (0-9, a-f)",
                         source, (unsigned long)lineno);
        }
        key[i] = (uint8_t)(hi << 4 | lo);
    }
    *id = (uint8_t)value;
    return UB_OK;
}

int ub_keyfile_parse(const char *text, size_t len, const char *source, uint8_t *id, uint8_t key[UB_SEC_KEY_LEN],
                     char *err, size_t err_cap) {
    if (text == NULL || source == NULL || id == NULL || key == NULL) return UB_ERR_INVAL;
    uint32_t lineno = 0, key_line = 0;
    size_t pos = 0;
    while (pos < len) {
        const char *nl = memchr(text + pos, '\n', len - pos);
        size_t end = nl == NULL ? len : (size_t)(nl - text);
        size_t line_len = end - pos;
        if (line_len > 0 && text[pos + line_len - 1] == '\r') line_len--;
        const char *line = text + pos;
        lineno++;
        pos = nl == NULL ? len : end + 1;
        size_t k = 0;
        while (k < line_len && (line[k] == ' ' || line[k] == '\t')) k++;
        if (k == line_len || line[k] == '#') continue;
        if (key_line != 0) {
            ub_priv_wipe(key, UB_SEC_KEY_LEN);
            return failf(err, err_cap, UB_ERR_CONFIG,
                         "%s:%lu: a second key (the key is on line %lu; a key file holds one key: use one file per key)",
                         source, (unsigned long)lineno, (unsigned long)key_line);
        }
        int rc = parse_key_line(line, line_len, source, lineno, id, key, err, err_cap);
        if (rc != UB_OK) return rc;
        key_line = lineno;
    }
    if (key_line == 0)
        return failf(err, err_cap, UB_ERR_CONFIG, "%s:%lu: no key in the file: " KEY_SHAPE " (" KEY_MAKE ")", source,
                     (unsigned long)(lineno == 0 ? 1 : lineno));
    return UB_OK;
}

int ub_keyfile_load(const char *path, uint8_t *id, uint8_t key[UB_SEC_KEY_LEN], char *err, size_t err_cap) {
    if (path == NULL || id == NULL || key == NULL) return UB_ERR_INVAL;
    int fd = open(path, O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0)
        return failf(err, err_cap, UB_ERR_IO, "%s: cannot open the key file: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) < 0) {
        int e = errno;
        close(fd);
        return failf(err, err_cap, UB_ERR_IO, "%s: cannot stat the key file: %s", path, strerror(e));
    }
    if (!S_ISREG(st.st_mode)) {
        close(fd);
        return failf(err, err_cap, UB_ERR_CONFIG, "%s: not a regular file (a key file is a plain text file)", path);
    }
    if ((st.st_mode & 077) != 0) { /* checked before a byte is read, as ssh does for its keys */
        close(fd);
        return failf(err, err_cap, UB_ERR_CONFIG,
                     "%s: mode %03o lets group or others access the key; refusing it (chmod 600 %s)", path,
                     (unsigned)(st.st_mode & 0777), path);
    }
    char text[UB_KEYFILE_MAX];
    size_t len = 0;
    for (;;) {
        ssize_t n = read(fd, text + len, sizeof text - len);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) {
            int e = errno;
            close(fd);
            ub_priv_wipe(text, sizeof text);
            return failf(err, err_cap, UB_ERR_IO, "%s: cannot read the key file: %s", path, strerror(e));
        }
        if (n == 0) break;
        len += (size_t)n;
        if (len == sizeof text) {
            close(fd);
            ub_priv_wipe(text, sizeof text);
            return failf(err, err_cap, UB_ERR_CONFIG, "%s: larger than %u bytes: not a key file", path,
                         (unsigned)UB_KEYFILE_MAX);
        }
    }
    close(fd);
    int rc = ub_keyfile_parse(text, len, path, id, key, err, err_cap);
    ub_priv_wipe(text, sizeof text);
    return rc;
}

static int write_all(int fd, const char *buf, size_t len) {
    size_t done = 0;
    while (done < len) {
        ssize_t n = write(fd, buf + done, len - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return UB_ERR_IO;
        done += (size_t)n;
    }
    return UB_OK;
}

int ub_keyfile_write(const char *path, uint8_t id, const uint8_t key[UB_SEC_KEY_LEN], char *err, size_t err_cap) {
    if (path == NULL || key == NULL || id == 0) return UB_ERR_INVAL;
    int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0 && errno == EEXIST)
        return failf(err, err_cap, UB_ERR_EXISTS,
                     "%s: already exists (a key is never overwritten: choose another file name, or remove it first)",
                     path);
    if (fd < 0) return failf(err, err_cap, UB_ERR_IO, "%s: cannot create the key file: %s", path, strerror(errno));
    char text[256];
    int n = snprintf(text, sizeof text,
                     "# uavbus key (docs/security.md). Secret: keep this file mode 0600, never commit it.\n"
                     "uavbus-key 1 id=%u ",
                     (unsigned)id);
    static const char hex[] = "0123456789abcdef";
    size_t len = (size_t)n;
    for (size_t i = 0; i < UB_SEC_KEY_LEN; i++) {
        text[len++] = hex[key[i] >> 4];
        text[len++] = hex[key[i] & 15];
    }
    text[len++] = '\n';
    /* fchmod as well: the umask may only have removed bits, but a pre-set ACL default must not add any. */
    int rc = fchmod(fd, 0600) < 0 || write_all(fd, text, len) != UB_OK || fsync(fd) < 0 ? UB_ERR_IO : UB_OK;
    int e = errno;
    ub_priv_wipe(text, sizeof text);
    if (close(fd) < 0 && rc == UB_OK) {
        rc = UB_ERR_IO;
        e = errno;
    }
    if (rc != UB_OK) {
        (void)unlink(path);
        return failf(err, err_cap, UB_ERR_IO, "%s: cannot write the key file: %s", path, strerror(e));
    }
    return UB_OK;
}

int ub_keyfile_new(const char *path, uint8_t id, uint8_t *id_out, char *err, size_t err_cap) {
    if (path == NULL) return UB_ERR_INVAL;
    uint8_t key[UB_SEC_KEY_LEN];
    int rc = ub_sec_keygen(key);
    if (rc == UB_ERR_UNSUPPORTED)
        return failf(err, err_cap, rc, "%s: this build has no security (UAVBUS_SECURITY=OFF): no key can be made",
                     path);
    if (rc != UB_OK) return failf(err, err_cap, rc, "%s: the random generator failed", path);
    if (id == 0) {
        uint8_t r = 0;
        while (r == 0) {
            uint8_t b[1];
            ub_sec_random(NULL, b, 1);
            r = b[0];
        }
        id = r;
    }
    rc = ub_keyfile_write(path, id, key, err, err_cap);
    ub_priv_wipe(key, sizeof key);
    if (rc == UB_OK && id_out != NULL) *id_out = id;
    return rc;
}

/* ---- counter file ---- */

#define COUNTER_MAGIC "uavbus-counter 1 "

int ub_counter_file_open(ub_counter_file_t *cf, const char *path, uint64_t *mark, char *err, size_t err_cap) {
    if (cf == NULL || path == NULL || mark == NULL) return UB_ERR_INVAL;
    memset(cf, 0, sizeof *cf);
    size_t plen = strlen(path);
    if (plen == 0 || plen + 5 > sizeof cf->path)
        return failf(err, err_cap, UB_ERR_RANGE, "%.60s...: counter file path longer than %u bytes", path,
                     (unsigned)(sizeof cf->path - 5));
    memcpy(cf->path, path, plen + 1);
    *mark = 0;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0 && errno == ENOENT) return UB_OK; /* first start: the wall clock alone sets the counter */
    if (fd < 0) return failf(err, err_cap, UB_ERR_IO, "%s: cannot open the counter file: %s", path, strerror(errno));
    char text[64];
    size_t len = 0;
    for (;;) {
        ssize_t n = read(fd, text + len, sizeof text - 1 - len);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) {
            int e = errno;
            close(fd);
            return failf(err, err_cap, UB_ERR_IO, "%s: cannot read the counter file: %s", path, strerror(e));
        }
        if (n == 0 || len + (size_t)n == sizeof text - 1) {
            len += (size_t)n;
            break;
        }
        len += (size_t)n;
    }
    close(fd);
    text[len] = '\0';
    size_t m = sizeof COUNTER_MAGIC - 1;
    uint64_t v = 0;
    size_t i = m, digits = 0;
    bool ok = len > m && memcmp(text, COUNTER_MAGIC, m) == 0;
    for (; ok && i < len && text[i] >= '0' && text[i] <= '9'; i++, digits++) {
        if (v > (UB_SEC_COUNTER_MAX + 1u - (uint64_t)(text[i] - '0')) / 10u) ok = false;
        v = v * 10u + (uint64_t)(text[i] - '0');
    }
    ok = ok && digits > 0 && (i == len || (text[i] == '\n' && i + 1 == len));
    if (!ok)
        return failf(err, err_cap, UB_ERR_CONFIG,
                     "%s:1: not a uavbus counter file (expected 'uavbus-counter 1 <number>'); if it was damaged, "
                     "remove it and make sure the clock is right before restarting (docs/security.md)",
                     path);
    cf->mark = v;
    *mark = v;
    return UB_OK;
}

/* The directory of cf->path, so the rename itself is made durable. */
static int fsync_dir(const char *path) {
    char dir[UB_SECFILE_PATH_MAX];
    const char *slash = strrchr(path, '/');
    if (slash == NULL) {
        dir[0] = '.';
        dir[1] = '\0';
    } else {
        size_t n = slash == path ? 1 : (size_t)(slash - path);
        memcpy(dir, path, n);
        dir[n] = '\0';
    }
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return UB_ERR_IO;
    int rc = fsync(fd) < 0 ? UB_ERR_IO : UB_OK;
    close(fd);
    return rc;
}

int ub_counter_file_reserve(void *user, uint64_t mark) {
    ub_counter_file_t *cf = user;
    if (cf == NULL || cf->path[0] == '\0') return UB_ERR_INVAL;
    char tmp[UB_SECFILE_PATH_MAX];
    char text[64];
    size_t plen = strnlen(cf->path, sizeof cf->path - 5); /* open() kept room for ".tmp" */
    memcpy(tmp, cf->path, plen);
    memcpy(tmp + plen, ".tmp", 5);
    int n = snprintf(text, sizeof text, COUNTER_MAGIC "%llu\n", (unsigned long long)mark);
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    int rc = fd < 0 ? UB_ERR_IO : UB_OK;
    if (rc == UB_OK && (write_all(fd, text, (size_t)n) != UB_OK || fsync(fd) < 0)) rc = UB_ERR_IO;
    if (fd >= 0 && close(fd) < 0) rc = UB_ERR_IO;
    if (rc == UB_OK && rename(tmp, cf->path) < 0) rc = UB_ERR_IO;
    if (rc == UB_OK && fsync_dir(cf->path) != UB_OK) rc = UB_ERR_IO;
    if (rc != UB_OK) {
        cf->last_errno = errno;
        cf->failures++;
        return UB_ERR_IO;
    }
    cf->mark = mark;
    cf->writes++;
    return UB_OK;
}

uint64_t ub_counter_file_mark(const ub_counter_file_t *cf) { return cf != NULL ? cf->mark : 0; }

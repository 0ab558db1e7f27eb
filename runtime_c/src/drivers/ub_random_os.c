/* POSIX source of unpredictable bytes for ub_random_fn (ub_random.h). Kept apart from the core:
 * a build without an operating system leaves this file out and passes its own function. */
#include "ub/ub_random.h"

#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#if defined(__linux__) && defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 25))
#include <sys/random.h>
#define UB_HAVE_GETRANDOM 1
#endif

static int read_urandom(uint8_t *out, size_t len) {
    int fd = open("/dev/urandom", O_RDONLY | O_CLOEXEC);
    if (fd < 0) return UB_ERR_IO;
    size_t done = 0;
    while (done < len) {
        ssize_t n = read(fd, out + done, len - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        done += (size_t)n;
    }
    (void)close(fd);
    return done == len ? UB_OK : UB_ERR_IO;
}

int ub_random_os(void *user, uint8_t *out, size_t len) {
    (void)user;
    if (out == NULL && len > 0) return UB_ERR_INVAL;
#ifdef UB_HAVE_GETRANDOM
    size_t done = 0;
    while (done < len) {
        ssize_t n = getrandom(out + done, len - done, 0);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break; /* ENOSYS (old kernel, seccomp): fall back to the device */
        done += (size_t)n;
    }
    if (done == len) return UB_OK;
#endif
    return read_urandom(out, len);
}

/* A pty pair for the serial driver tests (test_serial, test_serial_edges, test_legacy_link): the master stays
 * with the test as the far end, the driver opens the slave by its path. Header-only, included after <cmocka.h>
 * by a file that asks for posix_openpt and symlink (_XOPEN_SOURCE 700); each test file has its own copy. */
#ifndef UB_TEST_PTY_H
#define UB_TEST_PTY_H

#include <fcntl.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

/* Opens a pty master with O_RDWR | O_NOCTTY | `extra_flags` (e.g. O_NONBLOCK), writes its slave's path into
 * `slave_path` (`cap` bytes) and returns the master's fd; a failure fails the test. */
static inline int open_pty_master(char *slave_path, size_t cap, int extra_flags) {
    int master = posix_openpt(O_RDWR | O_NOCTTY | extra_flags);
    assert_true(master >= 0);
    assert_int_equal(grantpt(master), 0);
    assert_int_equal(unlockpt(master), 0);
    const char *name = ptsname(master);
    assert_non_null(name);
    assert_true(strlen(name) < cap);
    strcpy(slave_path, name);
    return master;
}

/* Points /tmp/ub_test_<tag>_<pid> at `slave` (replacing a stale one), as udev names a plugged adapter, so a
 * test can re-point it at a new pty; the path is written into `link_path` (`cap` bytes). The test unlinks it. */
static inline void pty_symlink(char *link_path, size_t cap, const char *tag, const char *slave) {
    snprintf(link_path, cap, "/tmp/ub_test_%s_%ld", tag, (long)getpid());
    unlink(link_path);
    assert_int_equal(symlink(slave, link_path), 0);
}

#endif /* UB_TEST_PTY_H */

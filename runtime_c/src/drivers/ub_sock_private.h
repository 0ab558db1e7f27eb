/*
 * Private to the socket drivers (ub_udp.c, ub_tcp.c): IPv4 addresses, non-blocking descriptors, and
 * closing without losing the errno that explains the failure.
 */
#ifndef UB_SOCK_PRIVATE_H
#define UB_SOCK_PRIVATE_H

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "ub/ub_driver.h"
#include "ub/ub_error.h"

/* Dotted IPv4 `addr` and `port` into `out`. @return UB_OK or UB_ERR_INVAL (NULL or not an IPv4 address). */
static inline int ub_sock_address(const char *addr, uint16_t port, struct sockaddr_in *out) {
    if (addr == NULL) return UB_ERR_INVAL;
    memset(out, 0, sizeof *out);
    out->sin_family = AF_INET;
    out->sin_port = htons(port);
    return inet_pton(AF_INET, addr, &out->sin_addr) == 1 ? UB_OK : UB_ERR_INVAL;
}

static inline int ub_sock_set_nonblocking(int fd) {
    int flags = fcntl(fd, F_GETFL);
    return (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) < 0) ? UB_ERR_IO : UB_OK;
}

/* close() after a failed call: the caller reports the errno of that call, not close()'s. */
static inline void ub_sock_close_keep_errno(int fd) {
    int saved = errno;
    close(fd);
    errno = saved;
}

/* The port `fd` is bound to. @return UB_OK or UB_ERR_IO. */
static inline int ub_sock_local_port(int fd, uint16_t *port) {
    struct sockaddr_in local;
    socklen_t len = sizeof local;
    if (getsockname(fd, (struct sockaddr *)&local, &len) < 0) return UB_ERR_IO;
    *port = ntohs(local.sin_port);
    return UB_OK;
}

/* What a HOST:PORT parameter must look like, for the spec messages of both socket drivers. */
#define UB_SOCK_HOSTPORT_HELP "expected HOST:PORT with a dotted IPv4 host and a port 0..65535, e.g. 127.0.0.1:5001"

/* A spec's "HOST:PORT" -> dotted host (`host_cap` bytes) + port. "localhost" means 127.0.0.1 (the drivers
 * take dotted IPv4 only). @return true when it is one; nothing is written otherwise. */
static inline bool ub_sock_parse_hostport(const char *value, char *host, size_t host_cap, uint16_t *port) {
    const char *colon = strrchr(value, ':');
    if (colon == NULL || colon == value || (size_t)(colon - value) >= host_cap || host_cap > 256) return false;
    char h[256];
    memcpy(h, value, (size_t)(colon - value));
    h[colon - value] = '\0';
    if (strcmp(h, "localhost") == 0) memcpy(h, "127.0.0.1", sizeof "127.0.0.1");
    struct in_addr a;
    if (inet_pton(AF_INET, h, &a) != 1) return false;
    uint32_t p;
    if (!ub_driver_parse_u32(colon + 1, 65535u, &p)) return false;
    memcpy(host, h, strlen(h) + 1);
    *port = (uint16_t)p;
    return true;
}

#endif /* UB_SOCK_PRIVATE_H */

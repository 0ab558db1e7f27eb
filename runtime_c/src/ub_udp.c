#include "ub/ub_udp.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "ub/ub_node.h"

static int make_address(const char *addr, uint16_t port, struct sockaddr_in *out) {
    if (addr == NULL) return UB_ERR_INVAL;
    memset(out, 0, sizeof *out);
    out->sin_family = AF_INET;
    out->sin_port = htons(port);
    return inet_pton(AF_INET, addr, &out->sin_addr) == 1 ? UB_OK : UB_ERR_INVAL;
}

int ub_udp_open(ub_udp_t *udp, const char *bind_addr, uint16_t bind_port, const char *peer_addr,
                uint16_t peer_port) {
    if (udp == NULL) return UB_ERR_INVAL;
    memset(udp, 0, sizeof *udp);
    udp->fd = -1;
    udp->link_id = -1;
    struct sockaddr_in local;
    if (make_address(bind_addr, bind_port, &local) < 0 || make_address(peer_addr, peer_port, &udp->peer) < 0)
        return UB_ERR_INVAL;
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    if (fd < 0) return UB_ERR_IO;
    int flags = fcntl(fd, F_GETFL);
    if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) < 0 ||
        bind(fd, (const struct sockaddr *)&local, sizeof local) < 0) {
        int saved = errno;
        close(fd);
        errno = saved;
        return UB_ERR_IO;
    }
    udp->fd = fd;
    return UB_OK;
}

int ub_udp_set_peer(ub_udp_t *udp, const char *peer_addr, uint16_t peer_port) {
    if (udp == NULL) return UB_ERR_INVAL;
    struct sockaddr_in peer;
    if (make_address(peer_addr, peer_port, &peer) < 0) return UB_ERR_INVAL;
    udp->peer = peer;
    return UB_OK;
}

int ub_udp_local_port(const ub_udp_t *udp, uint16_t *port) {
    if (udp == NULL || port == NULL || udp->fd < 0) return UB_ERR_INVAL;
    struct sockaddr_in local;
    socklen_t len = sizeof local;
    if (getsockname(udp->fd, (struct sockaddr *)&local, &len) < 0) return UB_ERR_IO;
    *port = ntohs(local.sin_port);
    return UB_OK;
}

static int udp_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)now_ms;
    ub_udp_t *udp = impl;
    if (udp->fd < 0) return UB_ERR_CLOSED;
    for (;;) {
        ssize_t n = sendto(udp->fd, frame, len, 0, (const struct sockaddr *)&udp->peer, sizeof udp->peer);
        if (n == (ssize_t)len) {
            udp->stats.datagrams_out++;
            return UB_OK;
        }
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS)) {
            udp->stats.again++;
            return UB_ERR_AGAIN;
        }
        udp->stats.send_errors++;
        return UB_ERR_IO;
    }
}

static int udp_fileno(void *impl) { return ub_udp_fileno(impl); }

const ub_link_ops_t ub_udp_ops = {.kind = "udp", .send = udp_send, .fileno = udp_fileno};

int ub_udp_attach(ub_udp_t *udp, ub_node_t *node, int link_id) {
    if (udp == NULL) return UB_ERR_INVAL;
    int rc = ub_node_link_attach(node, link_id, &ub_udp_ops, udp);
    if (rc < 0) return rc;
    udp->node = node;
    udp->link_id = link_id;
    return UB_OK;
}

static int same_address(const struct sockaddr_in *a, const struct sockaddr_in *b) {
    return a->sin_port == b->sin_port && a->sin_addr.s_addr == b->sin_addr.s_addr;
}

int ub_udp_service(ub_udp_t *udp, ub_node_t *node, uint64_t now_ms) {
    if (udp == NULL || udp->fd < 0 || node == NULL || node != udp->node) return UB_ERR_INVAL;
    int handed = 0;
    for (int i = 0; i < UB_UDP_RX_BUDGET; i++) {
        struct sockaddr_in from;
        socklen_t from_len = sizeof from;
        ssize_t n = recvfrom(udp->fd, udp->rx, sizeof udp->rx, 0, (struct sockaddr *)&from, &from_len);
        if (n < 0) {
            if (errno == EINTR) continue;
            if (errno == EAGAIN || errno == EWOULDBLOCK) break;
            /* An earlier send's ICMP "port unreachable" surfaces here; the peer may simply not be up yet. */
            if (errno == ECONNREFUSED) continue;
            return UB_ERR_IO;
        }
        if (from_len != sizeof from || from.sin_family != AF_INET || !same_address(&from, &udp->peer)) {
            udp->stats.foreign++;
            continue;
        }
        udp->stats.datagrams_in++;
        handed++;
        if (ub_node_rx_frame(node, udp->link_id, udp->rx, (size_t)n, now_ms) < 0) udp->stats.rejected++;
    }
    return handed;
}

int ub_udp_fileno(const ub_udp_t *udp) { return udp == NULL ? -1 : udp->fd; }

void ub_udp_close(ub_udp_t *udp) {
    if (udp == NULL || udp->fd < 0) return;
    close(udp->fd);
    udp->fd = -1;
}

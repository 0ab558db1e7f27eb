/* sendmmsg()/recvmmsg() are Linux extensions. */
#define _GNU_SOURCE
#include "ub/ub_udp.h"

#include <arpa/inet.h>
#include <errno.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "ub/ub_node.h"
#include "ub/ub_wire.h"
#include "ub_sock_private.h"

int ub_udp_open(ub_udp_t *udp, const char *bind_addr, uint16_t bind_port, const char *peer_addr,
                uint16_t peer_port) {
    if (udp == NULL) return UB_ERR_INVAL;
    memset(udp, 0, sizeof *udp);
    udp->fd = -1;
    udp->link_id = -1;
    struct sockaddr_in local;
    if (ub_sock_address(bind_addr, bind_port, &local) < 0 || ub_sock_address(peer_addr, peer_port, &udp->peer) < 0)
        return UB_ERR_INVAL;
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    if (fd < 0) return UB_ERR_IO;
    if (ub_sock_set_nonblocking(fd) < 0 || bind(fd, (const struct sockaddr *)&local, sizeof local) < 0) {
        ub_sock_close_keep_errno(fd);
        return UB_ERR_IO;
    }
    udp->fd = fd;
    return UB_OK;
}

int ub_udp_set_peer(ub_udp_t *udp, const char *peer_addr, uint16_t peer_port) {
    if (udp == NULL) return UB_ERR_INVAL;
    struct sockaddr_in peer;
    if (ub_sock_address(peer_addr, peer_port, &peer) < 0) return UB_ERR_INVAL;
    udp->peer = peer;
    return UB_OK;
}

int ub_udp_local_port(const ub_udp_t *udp, uint16_t *port) {
    if (udp == NULL || port == NULL || udp->fd < 0) return UB_ERR_INVAL;
    return ub_sock_local_port(udp->fd, port);
}

static int send_now(ub_udp_t *udp, const uint8_t *frame, size_t len) {
    for (;;) {
        ssize_t n = sendto(udp->fd, frame, len, 0, (const struct sockaddr *)&udp->peer, sizeof udp->peer);
        if (n == (ssize_t)len) {
            udp->stats.datagrams_out++;
            udp->stats.frames_out++;
            udp->stats.tx_calls++;
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

static size_t queued_frames(const ub_udp_t *udp) {
    size_t frames = 0;
    for (unsigned i = 0; i < udp->tx_count; i++) frames += udp->tx_frames[i];
    return frames;
}

/* Removes the first `sent` datagrams from the queue, keeping the order of the rest. */
static void dequeue(ub_udp_t *udp, unsigned sent) {
    unsigned left = udp->tx_count - sent;
    for (unsigned i = 0; i < left; i++) {
        memcpy(udp->tx[i], udp->tx[sent + i], udp->tx_len[sent + i]);
        udp->tx_len[i] = udp->tx_len[sent + i];
        udp->tx_frames[i] = udp->tx_frames[sent + i];
    }
    udp->tx_count = (uint16_t)left;
}

int ub_udp_flush(ub_udp_t *udp) {
    if (udp == NULL) return UB_ERR_INVAL;
    if (udp->fd < 0) return (int)queued_frames(udp);
    while (udp->tx_count > 0) {
        struct mmsghdr msgs[UB_UDP_TX_SLOTS];
        struct iovec iov[UB_UDP_TX_SLOTS];
        memset(msgs, 0, sizeof msgs);
        for (unsigned i = 0; i < udp->tx_count; i++) {
            iov[i].iov_base = udp->tx[i];
            iov[i].iov_len = udp->tx_len[i];
            msgs[i].msg_hdr.msg_name = &udp->peer;
            msgs[i].msg_hdr.msg_namelen = sizeof udp->peer;
            msgs[i].msg_hdr.msg_iov = &iov[i];
            msgs[i].msg_hdr.msg_iovlen = 1;
        }
        int n = sendmmsg(udp->fd, msgs, udp->tx_count, MSG_DONTWAIT);
        if (n > 0) {
            udp->stats.tx_calls++;
            udp->stats.datagrams_out += (uint64_t)n;
            dequeue(udp, (unsigned)n);
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS)) break;
        /* A hard error belongs to the first datagram: drop it (counted) so one bad send cannot wedge the queue. */
        udp->stats.send_errors++;
        udp->stats.tx_discarded += udp->tx_frames[0];
        dequeue(udp, 1);
    }
    return (int)queued_frames(udp);
}

/* Batching: appends the frame to the last queued datagram, or starts a new one; sends the
 * full queue with one sendmmsg() only when no slot is left. */
static int send_batched(ub_udp_t *udp, const uint8_t *frame, size_t len) {
    unsigned last = udp->tx_count;
    if (last > 0 && udp->tx_len[last - 1] + len <= UB_UDP_DATAGRAM_MAX) {
        memcpy(udp->tx[last - 1] + udp->tx_len[last - 1], frame, len);
        udp->tx_len[last - 1] = (uint16_t)(udp->tx_len[last - 1] + len);
        udp->tx_frames[last - 1]++;
        udp->stats.frames_out++;
        return UB_OK;
    }
    if (udp->tx_count == UB_UDP_TX_SLOTS) {
        int left = ub_udp_flush(udp);
        if (left < 0) return left;
        if (udp->tx_count == UB_UDP_TX_SLOTS) {
            udp->stats.again++;
            return UB_ERR_AGAIN;
        }
    }
    last = udp->tx_count++;
    memcpy(udp->tx[last], frame, len);
    udp->tx_len[last] = (uint16_t)len;
    udp->tx_frames[last] = 1;
    udp->stats.frames_out++;
    return UB_OK;
}

static int udp_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)now_ms;
    ub_udp_t *udp = impl;
    if (udp->fd < 0) return UB_ERR_CLOSED;
    if (len > UB_UDP_DATAGRAM_MAX) return UB_ERR_INVAL;
    return udp->batching ? send_batched(udp, frame, len) : send_now(udp, frame, len);
}

int ub_udp_set_batching(ub_udp_t *udp, int on) {
    if (udp == NULL) return UB_ERR_INVAL;
    if (!on && udp->tx_count > 0 && ub_udp_flush(udp) > 0) return UB_ERR_AGAIN;
    udp->batching = on != 0;
    return UB_OK;
}

size_t ub_udp_tx_pending(const ub_udp_t *udp) { return udp == NULL ? 0 : queued_frames(udp); }

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

/* Hands the frames of one datagram to the node. Each frame's msg_size says where the next one starts;
 * a single-frame datagram (the common case) is handed whole, so a bad one is still rejected with the
 * decoder's reason, and so is any tail that does not parse as a frame. */
static void hand_datagram(ub_udp_t *udp, ub_node_t *node, const uint8_t *data, size_t len, uint64_t now_ms) {
    size_t off = 0;
    while (off < len) {
        size_t rest = len - off, take = rest;
        if (rest > UB_FRAME_HEADER_LEN) {
            size_t size = ub_get_u16le(data + off + UB_FRAME_OFF_MSG_SIZE);
            if (size >= UB_FRAME_HEADER_LEN && size < rest) take = size;
        }
        udp->stats.frames_in++;
        if (ub_node_rx_frame(node, udp->link_id, data + off, take, now_ms) < 0) udp->stats.rejected++;
        off += take;
    }
}

int ub_udp_service(ub_udp_t *udp, ub_node_t *node, uint64_t now_ms) {
    if (udp == NULL || udp->fd < 0 || node == NULL || node != udp->node) return UB_ERR_INVAL;
    if (udp->tx_count > 0) {
        int left = ub_udp_flush(udp); /* what the socket refuses stays queued for the next call */
        (void)left;
    }
    int handed = 0;
    int budget = UB_UDP_RX_BUDGET;
    while (budget > 0) {
        struct mmsghdr msgs[UB_UDP_RX_SLOTS];
        struct iovec iov[UB_UDP_RX_SLOTS];
        struct sockaddr_in from[UB_UDP_RX_SLOTS];
        unsigned want = budget < UB_UDP_RX_SLOTS ? (unsigned)budget : UB_UDP_RX_SLOTS;
        memset(msgs, 0, sizeof msgs[0] * want);
        for (unsigned i = 0; i < want; i++) {
            iov[i].iov_base = udp->rx[i];
            iov[i].iov_len = sizeof udp->rx[i];
            msgs[i].msg_hdr.msg_name = &from[i];
            msgs[i].msg_hdr.msg_namelen = sizeof from[i];
            msgs[i].msg_hdr.msg_iov = &iov[i];
            msgs[i].msg_hdr.msg_iovlen = 1;
        }
        int n = recvmmsg(udp->fd, msgs, want, MSG_DONTWAIT, NULL);
        if (n < 0) {
            if (errno == EINTR) continue;
            if (errno == EAGAIN || errno == EWOULDBLOCK) break;
            /* An earlier send's ICMP "port unreachable" surfaces here; the peer may simply not be up yet. */
            if (errno == ECONNREFUSED) {
                budget--;
                continue;
            }
            return UB_ERR_IO;
        }
        if (n == 0) break;
        udp->stats.rx_calls++;
        budget -= n;
        for (int i = 0; i < n; i++) {
            if (msgs[i].msg_hdr.msg_namelen != sizeof from[i] || from[i].sin_family != AF_INET ||
                !same_address(&from[i], &udp->peer)) {
                udp->stats.foreign++;
                continue;
            }
            udp->stats.datagrams_in++;
            handed++;
            size_t len = msgs[i].msg_len;
            /* A truncated datagram is handed as one piece: its length cannot match a frame, so the node
             * rejects and counts it. */
            if (msgs[i].msg_hdr.msg_flags & MSG_TRUNC) {
                udp->stats.frames_in++;
                if (ub_node_rx_frame(node, udp->link_id, udp->rx[i], len, now_ms) < 0) udp->stats.rejected++;
                continue;
            }
            hand_datagram(udp, node, udp->rx[i], len, now_ms);
        }
        if ((unsigned)n < want) break;
    }
    return handed;
}

int ub_udp_fileno(const ub_udp_t *udp) { return udp == NULL ? -1 : udp->fd; }

void ub_udp_close(ub_udp_t *udp) {
    if (udp == NULL || udp->fd < 0) return;
    close(udp->fd);
    udp->fd = -1;
}

/* sendmmsg()/recvmmsg() are Linux extensions. */
#define _GNU_SOURCE
#include "ub/ub_udp.h"

#include <arpa/inet.h>
#include <stdbool.h>
#include <errno.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include <poll.h>
#include <stdio.h>

#include "ub/ub_node.h"
#include "ub/ub_ports.h"
#include "ub/ub_wire.h"
#include "drivers/ub_sock_private.h"

int ub_udp_open(ub_udp_t *udp, const char *bind_addr, uint16_t bind_port, const char *peer_addr,
                uint16_t peer_port) {
    if (udp == NULL) return UB_ERR_INVAL;
    memset(udp, 0, sizeof *udp);
    udp->fd = -1;
    udp->link_id = -1;
    struct sockaddr_in local;
    if (ub_sock_address(bind_addr, bind_port, &local) < 0) return UB_ERR_INVAL;
    if (peer_addr != NULL) {
        if (peer_port == 0 || ub_sock_address(peer_addr, peer_port, &udp->peers[0].addr) < 0) return UB_ERR_INVAL;
        udp->peers[0].in_use = 1;
        udp->peers[0].configured = 1;
        udp->accept = UB_UDP_ACCEPT_PEER;
    } else {
        udp->accept = UB_UDP_ACCEPT_ANY;
    }
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    if (fd < 0) return UB_ERR_IO;
    /* ICMP "port unreachable" for our datagrams surfaces as ECONNREFUSED on the next receive (IP_RECVERR: also on
     * an unbound-peer socket like this one): transport evidence that the peer is gone (ub_node_link_event()). */
    int on = 1;
    (void)setsockopt(fd, IPPROTO_IP, IP_RECVERR, &on, sizeof on);
    if (ub_sock_set_nonblocking(fd) < 0 || bind(fd, (const struct sockaddr *)&local, sizeof local) < 0) {
        ub_sock_close_keep_errno(fd);
        return UB_ERR_IO;
    }
    udp->fd = fd;
    return UB_OK;
}

int ub_udp_set_peer(ub_udp_t *udp, const char *peer_addr, uint16_t peer_port) {
    if (udp == NULL || peer_port == 0) return UB_ERR_INVAL;
    struct sockaddr_in peer;
    if (ub_sock_address(peer_addr, peer_port, &peer) < 0) return UB_ERR_INVAL;
    /* The configured peer is always peers[0]: move a learned one out of the way if it sits there. */
    if (udp->peers[0].in_use && !udp->peers[0].configured) {
        for (int i = 1; i < UB_UDP_MAX_PEERS; i++) {
            if (udp->peers[i].in_use) continue;
            udp->peers[i] = udp->peers[0];
            break;
        }
    }
    udp->peers[0].addr = peer;
    udp->peers[0].in_use = 1;
    udp->peers[0].configured = 1;
    udp->peers[0].last_heard_ms = 0;
    return UB_OK;
}

int ub_udp_set_accept(ub_udp_t *udp, ub_udp_accept_t accept) {
    if (udp == NULL || (unsigned)accept > UB_UDP_ACCEPT_ANY) return UB_ERR_INVAL;
    if (accept == UB_UDP_ACCEPT_PEER && !(udp->peers[0].in_use && udp->peers[0].configured)) return UB_ERR_INVAL;
    udp->accept = (uint8_t)accept;
    return UB_OK;
}

int ub_udp_peer_at(const ub_udp_t *udp, int i, char host[16], uint16_t *port) {
    if (udp == NULL || host == NULL || port == NULL || i < 0) return UB_ERR_INVAL;
    for (int k = 0; k < UB_UDP_MAX_PEERS; k++) {
        if (!udp->peers[k].in_use || i-- > 0) continue;
        if (inet_ntop(AF_INET, &udp->peers[k].addr.sin_addr, host, 16) == NULL) return UB_ERR_INVAL;
        *port = ntohs(udp->peers[k].addr.sin_port);
        return UB_OK;
    }
    return UB_ERR_NOTFOUND;
}

int ub_udp_local_port(const ub_udp_t *udp, uint16_t *port) {
    if (udp == NULL || port == NULL || udp->fd < 0) return UB_ERR_INVAL;
    return ub_sock_local_port(udp->fd, port);
}

/* The peer whose send result is the frame's (the first in the table); the others get copies. */
static int first_peer(const ub_udp_t *udp) {
    for (int k = 0; k < UB_UDP_MAX_PEERS; k++)
        if (udp->peers[k].in_use) return k;
    return -1;
}

static int send_to(ub_udp_t *udp, const struct sockaddr_in *to, const uint8_t *frame, size_t len) {
    for (;;) {
        ssize_t n = sendto(udp->fd, frame, len, 0, (const struct sockaddr *)to, sizeof *to);
        if (n == (ssize_t)len) return UB_OK;
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS)) return UB_ERR_AGAIN;
        return UB_ERR_IO;
    }
}

static int send_now(ub_udp_t *udp, const uint8_t *frame, size_t len) {
    int first = first_peer(udp);
    int rc = send_to(udp, &udp->peers[first].addr, frame, len);
    if (rc == UB_ERR_AGAIN) {
        udp->stats.again++;
        return rc;
    }
    if (rc != UB_OK) {
        udp->stats.send_errors++;
        return rc;
    }
    udp->stats.datagrams_out++;
    udp->stats.frames_out++;
    udp->stats.tx_calls++;
    for (int k = first + 1; k < UB_UDP_MAX_PEERS; k++) {
        if (!udp->peers[k].in_use) continue;
        if (send_to(udp, &udp->peers[k].addr, frame, len) == UB_OK) udp->stats.datagrams_out++;
        else udp->stats.copy_errors++;
    }
    return UB_OK;
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

/* One sendmmsg() of the first `count` queued datagrams to `to`: the number sent, or -errno. */
static int send_queue_to(ub_udp_t *udp, struct sockaddr_in *to, unsigned count) {
    struct mmsghdr msgs[UB_UDP_TX_SLOTS];
    struct iovec iov[UB_UDP_TX_SLOTS];
    memset(msgs, 0, sizeof msgs);
    for (unsigned i = 0; i < count; i++) {
        iov[i].iov_base = udp->tx[i];
        iov[i].iov_len = udp->tx_len[i];
        msgs[i].msg_hdr.msg_name = to;
        msgs[i].msg_hdr.msg_namelen = sizeof *to;
        msgs[i].msg_hdr.msg_iov = &iov[i];
        msgs[i].msg_hdr.msg_iovlen = 1;
    }
    for (;;) {
        int n = sendmmsg(udp->fd, msgs, count, MSG_DONTWAIT);
        if (n < 0 && errno == EINTR) continue;
        return n < 0 ? -errno : n;
    }
}

int ub_udp_flush(ub_udp_t *udp) {
    if (udp == NULL) return UB_ERR_INVAL;
    if (udp->fd < 0) return (int)queued_frames(udp);
    int first = first_peer(udp);
    while (udp->tx_count > 0 && first >= 0) {
        int n = send_queue_to(udp, &udp->peers[first].addr, udp->tx_count);
        if (n > 0) {
            udp->stats.tx_calls++;
            udp->stats.datagrams_out += (uint64_t)n;
            /* Copies of what the first peer got, to every other peer: best effort, counted. */
            for (int k = first + 1; k < UB_UDP_MAX_PEERS; k++) {
                if (!udp->peers[k].in_use) continue;
                int c = send_queue_to(udp, &udp->peers[k].addr, (unsigned)n);
                if (c > 0) udp->stats.datagrams_out += (uint64_t)c;
                udp->stats.copy_errors += (uint64_t)(n - (c > 0 ? c : 0));
            }
            dequeue(udp, (unsigned)n);
            continue;
        }
        if (n == -EAGAIN || n == -EWOULDBLOCK || n == -ENOBUFS) break;
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
    if (first_peer(udp) < 0) {
        udp->stats.no_peer++;
        return UB_ERR_NOROUTE; /* nobody to send to yet: the node counts it as no_route */
    }
    return udp->batching ? send_batched(udp, frame, len) : send_now(udp, frame, len);
}

int ub_udp_set_foreign(ub_udp_t *udp, ub_foreign_cb cb, void *user) {
    if (udp == NULL) return UB_ERR_INVAL;
    udp->foreign = cb;
    udp->foreign_user = cb != NULL ? user : NULL;
    return UB_OK;
}

int ub_udp_set_batching(ub_udp_t *udp, int on) {
    if (udp == NULL) return UB_ERR_INVAL;
    if (!on && udp->tx_count > 0 && ub_udp_flush(udp) > 0) return UB_ERR_AGAIN;
    udp->batching = on != 0;
    return UB_OK;
}

int ub_udp_set_rcvbuf(ub_udp_t *udp, uint32_t bytes) {
    if (udp == NULL || udp->fd < 0 || bytes < UB_UDP_RCVBUF_MIN || bytes > UB_UDP_RCVBUF_MAX) return UB_ERR_INVAL;
    int v = (int)bytes;
    return setsockopt(udp->fd, SOL_SOCKET, SO_RCVBUF, &v, sizeof v) == 0 ? UB_OK : UB_ERR_IO;
}

size_t ub_udp_tx_pending(const ub_udp_t *udp) { return udp == NULL ? 0 : queued_frames(udp); }

static int udp_fileno(void *impl) { return ub_udp_fileno(impl); }

const ub_link_ops_t ub_udp_ops = {.kind = "udp", .send = udp_send, .fileno = udp_fileno};

int ub_udp_attach(ub_udp_t *udp, ub_node_t *node, int link_id) {
    if (udp == NULL) return UB_ERR_INVAL;
    return ub_driver_attach(node, link_id, &ub_udp_ops, udp, &udp->node, &udp->link_id);
}

static int same_address(const struct sockaddr_in *a, const struct sockaddr_in *b) {
    return a->sin_port == b->sin_port && a->sin_addr.s_addr == b->sin_addr.s_addr;
}

static int find_peer(const ub_udp_t *udp, const struct sockaddr_in *from) {
    for (int k = 0; k < UB_UDP_MAX_PEERS; k++)
        if (udp->peers[k].in_use && same_address(&udp->peers[k].addr, from)) return k;
    return -1;
}

/* What a verdict says about a datagram's sender, worst to best (for a datagram of several frames). */
static int verdict_rank(ub_rx_verdict_t v) {
    switch (v) {
    case UB_VERDICT_ACCEPTED: return 3;
    case UB_VERDICT_DUPLICATE: return 2;
    case UB_VERDICT_UNVERIFIED: return 1;
    default: return 0;
    }
}

/* True when `data` (at least a header long) starts with a header whose checks hold: sync, header check,
 * version, consistent sizes. Parsing the 64 header bytes alone, a sound header reports the payload as
 * missing (TRUNCATED), or an empty-payload frame parses whole or fails only its message CRC. */
static int sound_header(const uint8_t *data) {
    ub_rx_reason_t why = UB_RX_BAD_SYNC;
    int rc = ub_frame_parse_reason(data, UB_FRAME_HEADER_LEN, NULL, &why);
    return rc == UB_OK || rc == UB_ERR_TRUNCATED || (rc == UB_ERR_CHECKSUM && why == UB_RX_BAD_CRC);
}

/* Hands the frames of one datagram to the node and returns the best verdict among them. Each frame's
 * msg_size says where the next one starts, but only a sound header's msg_size is trusted: otherwise the
 * rest of the datagram is handed whole and rejected once (with the decoder's reason), so a garbage
 * datagram is exactly one rejection, whatever bytes it holds. A single-frame datagram (the common case)
 * is handed whole without the extra check. */
static ub_rx_verdict_t hand_datagram(ub_udp_t *udp, ub_node_t *node, const uint8_t *data, size_t len,
                                     uint64_t now_ms) {
    ub_rx_verdict_t best = UB_VERDICT_REFUSED;
    size_t off = 0;
    if (ub_node_link_compact(node, udp->link_id) != NULL) { /* compact packets delimit themselves: the node splits */
        udp->stats.frames_in++;
        if (ub_node_rx_frame_verdict(node, udp->link_id, data, len, now_ms, &best) < 0) udp->stats.rejected++;
        return best;
    }
    if (udp->foreign != NULL && len > 0 && (len < 2 || data[0] != UB_SYNC0 || data[1] != UB_SYNC1)) {
        udp->stats.foreign_datagrams++;
        size_t took = udp->foreign(udp->foreign_user, data, len);
        if (took < len) udp->stats.foreign_refused += len - took;
        return UB_VERDICT_REFUSED; /* not a frame: teaches no peer */
    }
    while (off < len) {
        size_t rest = len - off, take = rest;
        if (rest > UB_FRAME_HEADER_LEN) {
            size_t size = ub_get_u16le(data + off + UB_FRAME_OFF_MSG_SIZE);
            if (size >= UB_FRAME_HEADER_LEN && size < rest && sound_header(data + off)) take = size;
        }
        udp->stats.frames_in++;
        ub_rx_verdict_t v = UB_VERDICT_REFUSED;
        if (ub_node_rx_frame_verdict(node, udp->link_id, data + off, take, now_ms, &v) < 0) udp->stats.rejected++;
        if (verdict_rank(v) > verdict_rank(best)) best = v;
        off += take;
    }
    return best;
}

/* A learned peer in slot k (configured peers are never replaced by learning); `provisional`: from an
 * unverified frame, to be confirmed by an accepted one within UB_UDP_PROVISIONAL_MS. */
static void put_learned(ub_udp_t *udp, int k, const struct sockaddr_in *from, bool provisional, uint64_t now_ms) {
    if (udp->peers[k].in_use) udp->stats.peers_forgotten++;
    udp->peers[k].addr = *from;
    udp->peers[k].in_use = 1;
    udp->peers[k].configured = 0;
    udp->peers[k].last_heard_ms = now_ms;
    udp->peers[k].provisional_until_ms = provisional ? now_ms + UB_UDP_PROVISIONAL_MS : 0;
    udp->stats.peers_learned++;
}

/* The node's verdict on a datagram from an address that is not a peer yet: learn it or not (ub_udp.h). */
static void learn(ub_udp_t *udp, ub_node_t *node, const struct sockaddr_in *from, ub_rx_verdict_t verdict,
                  uint64_t now_ms) {
    if (verdict == UB_VERDICT_REFUSED) return;
    /* Where frames are signed, a copy of one already handled proves nothing about who sends it: anyone who
     * overheard it can. An authentic frame from a source not verified yet makes a provisional peer, so the
     * node's challenge reaches the sender. */
    if (verdict == UB_VERDICT_DUPLICATE && ub_node_link_requires_signed(node, udp->link_id)) return;
    bool provisional = verdict == UB_VERDICT_UNVERIFIED;
    if (udp->accept == UB_UDP_ACCEPT_LEARN) {
        /* One peer. A duplicate (a redundant link's copy, or a replay) may teach the first one, but only a
         * frame the node accepted as new moves the link away from a peer it has. */
        int k = first_peer(udp);
        if (k >= 0 && verdict != UB_VERDICT_ACCEPTED) return;
        put_learned(udp, k >= 0 ? k : 0, from, provisional, now_ms);
        return;
    }
    /* ANY: a free slot, else the learned peer heard least recently (a provisional newcomer: only another
     * provisional one, so replays from new addresses never push out a confirmed peer). */
    int slot = -1;
    for (int k = 0; k < UB_UDP_MAX_PEERS && slot < 0; k++)
        if (!udp->peers[k].in_use) slot = k;
    if (slot < 0) {
        for (int k = 0; k < UB_UDP_MAX_PEERS; k++) {
            const ub_udp_peer_t *p = &udp->peers[k];
            if (p->configured || (provisional && p->provisional_until_ms == 0)) continue;
            if (slot < 0 || p->last_heard_ms < udp->peers[slot].last_heard_ms) slot = k;
        }
    }
    if (slot < 0) return;
    put_learned(udp, slot, from, provisional, now_ms); /* counts the peer it replaces as forgotten */
}

static void forget_idle(ub_udp_t *udp, uint64_t now_ms) {
    for (int k = 0; k < UB_UDP_MAX_PEERS; k++) {
        ub_udp_peer_t *p = &udp->peers[k];
        if (!p->in_use || p->configured) continue;
        bool unconfirmed = p->provisional_until_ms != 0 && now_ms >= p->provisional_until_ms;
        bool idle = udp->accept == UB_UDP_ACCEPT_ANY && now_ms >= p->last_heard_ms + UB_UDP_PEER_IDLE_MS;
        if (!unconfirmed && !idle) continue;
        p->in_use = 0;
        udp->stats.peers_forgotten++;
    }
}

/* An ICMP "unreachable" came back: empty the socket's error queue (IP_RECVERR keeps one entry per ICMP) and, when
 * the link has one configured peer, tell the node its link is down. The peer may simply not be up yet: the
 * services take it as evidence, not as a verdict (a frame from the peer revives the link). */
static void refused(ub_udp_t *udp, uint64_t now_ms) {
    udp->stats.refused++;
    for (int i = 0; i < 64; i++) {
        uint8_t buf[64], ctl[256];
        struct iovec iov = {.iov_base = buf, .iov_len = sizeof buf};
        struct msghdr m = {.msg_iov = &iov, .msg_iovlen = 1, .msg_control = ctl, .msg_controllen = sizeof ctl};
        if (recvmsg(udp->fd, &m, MSG_ERRQUEUE | MSG_DONTWAIT) < 0) break;
    }
    if (udp->accept == UB_UDP_ACCEPT_PEER && udp->node != NULL)
        ub_node_link_event(udp->node, udp->link_id, UB_LINK_EVENT_DOWN, now_ms);
}

int ub_udp_service(ub_udp_t *udp, ub_node_t *node, uint64_t now_ms) {
    if (udp == NULL || udp->fd < 0 || node == NULL || node != udp->node) return UB_ERR_INVAL;
    if (udp->tx_count > 0) {
        int left = ub_udp_flush(udp); /* what the socket refuses stays queued for the next call */
        (void)left;
    }
    forget_idle(udp, now_ms);
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
                refused(udp, now_ms);
                continue;
            }
            return UB_ERR_IO;
        }
        if (n == 0) break;
        udp->stats.rx_calls++;
        budget -= n;
        for (int i = 0; i < n; i++) {
            int known = msgs[i].msg_hdr.msg_namelen == sizeof from[i] && from[i].sin_family == AF_INET
                            ? find_peer(udp, &from[i])
                            : -2;
            if (known == -2 || (known < 0 && udp->accept == UB_UDP_ACCEPT_PEER)) {
                if (udp->stats.foreign++ == 0 && known != -2) udp->refused_from = from[i];
                continue;
            }
            udp->stats.datagrams_in++;
            handed++;
            size_t len = msgs[i].msg_len;
            ub_rx_verdict_t verdict;
            /* A truncated datagram is handed as one piece: its length cannot match a frame, so the node
             * rejects and counts it. */
            if (msgs[i].msg_hdr.msg_flags & MSG_TRUNC) {
                udp->stats.frames_in++;
                verdict = UB_VERDICT_REFUSED;
                if (ub_node_rx_frame_verdict(node, udp->link_id, udp->rx[i], len, now_ms, &verdict) < 0)
                    udp->stats.rejected++;
            } else {
                verdict = hand_datagram(udp, node, udp->rx[i], len, now_ms);
            }
            if (known >= 0) {
                if (verdict != UB_VERDICT_REFUSED) udp->peers[known].last_heard_ms = now_ms;
                if (verdict == UB_VERDICT_ACCEPTED) udp->peers[known].provisional_until_ms = 0; /* confirmed */
            } else {
                learn(udp, node, &from[i], verdict, now_ms);
            }
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

/* ---- the driver entry (ub_driver.h): "udp:bind=HOST:PORT[,peer=HOST:PORT][,accept=peer|learn|any][,batch=1][,rcvbuf=BYTES]" ---- */

enum { SEEN_BIND = 1u, SEEN_PEER = 2u, SEEN_ACCEPT = 4u, SEEN_BATCH = 8u, SEEN_RCVBUF = 16u };
static const char *const k_accept_words[] = {"peer", "learn", "any"};

static void udp_spec_init(ub_port_spec_t *spec) { spec->kind = UB_PORT_UDP; }

static int udp_spec_param(ub_port_spec_t *s, uint32_t *seen, const char *key, const char *value, char *err,
                          size_t cap) {
    if (strcmp(key, "bind") == 0 || strcmp(key, "peer") == 0) {
        bool bind = key[0] == 'b';
        if (*seen & (bind ? SEEN_BIND : SEEN_PEER)) {
            snprintf(err, cap, "'%s' given twice: give it once", key);
            return UB_ERR_INVAL;
        }
        if (!ub_sock_parse_hostport(value, bind ? s->host : s->peer_host, UB_PORT_HOST_LEN,
                                    bind ? &s->port : &s->peer_port)) {
            snprintf(err, cap, "'%s=%.40s': %s", key, value, UB_SOCK_HOSTPORT_HELP);
            return UB_ERR_INVAL;
        }
        if (!bind && s->peer_port == 0) {
            snprintf(err, cap, "'peer=%.40s': the peer port must not be 0 (it is where frames are sent)", value);
            return UB_ERR_INVAL;
        }
        *seen |= bind ? SEEN_BIND : SEEN_PEER;
        return UB_OK;
    }
    if (strcmp(key, "accept") == 0) {
        size_t m = 0;
        while (m < 3 && strcmp(value, k_accept_words[m]) != 0) m++;
        if (m == 3 || (*seen & SEEN_ACCEPT)) {
            snprintf(err, cap, "'accept=%.20s': %s", value,
                     (*seen & SEEN_ACCEPT) ? "given twice: give it once"
                                           : "use peer (the peer only), learn (one peer: the last sender the node "
                                             "accepted) or any (every sender of a genuine frame, up to "
                                             "UB_UDP_MAX_PEERS)");
            return UB_ERR_INVAL;
        }
        s->accept = (uint8_t)m;
        *seen |= SEEN_ACCEPT;
        return UB_OK;
    }
    if (strcmp(key, "batch") == 0) {
        /* 1/0 on a command line, true/false (or 1/0) in a JSON configuration. */
        bool on = strcmp(value, "1") == 0 || strcmp(value, "true") == 0;
        if ((*seen & SEEN_BATCH) || !(on || strcmp(value, "0") == 0 || strcmp(value, "false") == 0)) {
            snprintf(err, cap, "'batch=%.20s': %s", value,
                     (*seen & SEEN_BATCH) ? "given twice: give it once"
                                          : "give 1 (several frames per datagram, sent once per loop turn) or 0 "
                                            "(one datagram per frame, the default)");
            return UB_ERR_INVAL;
        }
        s->batch = on ? 1 : 0;
        *seen |= SEEN_BATCH;
        return UB_OK;
    }
    if (strcmp(key, "rcvbuf") == 0) {
        uint32_t bytes = 0;
        if ((*seen & SEEN_RCVBUF) || !ub_driver_parse_u32(value, UB_UDP_RCVBUF_MAX, &bytes) || bytes < UB_UDP_RCVBUF_MIN) {
            snprintf(err, cap, "'rcvbuf=%.20s': %s", value,
                     (*seen & SEEN_RCVBUF) ? "given twice: give it once"
                                           : "give the socket's receive buffer in bytes, 4096..67108864 (e.g. "
                                             "1048576 for a forwarder taking bursts; the kernel caps it at "
                                             "net.core.rmem_max)");
            return UB_ERR_INVAL;
        }
        s->rcvbuf = bytes;
        *seen |= SEEN_RCVBUF;
        return UB_OK;
    }
    return UB_ERR_NOTFOUND;
}

static int udp_spec_finish(ub_port_spec_t *s, uint32_t seen, char *err, size_t cap) {
    if (!(seen & SEEN_BIND)) {
        snprintf(err, cap, "udp needs bind=HOST:PORT, e.g. udp:bind=127.0.0.1:0,peer=127.0.0.1:5001 (or, to learn "
                           "its peers, udp:bind=0.0.0.0:5001)");
        return UB_ERR_INVAL;
    }
    if (!(seen & SEEN_ACCEPT)) s->accept = (seen & SEEN_PEER) ? UB_UDP_ACCEPT_PEER : UB_UDP_ACCEPT_ANY;
    if (s->accept == UB_UDP_ACCEPT_PEER && !(seen & SEEN_PEER)) {
        snprintf(err, cap, "udp with accept=peer needs peer=HOST:PORT, e.g. udp:bind=127.0.0.1:0,peer=127.0.0.1:5001");
        return UB_ERR_INVAL;
    }
    return UB_OK;
}

static int udp_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    /* accept= only when it is not what the other parameters imply (peer given: peer; none: any). */
    bool peer = spec->peer_port != 0;
    unsigned implied = peer ? UB_UDP_ACCEPT_PEER : UB_UDP_ACCEPT_ANY;
    char peer_text[UB_PORT_HOST_LEN + 16] = "";
    if (peer) snprintf(peer_text, sizeof peer_text, ",peer=%s:%u", spec->peer_host, (unsigned)spec->peer_port);
    char rcvbuf[24] = "";
    if (spec->rcvbuf != 0) snprintf(rcvbuf, sizeof rcvbuf, ",rcvbuf=%lu", (unsigned long)spec->rcvbuf);
    return snprintf(out, cap, "udp:bind=%s:%u%s%s%s%s%s", spec->host, (unsigned)spec->port, peer_text,
                    spec->accept != implied ? ",accept=" : "",
                    spec->accept != implied ? k_accept_words[spec->accept % 3] : "", spec->batch ? ",batch=1" : "",
                    rcvbuf);
}

static int udp_open(void *state, const ub_port_spec_t *spec) {
    ub_udp_t *udp = state;
    int rc = ub_udp_open(udp, spec->host, spec->port, spec->peer_port != 0 ? spec->peer_host : NULL, spec->peer_port);
    if (rc == UB_OK) rc = ub_udp_set_accept(udp, (ub_udp_accept_t)spec->accept);
    if (rc == UB_OK && spec->batch) rc = ub_udp_set_batching(udp, 1);
    if (rc == UB_OK && spec->rcvbuf != 0) rc = ub_udp_set_rcvbuf(udp, spec->rcvbuf);
    if (rc != UB_OK) ub_udp_close(udp);
    return rc;
}

static void udp_close(void *state) { ub_udp_close(state); }
static int udp_attach(void *state, ub_node_t *node, int link_id) { return ub_udp_attach(state, node, link_id); }
static int udp_service(void *state, ub_node_t *node, uint64_t now_ms) { return ub_udp_service(state, node, now_ms); }
static int udp_flush(void *state) { return ub_udp_flush(state); }

static int udp_pollfds(const void *state, struct pollfd *fds, int cap) {
    const ub_udp_t *udp = state;
    if (udp->fd < 0) return 0;
    if (cap < 1) return UB_ERR_NOSPACE;
    fds[0].fd = udp->fd;
    fds[0].events = (short)(POLLIN | (ub_udp_tx_pending(udp) > 0 ? POLLOUT : 0));
    fds[0].revents = 0;
    return 1;
}

/* The one timer of a UDP instance: when forget_idle() next forgets a learned peer (its provisional time runs
 * out, or it fell silent under accept=any). Everything else it does is poll()'s to report: input, room for the
 * queued output (POLLOUT), an ICMP error (POLLERR) -- so the driver is ready_only. */
static bool udp_next_due(const void *state, uint64_t *due_ms) {
    const ub_udp_t *udp = state;
    bool any = false;
    uint64_t best = UINT64_MAX;
    for (int k = 0; k < UB_UDP_MAX_PEERS; k++) {
        const ub_udp_peer_t *p = &udp->peers[k];
        if (!p->in_use || p->configured) continue;
        if (p->provisional_until_ms != 0 && p->provisional_until_ms < best) best = p->provisional_until_ms, any = true;
        if (udp->accept == UB_UDP_ACCEPT_ANY && p->last_heard_ms + UB_UDP_PEER_IDLE_MS < best)
            best = p->last_heard_ms + UB_UDP_PEER_IDLE_MS, any = true;
    }
    if (any) *due_ms = best;
    return any;
}

static int udp_local_port(const void *state, uint16_t *port) { return ub_udp_local_port(state, port); }

static int udp_set_foreign_op(void *state, ub_foreign_cb cb, void *user) { return ub_udp_set_foreign(state, cb, user); }

static size_t udp_counters(const void *state, ub_driver_counter_t *out, size_t cap) {
    const ub_udp_stats_t *s = &((const ub_udp_t *)state)->stats;
    const ub_driver_counter_t all[] = {
        {"datagrams_in", s->datagrams_in},   {"rejected", s->rejected},
        {"foreign", s->foreign},             {"datagrams_out", s->datagrams_out},
        {"again", s->again},                 {"send_errors", s->send_errors}, {"refused", s->refused},
        {"frames_in", s->frames_in},         {"frames_out", s->frames_out},
        {"rx_calls", s->rx_calls},           {"tx_calls", s->tx_calls},
        {"tx_discarded", s->tx_discarded},   {"peers_learned", s->peers_learned},
        {"peers_forgotten", s->peers_forgotten}, {"no_peer", s->no_peer},
        {"copy_errors", s->copy_errors},     {"foreign_datagrams", s->foreign_datagrams},
        {"foreign_refused", s->foreign_refused},
    };
    size_t n = sizeof all / sizeof all[0];
    for (size_t i = 0; i < n && i < cap && out != NULL; i++) out[i] = all[i];
    return n;
}

/* The stats event's "udp" object: the counters a user reads first, then the peers in sending order. */
static int udp_describe(const void *state, char *out, size_t cap) {
    const ub_udp_t *udp = state;
    const ub_udp_stats_t *s = &udp->stats;
    int n = snprintf(out, cap,
                     "\"datagrams_in\":%llu,\"rejected\":%llu,\"foreign\":%llu,\"datagrams_out\":%llu,\"again\":%llu,"
                     "\"send_errors\":%llu,\"no_peer\":%llu,\"peers_learned\":%llu,\"foreign_datagrams\":%llu,\"peers\":[",
                     (unsigned long long)s->datagrams_in, (unsigned long long)s->rejected,
                     (unsigned long long)s->foreign, (unsigned long long)s->datagrams_out,
                     (unsigned long long)s->again, (unsigned long long)s->send_errors, (unsigned long long)s->no_peer,
                     (unsigned long long)s->peers_learned, (unsigned long long)s->foreign_datagrams);
    char host[16];
    uint16_t port;
    for (int i = 0; n >= 0 && ub_udp_peer_at(udp, i, host, &port) == UB_OK; i++) {
        size_t at = (size_t)n < cap ? (size_t)n : cap;
        int k = snprintf(out + at, cap - at, "%s\"%s:%u\"", i ? "," : "", host, (unsigned)port);
        n = k < 0 ? k : n + k;
    }
    if (n >= 0) {
        size_t at = (size_t)n < cap ? (size_t)n : cap;
        int k = snprintf(out + at, cap - at, "]");
        n = k < 0 ? k : n + k;
    }
    return n;
}

/* The first datagram refused from a sender that is not the peer: the user likely wants accept=any/learn. */
static int udp_notice(const void *state, const char *link_name, char *out, size_t cap) {
    const ub_udp_t *udp = state;
    if (udp->stats.foreign == 0) return 0;
    char from[INET_ADDRSTRLEN] = "?", peer[INET_ADDRSTRLEN + 8] = "?";
    const struct sockaddr_in *r = &udp->refused_from;
    if (r->sin_port != 0) (void)inet_ntop(AF_INET, &r->sin_addr, from, sizeof from);
    char host[16];
    uint16_t port = 0;
    if (ub_udp_peer_at(udp, 0, host, &port) == UB_OK) snprintf(peer, sizeof peer, "%s:%u", host, port);
    snprintf(out, cap,
             "port '%s': refused a datagram from %s:%u: not this link's peer (%s); it is counted as 'foreign' and "
             "not reported again. To accept other senders too, open the port with accept=any (several peers, e.g. "
             "a GCS on an ephemeral port and a monitor) or accept=learn (docs/config-format.md#ports)",
             link_name, from, (unsigned)ntohs(r->sin_port), peer);
    return 1;
}

const ub_driver_t ub_udp_driver = {
    .name = "udp",
    .keys = "bind, peer, accept, batch, rcvbuf",
    .examples = "udp:bind=127.0.0.1:0,peer=127.0.0.1:5001 | udp:bind=0.0.0.0:5001 (peers learned)",
    .wire_params = true,
    .state_size = sizeof(ub_udp_t),
    .spec_init = udp_spec_init,
    .spec_param = udp_spec_param,
    .spec_finish = udp_spec_finish,
    .spec_format = udp_spec_format,
    .open = udp_open,
    .close = udp_close,
    .attach = udp_attach,
    .link_ops = &ub_udp_ops,
    .service = udp_service,
    .pollfds = udp_pollfds,
    .next_due = udp_next_due,
    .ready_only = true,
    .local_port = udp_local_port,
    .counters = udp_counters,
    .describe = udp_describe,
    .notice = udp_notice,
    .set_foreign = udp_set_foreign_op,
    .flush = udp_flush,
};

/**
 * @file ub_udp.h
 * @brief UDP link driver: one non-blocking IPv4 socket bound to a local
 *        address, exchanging datagrams with one unicast peer.
 *
 * A datagram carries one frame, or with batching on (ub_udp_set_batching())
 * several whole frames back to back, up to UB_UDP_DATAGRAM_MAX bytes: the
 * frame's msg_size says where the next one starts (trusted only when that
 * frame's header checks hold: a datagram whose header is damaged, or garbage,
 * is one rejection, never split at a random size). ub_udp_service() reads
 * every datagram waiting (recvmmsg(), UB_UDP_RX_SLOTS per system call, up to
 * UB_UDP_RX_BUDGET per call, so one busy link cannot starve an event loop)
 * and hands each frame to the node with ub_node_rx_frame_verdict(); a frame that
 * fails verification is counted there by reason (ub_link_counters_t.bad_datagrams).
 *
 * Peers: who the link sends to and accepts from (ub_udp_set_accept()):
 *  - UB_UDP_ACCEPT_PEER (the default with a peer address): the configured peer
 *    only. Datagrams from any other address are not handed on; they are
 *    counted as `foreign`, and the first sender is kept (`refused_from`) so the
 *    program can report it once (ub_ports_notice()).
 *  - UB_UDP_ACCEPT_LEARN: one peer, learned: the sender of the last frame the
 *    node *accepted* (UB_VERDICT_ACCEPTED: genuine, new, and with security on,
 *    verified), starting from the configured peer if any. A duplicate may teach
 *    the first peer but never replaces one. For a vehicle that does not know
 *    where its ground station will be (an ephemeral port, DHCP).
 *  - UB_UDP_ACCEPT_ANY (the default without a peer address): up to
 *    UB_UDP_MAX_PEERS peers, the configured one (never forgotten) plus every
 *    sender of a genuine frame (accepted or duplicate); every frame is sent to
 *    each of them. A learned peer silent for UB_UDP_PEER_IDLE_MS is forgotten,
 *    and when the table is full the one heard least recently makes room. For a
 *    GCS plus a second monitor, or `uavbus log play` into a running node.
 * Learning rests on the node's verdict, not on the transport: a datagram the
 * node refuses (not a frame, or unsigned/forged/replayed with security on)
 * never makes its sender a peer. With no peer yet, a send is refused with
 * UB_ERR_NOROUTE (counted `no_peer` here, `no_route` by the node).
 * On a link that requires signed frames (ub_node_link_requires_signed()):
 *  - a duplicate teaches nothing: anyone who overheard a frame can send a copy;
 *  - the first frame of a new signed sender is UB_VERDICT_UNVERIFIED (the node
 *    challenges its source first, docs/security.md). Its sender becomes a
 *    *provisional* peer, so the challenge reaches it: confirmed by the first
 *    frame of it the node accepts, forgotten after UB_UDP_PROVISIONAL_MS
 *    otherwise (counted in peers_forgotten). A provisional peer takes a free
 *    slot or another provisional one's, never a confirmed peer's: replaying a
 *    captured frame from a new address displaces no one and lasts 2 s at most.
 *
 * Batching (off by default, so every send is one datagram at once): sends are
 * packed into up to UB_UDP_TX_SLOTS datagrams and written with one sendmmsg()
 * when the slots are full, by ub_udp_flush(), or at the start of
 * ub_udp_service(); ub_udp_tx_pending() says when a flush is owed (poll for
 * POLLOUT). A loopback send costs ~1 us of kernel time whatever its size, so
 * this is what takes a link past ~0.8 M frames/s (bench/results.md). A frame
 * that finds every slot full and the socket refusing is UB_ERR_AGAIN (push
 * back: the caller keeps it and retries), never a silent drop.
 *
 * The socket's descriptor is exposed (ops->fileno, ub_udp_fileno()) so one
 * poll()/select() loop drives many links: call ub_udp_service() when it is
 * readable. Sending never blocks: a full socket buffer is UB_ERR_AGAIN, which
 * the node counts as backpressure.
 *
 *     ub_udp_t udp;                                   // caller-owned, no allocation
 *     ub_udp_open(&udp, "127.0.0.1", 0, "127.0.0.1", peer_port);
 *     ub_udp_attach(&udp, &node, link_id);
 *     loop: poll(ub_udp_fileno(&udp)) ...; ub_udp_service(&udp, &node, now_ms);
 *     ub_udp_close(&udp);
 */
#ifndef UB_UDP_H
#define UB_UDP_H

#include <stdint.h>
#include <netinet/in.h>

#include "ub_driver.h"
#include "ub_error.h"
#include "ub_frame.h"
#include "ub_link.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Datagrams read per ub_udp_service() call at most. */
#ifndef UB_UDP_RX_BUDGET
#define UB_UDP_RX_BUDGET 64
#endif

/** Bytes of one datagram at most, sent (batching) or received (one receive slot). Default:
 *  an Ethernet MTU's UDP payload, so batched datagrams are never IP-fragmented on a real network. */
#ifndef UB_UDP_DATAGRAM_MAX
#define UB_UDP_DATAGRAM_MAX ((UB_FRAME_MAX + 1) > 1472 ? (UB_FRAME_MAX + 1) : 1472)
#endif
/** Datagrams received per recvmmsg() call. */
#ifndef UB_UDP_RX_SLOTS
#define UB_UDP_RX_SLOTS 4
#endif
/** Datagrams queued for one sendmmsg() call when batching. */
#ifndef UB_UDP_TX_SLOTS
#define UB_UDP_TX_SLOTS 4
#endif
#if UB_UDP_DATAGRAM_MAX < UB_FRAME_MAX + 1 || UB_UDP_DATAGRAM_MAX > 65507
#error "UB_UDP_DATAGRAM_MAX must be UB_FRAME_MAX + 1 .. 65507 (an oversize datagram must not pass as a whole frame)"
#endif
#if UB_UDP_RX_SLOTS < 1 || UB_UDP_TX_SLOTS < 1
#error "UB_UDP_RX_SLOTS and UB_UDP_TX_SLOTS must be at least 1"
#endif
/** Peers one link sends to at most (UB_UDP_ACCEPT_ANY). */
#ifndef UB_UDP_MAX_PEERS
#define UB_UDP_MAX_PEERS 4
#endif
/** A learned peer silent this long is forgotten (UB_UDP_ACCEPT_ANY); a subscriber renews every second. */
#ifndef UB_UDP_PEER_IDLE_MS
#define UB_UDP_PEER_IDLE_MS 10000
#endif
/** A provisional peer (learned from an authentic first frame on a signed link) is forgotten after this
 *  unless a frame from it was accepted: the freshness challenge takes one round trip, retried every 200 ms. */
#ifndef UB_UDP_PROVISIONAL_MS
#define UB_UDP_PROVISIONAL_MS 2000
#endif
#if UB_UDP_MAX_PEERS < 1 || UB_UDP_MAX_PEERS > 255
#error "UB_UDP_MAX_PEERS must be 1..255"
#endif

/** Whom a UDP link accepts datagrams from and sends to (see the file comment). */
typedef enum ub_udp_accept {
    UB_UDP_ACCEPT_PEER = 0, /**< the configured peer only */
    UB_UDP_ACCEPT_LEARN,    /**< one peer: the sender of the last accepted frame */
    UB_UDP_ACCEPT_ANY       /**< up to UB_UDP_MAX_PEERS: every sender of a genuine frame */
} ub_udp_accept_t;

/** One peer of a link. */
typedef struct ub_udp_peer {
    struct sockaddr_in addr;
    uint64_t last_heard_ms; /**< last genuine frame from it (0: configured, never heard) */
    uint64_t provisional_until_ms; /**< 0: confirmed; else learned from an unverified frame and forgotten
                                        at this time unless a frame from it is accepted first */
    uint8_t in_use;
    uint8_t configured;     /**< given by the spec (ub_udp_open()/ub_udp_set_peer()), not learned */
} ub_udp_peer_t;

typedef struct ub_node ub_node_t;

/** Driver counters (the node keeps the per-link frame counters). */
typedef struct ub_udp_stats {
    uint64_t datagrams_in;  /**< datagrams from the peer handed to the node */
    uint64_t rejected;      /**< of those, refused by ub_node_rx_frame() (also counted by reason on the link) */
    uint64_t foreign;       /**< datagrams from another address, ignored */
    uint64_t datagrams_out; /**< datagrams sent */
    uint64_t again;         /**< sends refused because the socket buffer was full */
    uint64_t send_errors;   /**< other send failures */
    uint64_t refused;       /**< ICMP "unreachable" answers to our datagrams (ECONNREFUSED; a link event DOWN with one peer) */
    uint64_t frames_in;     /**< frames handed to the node (several per datagram when the peer batches) */
    uint64_t frames_out;    /**< frames accepted for sending (sent, or queued when batching) */
    uint64_t rx_calls;      /**< receive system calls that returned data */
    uint64_t tx_calls;      /**< send system calls that sent something */
    uint64_t tx_discarded;  /**< queued frames thrown away because their datagram's send failed (send_errors) */
    uint64_t peers_learned; /**< senders that became a peer (or replaced one) */
    uint64_t peers_forgotten; /**< learned peers dropped: idle, provisional and never confirmed, or making room */
    uint64_t no_peer;       /**< frames not sent because no peer is known yet (UB_ERR_NOROUTE) */
    uint64_t copy_errors;   /**< copies to the second and further peers that the socket refused */
    uint64_t foreign_datagrams; /**< accepted datagrams that are not uavbus (no sync pair) handed to the foreign handler */
    uint64_t foreign_refused;   /**< bytes of those the handler did not take */
} ub_udp_stats_t;

/** A UDP link. Caller-owned; treat the fields as private. */
typedef struct ub_udp {
    int fd;
    uint8_t accept;                          /* ub_udp_accept_t */
    ub_udp_peer_t peers[UB_UDP_MAX_PEERS];   /* sends go to each, in this order; [0] first when configured */
    struct sockaddr_in refused_from;         /* the first sender refused as foreign (refused_from.sin_port != 0) */
    ub_node_t *node;
    int link_id;
    ub_udp_stats_t stats;
    uint8_t batching;
    ub_foreign_cb foreign;                      /* ub_udp_set_foreign(); NULL: non-uavbus datagrams are rejected */
    void *foreign_user;
    uint16_t tx_count;                          /* datagrams queued (the last one may still grow) */
    uint16_t tx_frames[UB_UDP_TX_SLOTS];        /* frames in each queued datagram */
    uint16_t tx_len[UB_UDP_TX_SLOTS];           /* bytes in each queued datagram */
    uint8_t tx[UB_UDP_TX_SLOTS][UB_UDP_DATAGRAM_MAX];
    uint8_t rx[UB_UDP_RX_SLOTS][UB_UDP_DATAGRAM_MAX]; /* > UB_FRAME_MAX: an oversize datagram must not pass as a frame */
} ub_udp_t;

/** The transport vtable (kind "udp"); `impl` is the ub_udp_t. */
extern const ub_link_ops_t ub_udp_ops;

/** The driver entry (ub_driver.h) ub_ports opens "udp:..." specs with; its instance is a ub_udp_t. */
extern const ub_driver_t ub_udp_driver;

/**
 * Opens a non-blocking UDP socket bound to `bind_addr`:`bind_port` (dotted
 * IPv4; port 0 = any free port, see ub_udp_local_port()) that sends to
 * `peer_addr`:`peer_port` and accepts only that peer (UB_UDP_ACCEPT_PEER);
 * with `peer_addr` NULL, it starts with no peer and accepts any sender of a
 * genuine frame (UB_UDP_ACCEPT_ANY).
 * @return UB_OK; UB_ERR_INVAL (NULL, unparsable address, peer port 0); UB_ERR_IO (socket or bind failed, errno set).
 */
UB_CHECK int ub_udp_open(ub_udp_t *udp, const char *bind_addr, uint16_t bind_port, const char *peer_addr,
                         uint16_t peer_port);

/** Replaces the configured peer (e.g. once the other side's ephemeral port is known); learned peers
 *  stay. @return UB_OK or UB_ERR_INVAL. */
UB_CHECK int ub_udp_set_peer(ub_udp_t *udp, const char *peer_addr, uint16_t peer_port);

/** Sets whom the link accepts and sends to (see the file comment). @return UB_OK or UB_ERR_INVAL. */
UB_CHECK int ub_udp_set_accept(ub_udp_t *udp, ub_udp_accept_t accept);

/**
 * Peer `i` (0-based, in sending order) as a dotted host and port.
 * @return UB_OK; UB_ERR_NOTFOUND when there is no peer `i`; UB_ERR_INVAL.
 */
UB_CHECK int ub_udp_peer_at(const ub_udp_t *udp, int i, char host[16], uint16_t *port);

/** Reads the locally bound port into `port`. @return UB_OK, UB_ERR_INVAL or UB_ERR_IO. */
UB_CHECK int ub_udp_local_port(const ub_udp_t *udp, uint16_t *port);

/**
 * Puts this socket behind link slot `link_id` of `node` (ub_node_link_attach())
 * and remembers the slot for ub_udp_service().
 * @return UB_OK or the error of ub_node_link_attach().
 */
UB_CHECK int ub_udp_attach(ub_udp_t *udp, ub_node_t *node, int link_id);

/**
 * Flushes queued datagrams (batching), forgets idle learned peers, then reads
 * the waiting datagrams (at most UB_UDP_RX_BUDGET), hands the frames of those
 * it accepts (see Peers above) to `node` on the attached slot, and learns
 * peers from the node's verdicts.
 * @return the number of datagrams handed to the node (valid or not);
 *         UB_ERR_INVAL (not open, or not attached to `node`); UB_ERR_IO (read error).
 */
UB_CHECK int ub_udp_service(ub_udp_t *udp, ub_node_t *node, uint64_t now_ms);

/**
 * Turns batching on (`on` != 0) or off. Turning it off flushes what is queued first.
 * @return UB_OK; UB_ERR_INVAL (NULL); UB_ERR_AGAIN (off refused: frames still queued, socket full).
 */
UB_CHECK int ub_udp_set_batching(ub_udp_t *udp, int on);

/** Receive buffers one port may ask for (ub_udp_set_rcvbuf(), spec `rcvbuf=`), in bytes. */
#define UB_UDP_RCVBUF_MIN 4096u
#define UB_UDP_RCVBUF_MAX (64u << 20)

/**
 * Asks the kernel for a receive buffer of `bytes` (SO_RCVBUF; Linux grants up to net.core.rmem_max and
 * doubles it for its own accounting): what a burst from a batching peer can queue while this process is not
 * running. A datagram that finds the buffer full is lost in the kernel, never seen by the driver, so a
 * forwarder on a busy machine (the Zenoh bridge's site port) asks for more than the default.
 * @return UB_OK; UB_ERR_INVAL (NULL, closed, `bytes` outside UB_UDP_RCVBUF_MIN..UB_UDP_RCVBUF_MAX); UB_ERR_IO.
 */
UB_CHECK int ub_udp_set_rcvbuf(ub_udp_t *udp, uint32_t bytes);

/**
 * Foreign traffic on a datagram link (issue #24): a datagram from an accepted sender (the peer rules above
 * still decide who may send) that does not start with the uavbus sync pair is handed whole to `cb` as one
 * run (ub_foreign_cb, ub_frame.h) instead of to the node, and counted in foreign_datagrams; bytes `cb` does
 * not take are counted in foreign_refused. A datagram that starts with the sync pair is uavbus, damaged or
 * not, and goes to the node as before. `cb` NULL removes the handler. A compact link (its packets carry no
 * sync pair) never hands datagrams on. Never fails for a non-NULL `udp`.
 * @return UB_OK, or UB_ERR_INVAL for a NULL `udp`.
 */
UB_CHECK int ub_udp_set_foreign(ub_udp_t *udp, ub_foreign_cb cb, void *user);

/**
 * Sends every queued datagram it can (one sendmmsg() per UB_UDP_TX_SLOTS).
 * @return the number of frames still queued (0: all sent); UB_ERR_INVAL.
 */
UB_CHECK int ub_udp_flush(ub_udp_t *udp);

/** @return frames queued and not yet sent (poll for POLLOUT while non-zero). */
size_t ub_udp_tx_pending(const ub_udp_t *udp);

/** @return the socket descriptor, or -1 when closed. */
int ub_udp_fileno(const ub_udp_t *udp);

/** Closes the socket (the node slot keeps pointing here: detach or re-attach it). Safe to call twice. */
void ub_udp_close(ub_udp_t *udp);

#ifdef __cplusplus
}
#endif
#endif /* UB_UDP_H */

/**
 * @file ub_udp.h
 * @brief UDP link driver: one non-blocking IPv4 socket bound to a local
 *        address, exchanging datagrams with one unicast peer.
 *
 * Each datagram carries exactly one frame. ub_udp_service() reads every
 * datagram waiting (up to UB_UDP_RX_BUDGET per call, so one busy link cannot
 * starve an event loop) and hands each one to the node with
 * ub_node_rx_frame(); a datagram that fails verification is counted there by
 * reason (ub_link_counters_t.bad_datagrams). Datagrams from any address other
 * than the peer are not handed on; they are counted as `foreign`.
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

typedef struct ub_node ub_node_t;

/** Driver counters (the node keeps the per-link frame counters). */
typedef struct ub_udp_stats {
    uint64_t datagrams_in;  /**< datagrams from the peer handed to the node */
    uint64_t rejected;      /**< of those, refused by ub_node_rx_frame() (also counted by reason on the link) */
    uint64_t foreign;       /**< datagrams from another address, ignored */
    uint64_t datagrams_out; /**< datagrams sent */
    uint64_t again;         /**< sends refused because the socket buffer was full */
    uint64_t send_errors;   /**< other send failures */
} ub_udp_stats_t;

/** A UDP link. Caller-owned; treat the fields as private. */
typedef struct ub_udp {
    int fd;
    struct sockaddr_in peer;
    ub_node_t *node;
    int link_id;
    ub_udp_stats_t stats;
    uint8_t rx[UB_FRAME_MAX + 1]; /* one byte more: an oversize datagram must not pass as a whole frame */
} ub_udp_t;

/** The transport vtable (kind "udp"); `impl` is the ub_udp_t. */
extern const ub_link_ops_t ub_udp_ops;

/**
 * Opens a non-blocking UDP socket bound to `bind_addr`:`bind_port` (dotted
 * IPv4; port 0 = any free port, see ub_udp_local_port()) that sends to
 * `peer_addr`:`peer_port`.
 * @return UB_OK; UB_ERR_INVAL (NULL, unparsable address); UB_ERR_IO (socket or bind failed, errno set).
 */
UB_CHECK int ub_udp_open(ub_udp_t *udp, const char *bind_addr, uint16_t bind_port, const char *peer_addr,
                         uint16_t peer_port);

/** Changes the peer (e.g. once the other side's ephemeral port is known). @return UB_OK or UB_ERR_INVAL. */
UB_CHECK int ub_udp_set_peer(ub_udp_t *udp, const char *peer_addr, uint16_t peer_port);

/** Reads the locally bound port into `port`. @return UB_OK, UB_ERR_INVAL or UB_ERR_IO. */
UB_CHECK int ub_udp_local_port(const ub_udp_t *udp, uint16_t *port);

/**
 * Puts this socket behind link slot `link_id` of `node` (ub_node_link_attach())
 * and remembers the slot for ub_udp_service().
 * @return UB_OK or the error of ub_node_link_attach().
 */
UB_CHECK int ub_udp_attach(ub_udp_t *udp, ub_node_t *node, int link_id);

/**
 * Reads the waiting datagrams (at most UB_UDP_RX_BUDGET) and hands those from
 * the peer to `node` on the attached slot.
 * @return the number of datagrams handed to the node (valid or not);
 *         UB_ERR_INVAL (not open, or not attached to `node`); UB_ERR_IO (read error).
 */
UB_CHECK int ub_udp_service(ub_udp_t *udp, ub_node_t *node, uint64_t now_ms);

/** @return the socket descriptor, or -1 when closed. */
int ub_udp_fileno(const ub_udp_t *udp);

/** Closes the socket (the node slot keeps pointing here: detach or re-attach it). Safe to call twice. */
void ub_udp_close(ub_udp_t *udp);

#ifdef __cplusplus
}
#endif
#endif /* UB_UDP_H */

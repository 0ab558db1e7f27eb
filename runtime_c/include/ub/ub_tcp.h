/**
 * @file ub_tcp.h
 * @brief TCP link driver: a client (connects out, reconnects with exponential
 *        backoff) or a server (listens, serves one peer connection), both
 *        non-blocking, IPv4.
 *
 * The byte stream is handed to the node with ub_node_rx(); the slot's decoder
 * reassembles and verifies frames (rejections are counted in its stats, see
 * ub_node_link_bad_frames()). Each new connection re-attaches the slot, which
 * resets that decoder: bytes of a frame cut by a lost connection cannot be
 * glued to the next connection's stream.
 *
 * Sending goes through a fixed transmit buffer of UB_TCP_TX_BUFFER bytes.
 * Partial writes leave the rest queued; ub_tcp_service() flushes it (poll the
 * descriptor for POLLOUT while ub_tcp_tx_pending() is non-zero). A frame that
 * does not fit beside what is queued is refused whole with UB_ERR_AGAIN
 * (the node counts it as backpressure; the driver counts it too). Sending
 * while no connection is up returns UB_ERR_CLOSED (counted as tx_error by the
 * node, `send_closed` here). Bytes still queued when a connection dies are
 * counted in `tx_discarded`. Nothing is dropped silently.
 *
 * Time is passed in: the client's reconnect schedule is driven only by the
 * `now_ms` given to ub_tcp_service() (no sleeps, no clock reads). After a
 * failed attempt or a lost connection the next attempt is `backoff` later;
 * the backoff starts at `backoff_initial_ms` and doubles per failure up to
 * `backoff_max_ms`; a connection that comes up resets it. Call
 * ub_tcp_service() on readiness *and* periodically (e.g. with ub_node_tick()),
 * since a client waiting to retry has no descriptor to wait on.
 *
 * Server: a new connection never displaces an established peer on its own.
 * It is held as a **candidate** (at most UB_TCP_MAX_CANDIDATES) whose bytes go
 * to the node through a decoder of its own (ub_node_rx_stream()), so its
 * frames are checked like any others and nothing of it reaches the
 * established stream. A candidate is **adopted** only when the established
 * peer is gone or has sent no frame of proven freshness for `idle_ms` (the
 * usual cause: the same client reconnecting after a half-open connection),
 * and only once the candidate has itself sent a frame the node judged
 * authentic (with signing required: a valid signed frame, verified by the
 * node, not by this driver) that was no duplicate or replay; one whose
 * freshness the node could prove is preferred. `replaced` counts adoptions
 * that closed an established peer. With no established peer and a link that
 * does not require signing, a new connection is adopted at once.
 *
 * Client hello: a client whose node can sign (a security context with a
 * transmit key) sends one signed link-local CHALLENGE (docs/routing.md,
 * docs/security.md: the **link hello**, `hellos`) as soon as its connection is
 * up. A listener that requires signing therefore gets a proof on every
 * genuine connection within one trip, also when the client has nothing else
 * to send (a listener that only publishes is never stuck behind a silent
 * client). The listener's node takes the hello like any frame of the sender
 * (key, counter window) and answers nothing.
 *
 * Candidate slots cannot be held against a genuine client: every candidate
 * is closed `candidate_ms` after it connected (`candidates_expired`:
 * absolute age, a new connection starts a new candidate rather than renewing
 * one); at most UB_TCP_CANDIDATES_PER_ADDR unproven candidates come from one
 * IPv4 address; a new connection that finds its address at that bound, or
 * every slot taken, **evicts** the oldest unproven candidate (of its own
 * address first; `candidates_evicted`) instead of being refused. A proven
 * candidate is never evicted; only when every slot holds one is a new
 * connection closed at once (`candidates_refused`). So connections that
 * prove nothing only ever displace each other, and a genuine client, which
 * proves itself with its hello one trip after connecting, gets a slot at
 * once. Poll ub_tcp_listen_fileno() and ub_tcp_fileno(), and call
 * ub_tcp_service() periodically (candidates are read there).
 */
#ifndef UB_TCP_H
#define UB_TCP_H

#include <stdint.h>
#include <netinet/in.h>

#include "ub_driver.h"
#include "ub_error.h"
#include "ub_frame.h"
#include "ub_link.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Transmit buffer per connection, in bytes. At least one whole frame. */
#ifndef UB_TCP_TX_BUFFER
#define UB_TCP_TX_BUFFER (4 * UB_FRAME_MAX)
#endif
/** Bytes read per read() call, and read() calls per ub_tcp_service() at most. */
#ifndef UB_TCP_RX_CHUNK
#define UB_TCP_RX_CHUNK 2048
#endif
#ifndef UB_TCP_RX_BUDGET
#define UB_TCP_RX_BUDGET 16
#endif

/** Connections a server holds beside its established peer until they prove themselves. */
#ifndef UB_TCP_MAX_CANDIDATES
#define UB_TCP_MAX_CANDIDATES 4
#endif
/** Unproven candidates one IPv4 address may hold; a further connection from it evicts its oldest. */
#ifndef UB_TCP_CANDIDATES_PER_ADDR
#define UB_TCP_CANDIDATES_PER_ADDR 2
#endif
#if UB_TCP_CANDIDATES_PER_ADDR < 1 || UB_TCP_CANDIDATES_PER_ADDR > UB_TCP_MAX_CANDIDATES
#error "UB_TCP_CANDIDATES_PER_ADDR must be 1..UB_TCP_MAX_CANDIDATES"
#endif

#if UB_TCP_TX_BUFFER < UB_FRAME_MAX
#error "UB_TCP_TX_BUFFER must hold at least one whole frame (UB_FRAME_MAX)"
#endif

typedef struct ub_node ub_node_t;

typedef enum ub_tcp_role { UB_TCP_CLIENT = 0, UB_TCP_SERVER = 1 } ub_tcp_role_t;

typedef enum ub_tcp_state {
    UB_TCP_DOWN = 0,       /**< no connection (client: waiting for the next attempt) */
    UB_TCP_CONNECTING = 1, /**< client: connect() in progress */
    UB_TCP_UP = 2          /**< connected */
} ub_tcp_state_t;

/** Options; zero fields mean the defaults. */
typedef struct ub_tcp_options {
    uint32_t backoff_initial_ms; /**< default 100 */
    uint32_t backoff_max_ms;     /**< default 5000 */
    uint32_t idle_ms;            /**< server: an established peer without a fresh frame this long may be replaced; default 3000 */
    uint32_t candidate_ms;       /**< server: a candidate not adopted this long after it connected is closed; default 10000 */
} ub_tcp_options_t;

typedef struct ub_tcp_stats {
    uint64_t connects;         /**< connections that came up (client: connected; server: accepted) */
    uint64_t reconnects;       /**< connections that came up after an earlier one was lost */
    uint64_t disconnects;      /**< connections lost (peer closed, reset, I/O error) */
    uint64_t attempts;         /**< client connect() attempts */
    uint64_t failed_attempts;  /**< client attempts that failed */
    uint64_t replaced;         /**< server: established peers closed because a proven candidate was adopted */
    uint64_t candidates;       /**< server: connections held as candidates */
    uint64_t adopted;          /**< server: candidates adopted (after a fresh authentic frame) */
    uint64_t candidates_refused; /**< server: connections closed at once: every candidate slot holds a proven one */
    uint64_t candidates_evicted; /**< server: unproven candidates closed to make room for a new connection */
    uint64_t candidates_expired; /**< server: candidates closed for not being adopted within candidate_ms of connecting */
    uint64_t candidates_lost;  /**< server: candidates that closed or failed before adoption */
    uint64_t candidate_rejected; /**< server: frames the candidates' decoders rejected (any reason), counted when a candidate ends */
    uint64_t candidate_garbage;  /**< server: bytes of candidates' streams that were no frame, counted when a candidate ends */
    uint64_t bytes_in;
    uint64_t bytes_out;        /**< bytes the kernel accepted */
    uint64_t frames_out;       /**< frames accepted into the transmit path */
    uint64_t backpressure;     /**< frames refused with UB_ERR_AGAIN: transmit buffer full */
    uint64_t send_closed;      /**< frames refused with UB_ERR_CLOSED: no connection */
    uint64_t tx_discarded;     /**< queued bytes thrown away with a lost connection */
    uint64_t hellos;           /**< client: link hellos sent on connecting (signed link-local CHALLENGE) */
    uint64_t foreign_out;      /**< foreign messages written (ub_tcp_write_foreign()) */
} ub_tcp_stats_t;

/** A server's candidate connection. Treat as private. */
typedef struct ub_tcp_candidate {
    int fd;           /**< -1: free slot */
    uint8_t proven;   /**< 0 nothing yet; 1 an authentic frame (its freshness not provable yet); 2 a fresh one */
    uint64_t since_ms;
    uint32_t addr;    /**< the peer's IPv4 address (network order): the per-address bound */
    ub_decoder_t dec; /**< its own stream, apart from the established one */
} ub_tcp_candidate_t;

/** A TCP link. Caller-owned; treat the fields as private. */
typedef struct ub_tcp {
    ub_tcp_role_t role;
    ub_tcp_state_t state;
    int listen_fd;
    int fd;
    struct sockaddr_in addr; /* client: where to connect; server: where it listens */
    ub_tcp_options_t opt;
    uint32_t backoff_ms;
    uint64_t next_attempt_ms;
    uint8_t had_connection;
    ub_node_t *node;
    int link_id;
    ub_tcp_stats_t stats;
    size_t tx_len;
    uint8_t batching;
    uint64_t last_fresh_ms;  /* established peer: when it came up or last sent a fresh frame */
    ub_tcp_candidate_t cand[UB_TCP_MAX_CANDIDATES];
    uint8_t foreign_on;      /* ub_tcp_set_foreign(): the established stream is read through own_dec */
    ub_decoder_t own_dec;
    uint8_t tx[UB_TCP_TX_BUFFER];
    uint8_t rx[UB_TCP_RX_CHUNK];
} ub_tcp_t;

/** The transport vtable (kind "tcp"); `impl` is the ub_tcp_t. */
extern const ub_link_ops_t ub_tcp_ops;

/** The driver entry (ub_driver.h) ub_ports opens "tcp:..." specs with; its instance is a ub_tcp_t. */
extern const ub_driver_t ub_tcp_driver;

/**
 * Initialises a client for `addr`:`port` (dotted IPv4). Nothing is opened yet:
 * the first ub_tcp_service() starts the first attempt.
 * @return UB_OK or UB_ERR_INVAL (NULL, unparsable address, port 0).
 */
UB_CHECK int ub_tcp_client_init(ub_tcp_t *tcp, const char *addr, uint16_t port, const ub_tcp_options_t *opt);

/**
 * Opens a listening server on `addr`:`port` (port 0 = any free port, see
 * ub_tcp_local_port()), with SO_REUSEADDR so a restarted server can take its
 * port back at once.
 * @return UB_OK; UB_ERR_INVAL; UB_ERR_IO (socket, bind or listen failed, errno set).
 */
UB_CHECK int ub_tcp_server_open(ub_tcp_t *tcp, const char *addr, uint16_t port, const ub_tcp_options_t *opt);

/** Reads the server's listening port. @return UB_OK, UB_ERR_INVAL (not a server) or UB_ERR_IO. */
UB_CHECK int ub_tcp_local_port(const ub_tcp_t *tcp, uint16_t *port);

/** Puts this driver behind slot `link_id` of `node`. @return UB_OK or the error of ub_node_link_attach(). */
UB_CHECK int ub_tcp_attach(ub_tcp_t *tcp, ub_node_t *node, int link_id);

/**
 * Does everything due at `now_ms`: server accepts; client starts or completes
 * a connection attempt when due; flushes the transmit buffer; reads what is
 * available (at most UB_TCP_RX_BUDGET reads) into the node with ub_node_rx().
 * A lost connection is closed, counted and (client) scheduled for retry.
 * @return the number of frames the node found; UB_ERR_INVAL (not attached to `node`).
 */
UB_CHECK int ub_tcp_service(ub_tcp_t *tcp, ub_node_t *node, uint64_t now_ms);

/**
 * Turns write batching on (`on` != 0) or off (the default). Off, every frame is
 * written at once (one send() per frame). On, frames collect in the transmit
 * buffer and go out in one send() when the next frame does not fit, at
 * ub_tcp_flush(), or at the start of ub_tcp_service(): ub_tcp_tx_pending() is
 * then non-zero, so a poll loop that asks for POLLOUT flushes within the same
 * turn. A frame that does not fit while the socket refuses is UB_ERR_AGAIN
 * (push back), as without batching.
 * @return UB_OK or UB_ERR_INVAL.
 */
UB_CHECK int ub_tcp_set_batching(ub_tcp_t *tcp, int on);

/**
 * Writes what the socket takes of the transmit buffer.
 * @return bytes still queued (0: all written); UB_ERR_INVAL; UB_ERR_CLOSED
 *         (the connection was lost and is closed, counted as with ub_tcp_service()).
 */
UB_CHECK int ub_tcp_flush(ub_tcp_t *tcp, uint64_t now_ms);

/** @return the connection's descriptor (also while connecting), or -1. */
int ub_tcp_fileno(const ub_tcp_t *tcp);

/** @return the server's listening descriptor, or -1. */
int ub_tcp_listen_fileno(const ub_tcp_t *tcp);

/** @return the connection state. */
ub_tcp_state_t ub_tcp_state(const ub_tcp_t *tcp);

/** @return bytes waiting in the transmit buffer (poll for POLLOUT while non-zero). */
size_t ub_tcp_tx_pending(const ub_tcp_t *tcp);

/** @return the driver counters. */
const ub_tcp_stats_t *ub_tcp_stats(const ub_tcp_t *tcp);

/**
 * Gives the link a foreign-traffic handler (ub_frame.h, docs/adapters.md): the established connection's
 * stream is read through a decoder of the link's own whose handler is `cb`, so every run of bytes that is
 * not a uavbus frame goes to `cb` (counted `foreign_bytes`, `foreign_refused`). A new connection restarts
 * that decoder (a half frame of the old stream is counted as garbage) and keeps the handler. A server's
 * candidate connections are not the link's peer until adopted: what they send that is no frame is counted
 * `candidate_garbage`, never handed on. `cb` NULL removes it (back to the node slot's decoder).
 * @return UB_OK, or UB_ERR_INVAL for a NULL `tcp`.
 */
UB_CHECK int ub_tcp_set_foreign(ub_tcp_t *tcp, ub_foreign_cb cb, void *user);

/**
 * Writes bytes that are not a uavbus frame (a legacy datalink message) onto the established connection
 * through the same transmit buffer as frames, whole or not at all.
 * @return UB_OK; UB_ERR_AGAIN (no room: try later); UB_ERR_CLOSED (no connection); UB_ERR_INVAL; UB_ERR_IO.
 */
UB_CHECK int ub_tcp_write_foreign(ub_tcp_t *tcp, const uint8_t *data, size_t len, uint64_t now_ms);

/** @return server candidates currently held (not adopted yet). */
int ub_tcp_candidates(const ub_tcp_t *tcp);

/** Closes the connection, the candidates and the listening socket. Safe to call twice. */
void ub_tcp_close(ub_tcp_t *tcp);

#ifdef __cplusplus
}
#endif
#endif /* UB_TCP_H */

/**
 * @file ub_mavio.h
 * @brief POSIX transports between the MAVLink bridge (ub_mavbridge.h) and an autopilot: a UDP
 *        socket (bind + the autopilot's address), a TCP client (ArduPilot SITL's 5760; reconnects)
 *        or a serial device (raw 8N1, ub_serial.h's set-up), all non-blocking, from the same spec
 *        text as uavbus ports (`udp:bind=127.0.0.1:14550,peer=127.0.0.1:14555`,
 *        `tcp:connect=127.0.0.1:5760`, `serial:device=/dev/ttyACM0,baud=115200`), and the signing
 *        key file. The autopilot's address is pinned: UDP takes datagrams from the peer only, TCP
 *        and serial are the autopilot's own connection.
 *
 * Nothing is dropped silently: datagrams from another address than the peer (`foreign`), messages
 * the socket or the device could not take (`again`, `send_errors`, `tx_full`) are counted.
 */
#ifndef UB_MAVIO_H
#define UB_MAVIO_H

#include <netinet/in.h>
#include <poll.h>
#include <stddef.h>
#include <stdint.h>

#include "ub/ub_error.h"
#include "ub/ub_ports.h"
#include "ub/ub_serial.h"
#include "ub_mavbridge.h"
#include "ub_mavroute.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Bytes queued toward a serial device when it cannot take them at once. */
#ifndef UB_MAVIO_TX_BUFFER
#define UB_MAVIO_TX_BUFFER 4096
#endif
/** Receive buffer asked for the UDP socket: room for a burst of an autopilot's telemetry while the
 *  loop is busy (the kernel default holds ~256 datagrams). The kernel may grant less (rmem_max). */
#ifndef UB_MAVIO_RCVBUF
#define UB_MAVIO_RCVBUF (1 << 20)
#endif
/** TCP: wait before connecting again after a failure or a closed connection. */
#ifndef UB_MAVIO_RECONNECT_MS
#define UB_MAVIO_RECONNECT_MS 1000
#endif
/** Datagrams or reads per ub_mavio_service() at most (the poll loop comes back for the rest). */
#ifndef UB_MAVIO_RX_BUDGET
#define UB_MAVIO_RX_BUDGET 64
#endif

typedef struct ub_mavio_stats {
    uint64_t datagrams_in;  /**< UDP datagrams from the peer */
    uint64_t bytes_in;
    uint64_t foreign;       /**< UDP datagrams from any other address: dropped */
    uint64_t read_errors;
    uint64_t messages_out;  /**< messages taken whole by the socket / into the device path */
    uint64_t bytes_out;     /**< bytes the socket or the device accepted */
    uint64_t again;         /**< messages refused: socket buffer full, or serial queue full */
    uint64_t send_errors;   /**< socket or device write errors */
    uint64_t connects;      /**< TCP: connections made */
    uint64_t disconnects;   /**< TCP: connections the autopilot closed or broke */
    uint64_t connect_failures; /**< TCP: attempts refused or failed (retried every UB_MAVIO_RECONNECT_MS) */
} ub_mavio_stats_t;

/** One transport. Caller-owned; fields private. */
typedef struct ub_mavio {
    ub_port_kind_t kind;
    int fd;
    struct sockaddr_in peer;
    ub_serial_t serial;
    uint8_t connecting;       /* TCP: a non-blocking connect in progress */
    uint64_t retry_ms;        /* TCP: next connect attempt while fd < 0 */
    size_t tx_len;
    uint8_t tx[UB_MAVIO_TX_BUFFER];
    uint8_t rx[2048];
    ub_mavio_stats_t stats;
} ub_mavio_t;

/**
 * Opens a UDP (`bind` and `peer` required) or serial spec (ub_port_spec_parse()).
 * @return UB_OK; UB_ERR_INVAL (another transport kind); UB_ERR_IO (socket/device, errno in `err`).
 */
UB_CHECK int ub_mavio_open(ub_mavio_t *io, const ub_port_spec_t *spec, char *err, size_t err_cap);

/** ub_mav_write_fn for ub_mavbridge_init() (`user` = the ub_mavio_t): one whole message or nothing. */
int ub_mavio_write(void *user, const uint8_t *bytes, size_t len);

/**
 * Flushes queued serial bytes, then hands what arrived (at most UB_MAVIO_RX_BUDGET reads) to the bridge.
 * @return messages the bridge accepted, or UB_ERR_IO (the device went away).
 */
UB_CHECK int ub_mavio_service(ub_mavio_t *io, ub_mavbridge_t *br, uint64_t now_ms);

/** The descriptor to poll: POLLIN, plus POLLOUT while serial or TCP bytes wait or a connect is in
 *  progress. fd -1 (ignored by poll) while a TCP connection waits to be retried. */
void ub_mavio_pollfd(const ub_mavio_t *io, struct pollfd *pfd);

/** The UDP socket's bound port. @return UB_OK, or UB_ERR_INVAL (serial) / UB_ERR_IO. */
UB_CHECK int ub_mavio_local_port(const ub_mavio_t *io, uint16_t *port);

/** @return whether the transport can carry bytes now (TCP: connected; UDP and serial: open). */
bool ub_mavio_up(const ub_mavio_t *io);

/** Closes the descriptor. Safe twice. */
void ub_mavio_close(ub_mavio_t *io);

/**
 * Reads a MAVLink signing key file: `#` comments and blank lines, then one line of 64 hex digits
 * (the 32-byte secret; the SHA-256 of a passphrase, `printf %s PASSPHRASE | sha256sum`, is the key
 * Mission Planner and QGroundControl derive from it). Refuses a file readable or writable by group
 * or others, like ssh. Errors read "<path>:<line>: <what to do>".
 * @return UB_OK; UB_ERR_IO (cannot read it); UB_ERR_CONFIG (bad content or mode).
 */
UB_CHECK int ub_mavbridge_load_key(const char *path, uint8_t key[32], char *err, size_t err_cap);

/* ---- the GCS endpoint (the front door, ub_mavroute.h) ------------------------------------------------ */

/** A ground station silent this long (no datagram; GCSs send HEARTBEAT every second) is forgotten. */
#ifndef UB_MAVGCS_CLIENT_TIMEOUT_MS
#define UB_MAVGCS_CLIENT_TIMEOUT_MS 10000
#endif

typedef struct ub_mavgcs_stats {
    uint64_t datagrams_in;
    uint64_t clients_new;     /**< ground stations that appeared */
    uint64_t clients_expired; /**< ... and were forgotten after UB_MAVGCS_CLIENT_TIMEOUT_MS of silence */
    uint64_t clients_full;    /**< datagrams from a new address (TCP: connections) while UB_MAVROUTE_MAX_CLIENTS are known: dropped */
    uint64_t clients_closed;  /**< TCP: connections the ground station closed, or broke, or that a message could not
                                   go out on whole (closed rather than leave half a frame in the stream) */
    uint64_t again;           /**< datagrams the socket could not take now */
    uint64_t send_errors;
    uint64_t read_errors;
    uint64_t unauthenticated; /**< UDP datagrams from a new address with no valid (with --gcs-key: well signed) frame:
                                   the address gets no place and no frames */
} ub_mavgcs_stats_t;

/** A server endpoint for ground stations: UDP (QGroundControl, MAVProxy, MAVSDK as `udpout` clients; every
 *  address that sends a datagram with a valid frame becomes a client of the router), TCP (every connection
 *  is a client) or serial (a radio or cable to one ground station: client 0, never forgotten; bytes the
 *  device cannot take now wait in a queue of UB_MAVIO_TX_BUFFER, a frame that does not fit is left out
 *  whole, `again`). Caller-owned. */
typedef struct ub_mavgcs {
    int fd;          /* the UDP socket, the TCP listening socket, or the serial device */
    uint8_t tcp;
    uint8_t serial;
    ub_serial_t ser;
    size_t tx_len;   /* serial: bytes waiting */
    uint8_t tx[UB_MAVIO_TX_BUFFER];
    struct {
        struct sockaddr_in addr;
        uint64_t last_ms;
        int fd;      /* TCP: the connection */
        uint8_t in_use;
    } clients[UB_MAVROUTE_MAX_CLIENTS];
    uint8_t rx[2048];
    ub_mavgcs_stats_t stats;
} ub_mavgcs_t;

/** Opens `udp:bind=HOST:PORT` (no peer: ground stations are learned), `tcp:listen=HOST:PORT` or
 *  `serial:device=PATH[,baud=N]`.
 *  @return UB_OK, UB_ERR_INVAL, UB_ERR_IO. */
UB_CHECK int ub_mavgcs_open(ub_mavgcs_t *g, const ub_port_spec_t *spec, char *err, size_t err_cap);
/** ub_mavroute_send_fn (`user` = the ub_mavgcs_t). */
int ub_mavgcs_send(void *user, int client, const uint8_t *bytes, size_t len);
/** Reads what arrived (at most UB_MAVIO_RX_BUDGET datagrams) into the router; forgets silent clients.
 *  @return UB_OK or UB_ERR_IO. */
UB_CHECK int ub_mavgcs_service(ub_mavgcs_t *g, ub_mavroute_t *rt, uint64_t now_ms);
/** The descriptors to poll (the socket, each TCP connection; the serial device, POLLOUT while bytes wait) into `pfds`. @return how many (<= max). */
int ub_mavgcs_pollfds(const ub_mavgcs_t *g, struct pollfd *pfds, int max);
/** @return UB_OK with the bound port, or UB_ERR_IO. */
UB_CHECK int ub_mavgcs_local_port(const ub_mavgcs_t *g, uint16_t *port);
/** @return ground stations known now. */
int ub_mavgcs_clients(const ub_mavgcs_t *g);
void ub_mavgcs_close(ub_mavgcs_t *g);

#ifdef __cplusplus
}
#endif
#endif /* UB_MAVIO_H */

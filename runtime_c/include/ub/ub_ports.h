/**
 * @file ub_ports.h
 * @brief Ports: the transports behind one node's links, opened from text
 *        (command line or the config's "ports" section), serviced from one
 *        poll() loop, switched at run time, optionally impaired.
 *
 * A **port spec** binds a link to a transport. The same text is used on the
 * command line (`--port onboardPortIPC=tcp:connect=127.0.0.1:5001`) and in
 * the config file (`"ports": {"onboardPortIPC": {"transport": "tcp",
 * "connect": "127.0.0.1:5001"}}`):
 *
 * | transport | parameters |
 * |---|---|
 * | `udp`    | `bind=HOST:PORT` (PORT 0 = any free port); `peer=HOST:PORT`; `accept=peer|learn|any` (ub_udp.h; default `peer` with a peer, else `any`) |
 * | `tcp`    | `listen=HOST:PORT` (server; PORT 0 = any) or `connect=HOST:PORT` (client) |
 * | `serial` | `device=PATH`, optional `baud=` one of ub_serial's rates (default 115200) |
 * | `mem`    | none: the program attaches a ub_memlink itself; ub_ports skips it |
 * | (registered) | what its driver takes (ub_driver.h; ub_ports_register()) |
 *
 * Every socket and serial port also takes `encoding=full|compact` (the link's wire encoding,
 * ub_compact.h; both ends alike) and `mtu=BYTES` (64..65535: the largest frame the link carries on
 * the wire; larger directories go in fragments, larger forwarded frames are dropped `too_big`), and a
 * serial port `prio=1` (send by priority class at its byte rate, baud / 10: the bandwidth model of
 * ub_impair.h with `prio` in front of it, on top of any impairment; ub_prio.h).
 *
 * HOST is a dotted IPv4 address (127.0.0.1), or `localhost`.
 *
 * Opening a link that is already open is the **runtime software switch**
 * (paper III.E): the new transport is opened and attached to the link slot
 * (ub_node_link_attach()) before the old one is closed, so entity tables,
 * masks, publish/subscribe tables and link counters are untouched. When the
 * new transport needs the very address the old one holds (same UDP bind or
 * TCP listen port), the old one is closed first and the open retried.
 *
 * Drivers: ub_ports names no transport. Each is a driver table (ub_driver.h) in a registry the set
 * owns: ub_ports_init() registers the built-ins (udp, tcp, serial, mem) and ub_ports_register() adds
 * one at run time; the spec's transport word chooses it. The functions without a `ports` argument
 * (ub_port_spec_parse(), ub_port_arg_parse(), ub_port_spec_from_config()) know the built-ins only;
 * their ub_ports_* twins also know what was registered.
 *
 * Memory: ub_ports_t is caller-owned and large (two driver slots per port so
 * a rebind can hold old and new at once, plus an impairment queue): give it
 * static storage. It keeps a pointer to the node, which must outlive it.
 *
 *     static ub_ports_t ports;
 *     ub_ports_init(&ports, &node);
 *     ub_ports_open_config(&ports, &cfg, now, err, sizeof err);       // the file's ports
 *     ub_port_spec_t spec;
 *     ub_port_spec_parse("udp:bind=127.0.0.1:0,peer=127.0.0.1:5001", &spec, err, sizeof err);
 *     ub_ports_open(&ports, "gcsPortDatalink1", &spec, now, err, sizeof err);
 *     for (;;) {
 *         int n = ub_ports_pollfds(&ports, fds, cap);
 *         poll(fds, n, ub_ports_poll_timeout(&ports, now, 10));
 *         now = monotonic_ms();
 *         ub_ports_service(&ports, now);
 *         ub_node_tick(&node, now);
 *     }
 *     ub_ports_close_all(&ports);
 */
#ifndef UB_PORTS_H
#define UB_PORTS_H

#include <poll.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_compact.h"
#include "ub_config.h"
#include "ub_driver.h"
#include "ub_error.h"
#include "ub_impair.h"
#include "ub_link.h"
#include "ub_node.h"
#include "ub_nodecfg.h"
#include "ub_legacy_link.h"
#include "ub_serial.h"
#include "ub_tcp.h"
#include "ub_udp.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Ports of one ub_ports_t (one per link slot at most). */
#ifndef UB_PORTS_MAX
#define UB_PORTS_MAX UB_MAX_NODE_LINKS
#endif
/** Longest host text ("127.0.0.1"), including the NUL. */
#define UB_PORT_HOST_LEN 64
/** Longest serial device path, including the NUL. */
#define UB_PORT_DEVICE_LEN 64
/** Recommended error buffer size for this API. */
#define UB_PORTS_ERR_LEN 256
/** Default serial rate. */
#define UB_PORT_DEFAULT_BAUD 115200u
/** Drivers one ports set knows at most: the four built-ins and registered ones. */
#ifndef UB_PORTS_MAX_DRIVERS
#define UB_PORTS_MAX_DRIVERS 10
#endif

typedef enum ub_port_kind {
    UB_PORT_NONE = 0,
    UB_PORT_UDP,         /**< bind + peer */
    UB_PORT_TCP_LISTEN,  /**< server */
    UB_PORT_TCP_CONNECT, /**< client (reconnects with backoff) */
    UB_PORT_SERIAL,      /**< device + baud */
    UB_PORT_MEM,         /**< attached by the program */
    UB_PORT_DRIVER       /**< a registered driver's (spec.driver says which) */
} ub_port_kind_t;

/** A parsed port spec. A plain value: its one pointer is to the driver's constant table. A registered
 *  driver keeps its parameters in these same fields (an address in host/port, a path or name in device,
 *  a number in baud or port), as its spec_param() and open() agree. */
typedef struct ub_port_spec {
    ub_port_kind_t kind;
    const ub_driver_t *driver;        /**< the transport (set by the parsers); NULL: none */
    char host[UB_PORT_HOST_LEN];      /**< udp bind / tcp listen / tcp connect address (dotted) */
    uint16_t port;                    /**< its port */
    char peer_host[UB_PORT_HOST_LEN]; /**< udp peer address (dotted) */
    uint16_t peer_port;               /**< 0: no configured peer (udp learns its peers) */
    uint8_t accept;                   /**< udp: ub_udp_accept_t */
    char device[UB_PORT_DEVICE_LEN];  /**< serial device */
    uint32_t baud;                    /**< serial rate */
    uint8_t encoding;                 /**< UB_PORT_ENCODING_FULL or UB_PORT_ENCODING_COMPACT */
    uint16_t mtu;                     /**< 0: no limit */
    uint8_t prio;                     /**< prio=1: send by priority class at the port's byte rate (serial: baud / 10) */
    uint8_t batch;                    /**< udp batch=1: several frames per datagram, sent at each flush (ub_udp_set_batching()) */
    uint32_t rcvbuf;                  /**< udp rcvbuf=BYTES: the socket's receive buffer (ub_udp_set_rcvbuf()); 0: the system's */
} ub_port_spec_t;

#define UB_PORT_ENCODING_FULL 0u
#define UB_PORT_ENCODING_COMPACT 1u

/** @return the transport word of a kind: "udp", "tcp", "serial", "mem", or "none" (also for
 *  UB_PORT_DRIVER: use ub_port_spec_transport()). */
const char *ub_port_kind_transport(ub_port_kind_t kind);

/** @return the transport word of a spec: its driver's name ("udp", "pipe"), or "none". */
const char *ub_port_spec_transport(const ub_port_spec_t *spec);

/**
 * Parses the spec text of the command-line form: `TRANSPORT[:KEY=VALUE[,KEY=VALUE]...]`,
 * e.g. "tcp:connect=127.0.0.1:5001", "udp:bind=127.0.0.1:0,peer=127.0.0.1:5001",
 * "serial:device=/dev/pts/3,baud=57600", "mem".
 * @return UB_OK, or UB_ERR_INVAL with `err` saying what is wrong and what to
 *         write instead (no location prefix: the caller adds where the text came from).
 */
UB_CHECK int ub_port_spec_parse(const char *text, ub_port_spec_t *spec, char *err, size_t err_cap);

/**
 * Splits a whole `--port` argument "NAME=SPEC" into the link name (at most
 * UB_NODECFG_PORT_KEY_MAX characters, may be "entity:link") and the parsed spec.
 * @return UB_OK, or UB_ERR_INVAL with `err` as ub_port_spec_parse() says.
 */
UB_CHECK int ub_port_arg_parse(const char *arg, char *name, size_t name_cap, ub_port_spec_t *spec, char *err,
                               size_t err_cap);

/**
 * Converts a config "ports" entry (shape-checked by ub_nodecfg) into a spec.
 * Errors read "<source>:<line>: port '<name>', field '<param>': <what to do>".
 * @return UB_OK, or UB_ERR_CONFIG with `err` set.
 */
UB_CHECK int ub_port_spec_from_config(const ub_nodecfg_port_t *entry, const char *source, ub_port_spec_t *spec,
                                      char *err, size_t err_cap);

/** Formats a spec back into its command-line form (for messages and "ready" events); a text longer
 *  than `cap` is cut and ends in "...". */
void ub_port_spec_format(const ub_port_spec_t *spec, char *out, size_t cap);

/** Storage of one driver instance: as large as the largest built-in one. Private. */
typedef union ub_port_state {
    ub_udp_t udp_;
    ub_tcp_t tcp_;
    ub_serial_t serial_;
    ub_legacy_link_t legacy_;
    max_align_t align_;
} ub_port_state_t;

/** The largest instance (ub_driver_t.state_size) a driver may have. */
#define UB_DRIVER_STATE_MAX (sizeof(ub_port_state_t))

/** One driver instance: which driver, and its state. Private (ub_ports_state() reads it). */
typedef struct ub_port_driver {
    const ub_driver_t *driver; /**< NULL: empty */
    ub_port_state_t state;
} ub_port_driver_t;

/** One open port. Treat as read-only (use the functions). */
typedef struct ub_port {
    uint8_t in_use;
    uint8_t active;           /**< which of drv[] is current */
    uint8_t impaired;         /**< impair sits between the slot and drv[active] */
    int link_id;
    ub_port_spec_t spec;      /**< the spec now in force */
    uint32_t rebinds;         /**< successful software switches */
    uint64_t service_errors;  /**< driver service calls that failed (e.g. serial device gone) */
    uint8_t notice_reported;  /**< ub_ports_notice() has reported this port's driver notice */
    ub_port_driver_t drv[2];
    ub_impair_t impair;
    uint8_t own_impair;       /**< this port's own impairment overrides the node-wide one */
    uint8_t set_mtu;          /**< the spec set the link's MTU (cleared again when the port closes) */
    ub_compact_t compact;     /**< the link's compact state while the spec asks for encoding=compact */
    ub_impair_params_t own_params;
    uint64_t own_seed;
    ub_impair_params_t eff_params; /**< what is in force when the spec asks for prio=1: the impairment + the byte budget */
    ub_foreign_cb foreign;    /**< ub_ports_set_foreign(): given to every instance of this port, NULL: none */
    void *foreign_user;
} ub_port_t;

/** The ports of one node. Caller-owned; large: use static storage. */
typedef struct ub_ports {
    ub_node_t *node;
    const ub_driver_t *drivers[UB_PORTS_MAX_DRIVERS]; /**< the registry: built-ins first */
    uint8_t driver_count;
    uint8_t impair_on;
    ub_impair_params_t impair_params;
    uint64_t impair_seed;
    ub_port_t port[UB_PORTS_MAX];
} ub_ports_t;

/** Prepares an empty set for `node` and registers the built-in drivers. @return UB_OK or UB_ERR_INVAL. */
UB_CHECK int ub_ports_init(ub_ports_t *ports, ub_node_t *node);

/**
 * Adds a driver (ub_driver.h) to the set's registry: specs naming its transport word then parse and open
 * here. The table must outlive the set.
 * @return UB_OK; UB_ERR_INVAL (NULL, a bad name, an operation missing: spec_param, spec_format, and with
 *         open: close, attach, link_ops, service, pollfds, counters; state_size above
 *         UB_DRIVER_STATE_MAX); UB_ERR_EXISTS (the word is taken); UB_ERR_FULL (UB_PORTS_MAX_DRIVERS).
 */
UB_CHECK int ub_ports_register(ub_ports_t *ports, const ub_driver_t *driver);

/**
 * Writes `len` bytes that are not a uavbus frame (a legacy datalink message: the application's side of the
 * "large case statement", docs/adapters.md) onto the port of `link_name`, whole or not at all.
 * @return UB_OK; UB_ERR_AGAIN (transmit buffer full: try later); UB_ERR_CLOSED (link down); UB_ERR_NOTFOUND
 *         (no open port); UB_ERR_UNSUPPORTED (the transport cannot: UDP, mem); UB_ERR_INVAL.
 */
UB_CHECK int ub_ports_write_foreign(ub_ports_t *ports, const char *link_name, const uint8_t *data, size_t len,
                                    uint64_t now_ms);

/**
 * Gives the port of `link_name` a foreign-traffic handler (issue #24, docs/adapters.md): the bytes of a
 * stream that are not uavbus frames, or the datagrams that are not uavbus, go to `cb(user, run, len)` in
 * order instead of being dropped as garbage. The port keeps it: a software switch gives it to the new
 * transport too; closing the port forgets it. `cb` NULL removes it. Python: Node.set_foreign_handler().
 * @return UB_OK; UB_ERR_INVAL (NULL ports); UB_ERR_NOTFOUND (no open port on that link);
 *         UB_ERR_UNSUPPORTED (its transport cannot: ub_driver_t.set_foreign is NULL).
 */
UB_CHECK int ub_ports_set_foreign(ub_ports_t *ports, const char *link_name, ub_foreign_cb cb, void *user);

/** ub_port_spec_parse() knowing the drivers registered in `ports` too. */
UB_CHECK int ub_ports_spec_parse(const ub_ports_t *ports, const char *text, ub_port_spec_t *spec, char *err,
                                 size_t err_cap);

/** ub_port_arg_parse() knowing the drivers registered in `ports` too. */
UB_CHECK int ub_ports_arg_parse(const ub_ports_t *ports, const char *arg, char *name, size_t name_cap,
                                ub_port_spec_t *spec, char *err, size_t err_cap);

/** ub_port_spec_from_config() knowing the drivers registered in `ports` too. */
UB_CHECK int ub_ports_spec_from_config(const ub_ports_t *ports, const ub_nodecfg_port_t *entry, const char *source,
                                       ub_port_spec_t *spec, char *err, size_t err_cap);

/**
 * Opens `spec` behind link `link_name` (a link of a hosted entity; "entity:link"
 * also accepted), or switches an open one to it (see the file comment).
 * @return UB_OK; UB_ERR_NOTFOUND (no such link in the node); UB_ERR_INVAL
 *         (bad spec, or a transport that cannot be opened from a spec: mem); UB_ERR_IO (socket/device could not
 *         be opened: the old transport, if any, stays in place); UB_ERR_FULL.
 *         `err` says which and what to do.
 */
UB_CHECK int ub_ports_open(ub_ports_t *ports, const char *link_name, const ub_port_spec_t *spec, uint64_t now_ms,
                           char *err, size_t err_cap);

/** ub_ports_spec_parse() + ub_ports_open(). */
UB_CHECK int ub_ports_open_text(ub_ports_t *ports, const char *link_name, const char *spec_text, uint64_t now_ms,
                                char *err, size_t err_cap);

/**
 * Opens every "ports" entry of `cfg` that names a link of this node (entries
 * for links of entities hosted elsewhere are skipped, and so are `mem` ones).
 * @return the number of ports opened; UB_ERR_CONFIG (bad entry: "<file>:<line>: port ...");
 *         or the error of ub_ports_open() with `err` prefixed by the entry's file:line.
 */
UB_CHECK int ub_ports_open_config(ub_ports_t *ports, const ub_nodecfg_t *cfg, uint64_t now_ms, char *err,
                                  size_t err_cap);

/** Closes the port of `link_name` and detaches its slot. @return UB_OK or UB_ERR_NOTFOUND. */
UB_CHECK int ub_ports_close(ub_ports_t *ports, const char *link_name);

/** Closes every port (detaching the slots). Safe to call twice. */
void ub_ports_close_all(ub_ports_t *ports);

/**
 * Services every open port without blocking: reads, flushes, TCP accepts and
 * reconnects, impairment releases. Also re-installs the impairment in front of
 * a TCP port whose driver re-attached itself on a new connection.
 * @return frames/datagrams handed to the node (driver errors are counted per port).
 */
int ub_ports_service(ub_ports_t *ports, uint64_t now_ms);

/**
 * Sends what every port holds queued (a UDP port with batch=1 packs frames into datagrams and sends them
 * at a flush: ub_udp_flush()), without reading anything. A program that sends from outside its poll loop
 * (a Zenoh thread handing a sample to the router, a Python publish) calls it after its sends, so nothing
 * waits for the next turn; ub_ports_service() and ub_ports_drain() flush too.
 * @return frames still queued because a socket refused them (a full buffer: poll for POLLOUT, the next
 *         service sends them), 0 when all left; UB_ERR_INVAL (NULL).
 */
int ub_ports_flush(ub_ports_t *ports);

/**
 * ub_ports_service() after a poll() over ub_ports_pollfds()'s descriptors (`fds[0, nfds)`, revents set by
 * poll()): a port whose driver is ready_only (ub_driver.h: UDP) is serviced only when poll() reported one of
 * its descriptors (matched by descriptor, so a port rebound since the poll() is safe) or its next_due() has
 * come; every other port, and every impairment queue, as ub_ports_service() does. A loop woken by a timer or
 * by one port's input so reads no socket that has nothing (issue 28 item 5: 3.9 of 4 reads found nothing).
 * @return frames/datagrams handed to the node; 0 on a NULL `ports`. `fds` NULL counts as no descriptor ready.
 */
int ub_ports_service_ready(ub_ports_t *ports, const struct pollfd *fds, int nfds, uint64_t now_ms);

/**
 * Fills `fds` with the descriptors to poll: POLLIN for every socket and
 * device (TCP servers: listening and connected), plus POLLOUT while output is
 * pending or a TCP connect is in progress.
 * @return the number filled, or UB_ERR_NOSPACE (more than `cap` needed;
 *         2 * UB_PORTS_MAX always suffices).
 */
UB_CHECK int ub_ports_pollfds(const ub_ports_t *ports, struct pollfd *fds, int cap);

/**
 * A poll() timeout: ms until the next impairment release or TCP retry is due,
 * capped at `max_ms` (and 0 when something is due already).
 */
int ub_ports_poll_timeout(const ub_ports_t *ports, uint64_t now_ms, int max_ms);

/**
 * Reads back the local port of `link_name`: a UDP port's bound port, a TCP
 * server's listening port.
 * @return UB_OK; UB_ERR_NOTFOUND (no open port for that link); UB_ERR_INVAL (a
 *         TCP client or serial port has no local port); UB_ERR_IO.
 */
UB_CHECK int ub_ports_local_port(const ub_ports_t *ports, const char *link_name, uint16_t *port);

/**
 * The next one-time notice a program should show its user (log or stderr), e.g. the first datagram a
 * UDP port refused because it came from an address that is not its peer. Each such condition is
 * reported once per port (counters keep counting).
 * @return 1 with the message in `out`; 0 when there is nothing (left) to report; UB_ERR_INVAL.
 */
int ub_ports_notice(ub_ports_t *ports, char *out, size_t cap);

/** Why ub_ports_drain() returned. */
typedef enum ub_drain_end {
    UB_DRAIN_EMPTY = 0, /**< the output holds nothing: no reason to wait for company */
    UB_DRAIN_IDLE = 1,  /**< a round after an `idle_us` gap read nothing: the input went quiet, send now */
    UB_DRAIN_FULL = 2,  /**< the output holds `flush_at` bytes */
    UB_DRAIN_AGED = 3,  /**< `max_us` since the drain began, the input still busy */
    UB_DRAIN_WOKEN = 4  /**< `wake_fd` became readable: the caller has other work */
} ub_drain_end_t;

/** The descriptors a drain watches: every port's (2 * UB_PORTS_MAX) and the caller's wake_fd. */
#define UB_DRAIN_FDS (2 * UB_PORTS_MAX + 1)

/**
 * How ub_ports_drain() waits for company, and what it saw (caller-owned; set the first five fields and zero
 * the rest, e.g. `ub_ports_drain_t d = {.wake_fd = -1, ...}`).
 */
typedef struct ub_ports_drain {
    int wake_fd;           /**< a descriptor whose readiness ends the wait at once (-1: none) */
    uint32_t idle_us;      /**< the gap: the input is idle when nothing came in this long (0: when a second read finds none) */
    uint32_t max_us;       /**< a drain ends this long after its first pending frame however busy the input (a batch's age) */
    const size_t *pending; /**< bytes the caller's output holds (e.g. &batchlink.len); NULL: the drain never waits */
    size_t flush_at;       /**< *pending reaching this ends the drain (bounds a batch's size) */
    struct pollfd fds[UB_DRAIN_FDS]; /**< the ports' descriptors as of the last drain (then wake_fd, if any) */
    int nfds;              /**< entries of fds[] that are the ports' */
    uint32_t fds_gen;      /**< bumped whenever the ports' descriptors or their events changed */
    uint64_t drains, rounds; /**< calls; ub_ports_service() rounds in them */
    uint64_t ends[5];      /**< drains by ub_drain_end_t */
} ub_ports_drain_t;

/**
 * The input side of a forwarding loop in one call (the Zenoh bridge's turn): services the ports (every
 * datagram they hold goes to the node), and while the caller's output holds something (`*pending` > 0)
 * sleeps a gap (waking early only for `wake_fd`: `idle_us` first, doubled after each round that read
 * something) and services them again, until a round after a gap
 * reads nothing (the input went idle), the output reaches `flush_at` bytes, `max_us` have passed since the
 * first frame was pending, or `wake_fd` is readable; then ticks the node once at `now_ms`, flushes what
 * the ports queued (ub_ports_flush(): the tick's frames leave now, not a poll timeout later) and refreshes
 * fds[]. The caller sends its output after any non-EMPTY end, so nothing waits beyond one drain: a lone
 * frame after a quiet spell leaves one gap later, a burst leaves in batches of up to `flush_at` bytes or
 * `max_us` of input. The gap is slept through whole, so a busy input costs a few rounds per drain, not a
 * wake-up per datagram. Time is read from CLOCK_MONOTONIC only to bound the drain.
 * @return a ub_drain_end_t; UB_ERR_INVAL on a NULL argument or a port set without a node; the error of
 *         ub_ports_pollfds() (cannot happen: fds[] has room for every port).
 */
UB_CHECK int ub_ports_drain(ub_ports_t *ports, ub_ports_drain_t *how, uint64_t now_ms);

/** @return the UDP driver now behind `link_name` (its stats and peers, ub_udp.h), or NULL if that
 *  link has no open UDP port. */
const ub_udp_t *ub_ports_udp(const ub_ports_t *ports, const char *link_name);

/**
 * The driver instance now behind `link_name`, for that driver's own functions (ub_tcp_stats()...).
 * @return its state, or NULL when the link has no open port or (`driver` not NULL) another transport.
 */
const void *ub_ports_state(const ub_ports_t *ports, const char *link_name, const ub_driver_t *driver);

/**
 * The counters of the driver instance behind `link_name` (ub_driver_t.counters: its stats by name).
 * @return how many it has (may exceed `cap`); UB_ERR_NOTFOUND (no open port); UB_ERR_INVAL.
 */
int ub_ports_counters(const ub_ports_t *ports, const char *link_name, ub_driver_counter_t *out, size_t cap);

/**
 * Describes the driver instance behind `link_name` as one JSON member: its transport word and the
 * object of its state and counters, e.g. `"tcp":{"state":"up","connects":1,...}` (what the stats event
 * carries in a link's entry, after "port"). A text longer than `cap` is cut and ends in "...".
 * @return the length written; UB_ERR_NOTFOUND (no open port); UB_ERR_NOSPACE (cut); UB_ERR_INVAL.
 */
int ub_ports_describe(const ub_ports_t *ports, const char *link_name, char *out, size_t cap);

/** @return the open port of `link_name`, or NULL. */
const ub_port_t *ub_ports_find(const ub_ports_t *ports, const char *link_name);

/**
 * Puts the seeded impairment (ub_impair.h) in front of every socket and serial
 * port, open now or opened later; each port gets its own PRNG stream
 * (seed mixed with its link id). `params` NULL (or all zero) removes it.
 * @return UB_OK or UB_ERR_INVAL.
 */
UB_CHECK int ub_ports_set_impairment(ub_ports_t *ports, const ub_impair_params_t *params, uint64_t seed);

/**
 * Gives the open port of `link_name` its own impairment, which takes
 * precedence over ub_ports_set_impairment() (e.g. one radio link out of
 * range: loss 1, while the others keep the node-wide model). `params` NULL
 * (or all zero) removes the override: the node-wide setting applies again.
 * The override goes with the port when it is closed.
 * @return UB_OK; UB_ERR_NOTFOUND (no open port for that link); UB_ERR_INVAL.
 */
UB_CHECK int ub_ports_set_link_impairment(ub_ports_t *ports, const char *link_name, const ub_impair_params_t *params,
                                          uint64_t seed);

#ifdef __cplusplus
}
#endif
#endif /* UB_PORTS_H */

/**
 * @file ub_driver.h
 * @brief The driver interface: what a transport (UDP, TCP, serial, a radio modem, CAN, a test pipe)
 *        provides so that ports (ub_ports.h) can open it from a port spec, service it from one poll()
 *        loop, switch it at run time and report its counters, without ub_ports naming it.
 *
 * A driver is one `const ub_driver_t` table (LCM's provider vtable, libcsp's interface): a transport word
 * ("udp"), the spec parameters it takes, and operations on one **instance**. Instances live in storage
 * the ports set owns (two per port, so a rebind holds the old and the new one at once): a driver never
 * allocates, and keeps no state outside its instance (`state`, `state_size` bytes, zeroed before open).
 *
 * Registration: ub_ports_init() registers the built-in drivers (udp, tcp, serial, and mem, which is
 * parsed but attached by the program); ub_ports_register() adds one more at run time. A registered
 * driver is chosen by its transport word in every spec form: `--port LINK=pipe:fd=7`, the config's
 * `"transport": "pipe"`, a rebind. docs/architecture.md, "A new transport in six steps", walks
 * through writing one; runtime_c/tests/test_driver_pipe.c is a complete one in ~150 lines.
 *
 * Contracts every operation keeps:
 *  - Errors are negative ub_error_t codes. A message written into `err` is one line saying what is
 *    wrong and what to write instead, without a location (the caller adds "port 'NAME': ..." or
 *    "file:line: ..."); ub_ports replaces control and non-ASCII bytes in it by '?'.
 *  - open() leaves errno as the failing system call set it (ub_ports reports strerror(errno) and retries
 *    a rebind after closing the old instance when errno is EADDRINUSE).
 *  - Nothing blocks: service() reads what is waiting and returns; sends queue or return UB_ERR_AGAIN.
 *  - close() is safe on an instance that failed to open or was closed already.
 *  - Optional operations may be NULL; the comment of each says what NULL means.
 */
#ifndef UB_DRIVER_H
#define UB_DRIVER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_error.h"
#include "ub_link.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ub_node ub_node_t;
struct ub_port_spec; /* ub_ports.h: the parsed spec a driver fills and opens from */
struct pollfd;       /* <poll.h>: a driver includes it; this header stays portable (ub_driver_attach() is core) */

/** Longest transport word, without the NUL ("serial"). Words are lower-case letters and digits. */
#define UB_DRIVER_NAME_MAX 15

/** One named counter of an instance (ub_driver_t.counters). `name` is static text. */
typedef struct ub_driver_counter {
    const char *name;
    uint64_t value;
} ub_driver_counter_t;

/** A transport. Give it static storage duration and `const`: ports keep a pointer to it. */
typedef struct ub_driver {
    /** Transport word of the spec ("udp"): 1..UB_DRIVER_NAME_MAX lower-case letters or digits. */
    const char *name;
    /** The parameter keys, for messages: "bind, peer, accept" ("none" when it takes none). */
    const char *keys;
    /** One or more example specs separated by " | ", quoted in messages about a spec. */
    const char *examples;
    /** Takes the link's wire parameters `encoding=` and `mtu=` (parsed by ub_ports: every transport
     *  that carries frames; false only for one that cannot be opened from a spec, like mem). */
    bool wire_params;
    /** Bytes of one instance; at most UB_DRIVER_STATE_MAX (ub_ports.h); ub_ports_register() checks. */
    size_t state_size;

    /* ---- the spec ---- */

    /** Optional: fills the defaults of a new spec (spec->kind, a default rate...). The spec is zeroed and
     *  spec->driver set first. NULL: kind UB_PORT_DRIVER, no defaults. */
    void (*spec_init)(struct ub_port_spec *spec);
    /**
     * One KEY=VALUE of a spec. `seen` is the driver's own bit set across one spec's parameters (starts 0),
     * e.g. to refuse a key given twice.
     * @return UB_OK; UB_ERR_NOTFOUND when `key` is not one of the driver's (ub_ports then tries the wire
     *         parameters, then reports it unknown, listing `keys`); UB_ERR_INVAL with `err` naming the key.
     */
    int (*spec_param)(struct ub_port_spec *spec, uint32_t *seen, const char *key, const char *value, char *err,
                      size_t err_cap);
    /** Optional: checks the whole spec once every parameter was read (a required key missing...).
     *  @return UB_OK or UB_ERR_INVAL with `err` set. NULL: every spec is complete. */
    int (*spec_finish)(struct ub_port_spec *spec, uint32_t seen, char *err, size_t err_cap);
    /** Writes the spec back in its command-line form without the wire parameters ("udp:bind=..."), so that
     *  parsing the text gives the same spec. @return what snprintf() returns. */
    int (*spec_format)(const struct ub_port_spec *spec, char *out, size_t cap);

    /* ---- one instance ---- */

    /** Opens the socket or device of `spec` into `state` (zeroed, not attached yet). NULL: the transport
     *  cannot be opened from a spec (mem: the program attaches it). @return UB_OK, UB_ERR_IO (errno set)... */
    int (*open)(void *state, const struct ub_port_spec *spec);
    /** Closes what open() opened. The node slot may still point at the instance: ub_ports re-attaches or
     *  detaches it. Safe to call twice. */
    void (*close)(void *state);
    /** Puts the instance behind link slot `link_id` of `node` (ub_node_link_attach(), most simply through
     *  ub_driver_attach()) and remembers the slot for service(). @return UB_OK or its error. */
    int (*attach)(void *state, ub_node_t *node, int link_id);
    /** The link vtable behind the slot; its `impl` is `state`. ub_ports uses it to put the impairment
     *  (ub_impair.h) in front of the instance and to take it away again. */
    const ub_link_ops_t *link_ops;
    /** Optional: runs right after a successful attach (a TCP client starts its first connection attempt
     *  here rather than at the first service). NULL: nothing. */
    void (*start)(void *state, ub_node_t *node, uint64_t now_ms);
    /** Reads what is waiting, flushes, accepts, reconnects; never blocks.
     *  @return frames or datagrams handed to the node, or a negative code (counted in the port's
     *  service_errors). */
    int (*service)(void *state, ub_node_t *node, uint64_t now_ms);
    /** Fills `fds` with the descriptors to poll (POLLIN, plus POLLOUT while output is pending).
     *  @return the number filled (0 while it has none, e.g. waiting to reopen), or UB_ERR_NOSPACE when
     *  more than `cap` are needed (at most 2 per instance: ub_ports sizes the caller's array so). */
    int (*pollfds)(const void *state, struct pollfd *fds, int cap);
    /** Optional: true with `*due_ms` set when the instance must be serviced at that time even if none of
     *  its descriptors wakes the loop (a reconnect or reopen retry). NULL: never. */
    bool (*next_due)(const void *state, uint64_t *due_ms);
    /** Optional: the local port (a UDP socket's bound port, a TCP server's listening port).
     *  NULL: UB_ERR_INVAL (the transport has none). */
    int (*local_port)(const void *state, uint16_t *port);
    /** Fills at most `cap` counters (the driver's stats, by name); `out` may be NULL with `cap` 0.
     *  @return how many it has (may exceed `cap`). */
    size_t (*counters)(const void *state, ub_driver_counter_t *out, size_t cap);
    /** Writes the instance's state and counters as JSON object members, without braces
     *  (`"state":"up","connects":1,...`): the object the stats event carries under the transport word
     *  (ub_ports_describe()). Optional: NULL writes the first 32 counters() (ub_driver_format_counters()).
     *  @return what snprintf() returns. */
    int (*describe)(const void *state, char *out, size_t cap);
    /** Optional: a condition the user should hear of once per port (a UDP datagram refused from a sender
     *  that is not the peer). @return 1 with the message in `out` (`link_name` names the link), else 0.
     *  ub_ports asks until the first 1, then never again for that port. */
    int (*notice)(const void *state, const char *link_name, char *out, size_t cap);
    /** Optional: gives the instance a foreign-traffic handler (ub_frame.h, docs/adapters.md): every run of
     *  received bytes that is not a uavbus frame (a stream transport), or every datagram that is not uavbus,
     *  goes to `cb(user, ...)`. `cb` NULL removes it. ub_ports_set_foreign() calls it, and again on the new
     *  instance after a software switch. NULL: the transport cannot (UB_ERR_UNSUPPORTED). @return UB_OK. */
    int (*set_foreign)(void *state, ub_foreign_cb cb, void *user);
    /** Optional: writes bytes that are not a uavbus frame (a legacy datalink message, a device's command)
     *  onto the link, whole or not at all, between frames. ub_ports_write_foreign() calls it. NULL: the
     *  transport cannot (UB_ERR_UNSUPPORTED). @return UB_OK, UB_ERR_AGAIN (full: later), UB_ERR_CLOSED. */
    int (*write_foreign)(void *state, const uint8_t *data, size_t len, uint64_t now_ms);
    /** Optional: sends what the instance queued (UDP with batch=1), reading nothing; ub_ports_flush() calls it.
     *  @return frames still queued (the socket refused them: poll for POLLOUT), or a negative code.
     *  NULL: the transport sends at once (nothing is ever queued between calls). */
    int (*flush)(void *state);
    /** true when service() has work only while one of the instance's descriptors is ready (poll()'s
     *  revents: input, room for pending output, an error) or next_due() has come: every timer of the
     *  instance is in next_due(). ub_ports_service_ready() then skips the instance on the other loop turns
     *  (no read that finds nothing). false (the default, e.g. a device adapter that writes on its own
     *  schedule): serviced on every turn. */
    bool ready_only;
} ub_driver_t;

/**
 * The attach every driver shares: ub_node_link_attach(node, link_id, ops, impl) and, when that worked,
 * `*node_out` = node and `*link_out` = link_id (the instance's own record of its slot, which service()
 * and a re-attach after a reconnect use).
 * @return UB_OK; UB_ERR_INVAL (NULL); or the error of ub_node_link_attach().
 */
UB_CHECK int ub_driver_attach(ub_node_t *node, int link_id, const ub_link_ops_t *ops, void *impl,
                              ub_node_t **node_out, int *link_out);

/**
 * Re-attaches an instance to the slot it recorded (a stream transport whose connection or device is new:
 * re-attaching resets the slot's decoder, so no half frame of the old stream survives).
 * @return UB_OK, or UB_ERR_INVAL when it was never attached.
 */
UB_CHECK int ub_driver_reattach(ub_node_t *node, int link_id, const ub_link_ops_t *ops, void *impl);

/** Decimal text "0".."max" to `*out` (digits only: no sign, no spaces). @return true when it is one. */
bool ub_driver_parse_u32(const char *text, uint32_t max, uint32_t *out);

/** Writes `"name":value` pairs separated by ',' (the default describe()). @return what snprintf() returns. */
int ub_driver_format_counters(const ub_driver_counter_t *counters, size_t n, char *out, size_t cap);

#ifdef __cplusplus
}
#endif
#endif /* UB_DRIVER_H */

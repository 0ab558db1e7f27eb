/*
 * What every device adapter on a serial port shares (docs/adapters.md): the port spec (`device`, `baud`,
 * `dir`), opening the serial link through a decoder of its own whose foreign-traffic handler is the
 * adapter's parser, finding and checking the directory in the node's catalogue, servicing, polling and
 * the link's half of the counters. An adapter writes only what is its own: its parser, what a decoded
 * message writes into the directory, its counters (and, to write to the device, what a service call sends).
 *
 * Shape: an adapter's `const adapter_serial_kind_t` starts with its `ub_driver_t` (filled by
 * ADAPTER_SERIAL_DRIVER), so the one table ub_ports keeps a pointer to is both; the shared operations find
 * the kind again from the spec (spec->driver) or from the instance. The instance struct starts with an
 * `adapter_serial_t`, which starts with the `ub_serial_t`: the link's impl is the serial link itself and
 * every serial operation (ub_serial_ops) applies unchanged.
 *
 *     typedef struct my_adapter { adapter_serial_t base; my_parser_t parser; } my_adapter_t;
 *     static size_t my_feed(adapter_serial_t *a, const uint8_t *run, size_t len) { ... return len; }
 *     const adapter_serial_kind_t adapter_my = {
 *         .driver = ADAPTER_SERIAL_DRIVER("my", "my:device=/dev/ttyS1,baud=9600", my_adapter_t),
 *         .dir_type = "myDevice_t", .default_dir = "myDevice", .default_baud = 9600,
 *         .dir_size = sizeof(myDevice_t), .reset = my_reset, .feed = my_feed, .counters = my_counters};
 *     ub_ports_register(&ports, &adapter_my.driver);
 */
#ifndef ADAPTER_SERIAL_H
#define ADAPTER_SERIAL_H

#include <stddef.h>
#include <stdint.h>

#include "ub/ub_driver.h"
#include "ub/ub_frame.h"
#include "ub/ub_ports.h"
#include "ub/ub_serial.h"

typedef struct adapter_serial adapter_serial_t;

/** One kind of adapter. Static storage, const: ub_ports keeps a pointer to `driver`, its first member. */
typedef struct adapter_serial_kind {
    ub_driver_t driver;       /**< first: ADAPTER_SERIAL_DRIVER(...) */
    const char *dir_type;     /**< the directory's C type, for messages ("nmeaGps_t") */
    const char *default_dir;  /**< the directory written when the spec names none ("gpsNmea") */
    uint32_t default_baud;
    size_t dir_size;          /**< sizeof the directory's struct: attach fails closed on another layout */
    /** At open: empty the parser (the instance was zeroed first). */
    void (*reset)(adapter_serial_t *a);
    /** The link's foreign bytes, the directory attached (`a->dir` set). @return the bytes it took. */
    size_t (*feed)(adapter_serial_t *a, const uint8_t *run, size_t len);
    /** Optional: each service call, before the link is read (time-outs, writes to the device). */
    void (*service)(adapter_serial_t *a, uint64_t now_ms);
    /** The parser's counters, first in the port's list (the link's follow). @return how many it has. */
    size_t (*counters)(const adapter_serial_t *a, ub_driver_counter_t *out, size_t cap);
} adapter_serial_kind_t;

/** The part of an adapter's instance the helper owns; first member of the adapter's own struct. */
struct adapter_serial {
    ub_serial_t serial; /* first: the link's impl (ub_serial_ops) is this serial link */
    ub_decoder_t dec;   /* the link's decoder; its foreign-traffic handler is the kind's feed */
    const adapter_serial_kind_t *kind;
    void *dir;          /* the directory's bound storage; NULL until attached (foreign bytes refused) */
    ub_node_t *node;    /* the node attached to, for adapter_serial_directory() */
    uint64_t now_ms;    /* the service call's time, for the directory's timeTag */
    char dir_name[UB_PORT_HOST_LEN];
};

/* The shared operations (adapter_serial.c); ADAPTER_SERIAL_DRIVER names them. */
void adapter_serial_spec_init(ub_port_spec_t *spec);
int adapter_serial_spec_param(ub_port_spec_t *s, uint32_t *seen, const char *key, const char *value, char *err,
                              size_t cap);
int adapter_serial_spec_finish(ub_port_spec_t *s, uint32_t seen, char *err, size_t cap);
int adapter_serial_spec_format(const ub_port_spec_t *spec, char *out, size_t cap);
int adapter_serial_open(void *state, const ub_port_spec_t *spec);
void adapter_serial_close(void *state);
int adapter_serial_attach(void *state, ub_node_t *node, int link_id);
int adapter_serial_service(void *state, ub_node_t *node, uint64_t now_ms);
int adapter_serial_pollfds(const void *state, struct pollfd *fds, int cap);
bool adapter_serial_next_due(const void *state, uint64_t *due_ms);
size_t adapter_serial_counters(const void *state, ub_driver_counter_t *out, size_t cap);

/**
 * Writes `len` bytes of the device's own protocol (a configuration message) onto the link, whole or not
 * at all, between uavbus frames. @return UB_OK, UB_ERR_AGAIN (transmit buffer full), UB_ERR_CLOSED (down).
 */
int adapter_serial_write(adapter_serial_t *a, const uint8_t *data, size_t len);

/** Copies at most `cap` of the `n` counters `all` to `out` (may be NULL). @return n (the counters() contract). */
size_t adapter_serial_put_counters(const ub_driver_counter_t *all, size_t n, ub_driver_counter_t *out, size_t cap);

/**
 * Another directory the adapter uses (the one a device is configured through): the bound storage of the
 * catalogued instance `name` if its type's C size is `size`, else NULL (not catalogued, not hosted, or of
 * another layout: the adapter then does not write to the device). Only once attached.
 */
void *adapter_serial_directory(adapter_serial_t *a, const char *name, size_t size);

/** The driver table of an adapter kind: transport word, examples, instance struct. */
#define ADAPTER_SERIAL_DRIVER(word, examples_, instance_type)                                                 \
    {                                                                                                         \
        .name = (word), .keys = "device, baud, dir", .examples = (examples_),                                 \
        .wire_params = false, /* the link carries full frames between the device's messages */               \
        .state_size = sizeof(instance_type), .spec_init = adapter_serial_spec_init,                           \
        .spec_param = adapter_serial_spec_param, .spec_finish = adapter_serial_spec_finish,                   \
        .spec_format = adapter_serial_spec_format, .open = adapter_serial_open, .close = adapter_serial_close, \
        .attach = adapter_serial_attach, .link_ops = &ub_serial_ops, .service = adapter_serial_service,       \
        .pollfds = adapter_serial_pollfds, .next_due = adapter_serial_next_due,                               \
        .counters = adapter_serial_counters,                                                                  \
    }

#endif /* ADAPTER_SERIAL_H */

/**
 * @file ub_legacy_link.h
 * @brief A serial link in the paper's legacy datalink format (section IV): every uavbus frame travels as one
 *        message of a registered type inside the envelope of ub_legacy.h, and every other message type on
 *        the stream goes whole, byte-exact, to the link's foreign-traffic handler (the application's "large
 *        case statement"), so an old ground station that knows only its legacy types keeps working on the
 *        same wire, and a type unknown to uavbus is passed on, not dropped.
 *
 *     legacy:device=/dev/ttyS1[,baud=115200][,type=200]
 *
 * `type` (1..65535, default UB_LEGACY_DEFAULT_TYPE) is the message type the uavbus frames are carried as.
 * Received: a message of that type whose payload is a valid frame goes to the node (one frame per message,
 * checked like a datagram); one whose payload is not a frame is counted `frames_rejected`; other types go to
 * the handler (ub_ports_set_foreign(), Python Node.set_foreign_handler()) as whole messages, header
 * included, or are counted `unhandled` when there is none. Bad checksums are counted by the envelope parser.
 * Sent: each frame in one message of `type`, written whole between other messages; the application writes
 * its legacy messages with ub_ports_write_foreign() (build them with ub_legacy_build()). A device that hangs
 * up is reopened as a serial link is (ub_serial.h); the parser starts afresh with the new stream.
 */
#ifndef UB_LEGACY_LINK_H
#define UB_LEGACY_LINK_H

#include <stdint.h>

#include "ub_driver.h"
#include "ub_legacy.h"
#include "ub_serial.h"

#ifdef __cplusplus
extern "C" {
#endif

/** The message type uavbus frames are carried as when the spec names none. */
#define UB_LEGACY_DEFAULT_TYPE 200u

typedef struct ub_legacy_link_stats {
    uint64_t frames_in;        /**< uavbus messages whose frame the node took in (any verdict) */
    uint64_t frames_rejected;  /**< uavbus messages whose payload is not a valid frame */
    uint64_t frames_out;       /**< frames sent, one message each */
    uint64_t foreign_messages; /**< other types handed to the handler */
    uint64_t foreign_refused;  /**< of those, the bytes the handler did not take */
    uint64_t unhandled;        /**< other types while no handler was set: counted, dropped */
} ub_legacy_link_stats_t;

/** One instance; caller- (ports-) owned. Treat as private. */
typedef struct ub_legacy_link {
    ub_serial_t serial; /* first: the serial link underneath */
    ub_legacy_t parser;
    uint16_t type;
    ub_foreign_cb foreign;
    void *foreign_user;
    uint64_t now_ms;
    ub_legacy_link_stats_t stats;
} ub_legacy_link_t;

/** The transport vtable (kind "legacy"); `impl` is the ub_legacy_link_t. */
extern const ub_link_ops_t ub_legacy_link_ops;

/** The driver entry ub_ports opens "legacy:..." specs with (built in). */
extern const ub_driver_t ub_legacy_driver;

#ifdef __cplusplus
}
#endif
#endif /* UB_LEGACY_LINK_H */

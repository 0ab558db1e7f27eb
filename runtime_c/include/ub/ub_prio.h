/**
 * @file ub_prio.h
 * @brief Priority classes of frames on slow links (issue 28, docs/pubsub.md "Priorities on slow links").
 *
 * Every frame a node sends has a **class**, derived where it leaves (never carried on the wire,
 * docs/wire-format.md "Priority classes") from its admin code and, for DATA, from the class the node's
 * configuration gives its content:
 *
 *   | class     | frames                                                                        |
 *   |-----------|-------------------------------------------------------------------------------|
 *   | command   | every admin frame but FRAGMENT (requests, STOPs, ACK/NACK, challenges,        |
 *   |           | routing, membership, inspection, link hellos, revocations); DATA of a content |
 *   |           | configured "command"                                                          |
 *   | control   | DATA of a content configured "control" (setpoints, mode changes)              |
 *   | telemetry | DATA of every other content (the default)                                     |
 *   | bulk      | FRAGMENT (a large directory in pieces); DATA of a content configured "bulk"   |
 *
 * The node hands the class to a transport that asks for it (ub_link_ops_t.send_class); a transport with
 * a byte budget (the impairment's bandwidth model with `prio=1`, ub_impair.h) then puts the medium to the
 * highest class waiting whenever it is free, with a bounded queue per class (capacities in ub_config.h):
 * a full telemetry queue drops its **oldest** frame for the new one (counted `shed`); a full queue of any
 * other class pushes back (UB_ERR_AGAIN, counted `backpressure`: fragments pause and go on later, a
 * request is sent again by its retry). A frame on the medium is never interrupted, so a command waits at
 * most the frame being sent: one MTU time. Bulk is not starved by a telemetry flood: after
 * UB_PRIO_BULK_EVERY telemetry frames taken while bulk waited, one bulk frame goes.
 */
#ifndef UB_PRIO_H
#define UB_PRIO_H

#include <stdint.h>

#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Priority classes, highest first: a lower number always leaves first. */
typedef enum ub_prio_class {
    UB_PRIO_COMMAND = 0,   /**< administration and commands */
    UB_PRIO_CONTROL = 1,   /**< control data (a content configured "control") */
    UB_PRIO_TELEMETRY = 2, /**< ordinary DATA: the default class of a content */
    UB_PRIO_BULK = 3,      /**< fragments of large directories; contents configured "bulk" */
    UB_PRIO_CLASSES = 4
} ub_prio_class_t;

/** @return "command", "control", "telemetry", "bulk", or "?" when out of range. */
const char *ub_prio_class_name(ub_prio_class_t cls);

/** Reads a class name as ub_prio_class_name() writes it. @return UB_OK or UB_ERR_INVAL. */
UB_CHECK int ub_prio_class_parse(const char *name, ub_prio_class_t *cls);

/**
 * The class of a frame from its admin code (ub_frame.h) and, for DATA (code 0), `data_class`: the class
 * configured for its content (UB_PRIO_TELEMETRY when none, or when the content is not in the catalogue).
 * FRAGMENT is always bulk; every other admin code is command. A `data_class` out of range is telemetry.
 */
ub_prio_class_t ub_prio_class_of(uint8_t admin, ub_prio_class_t data_class);

#ifdef __cplusplus
}
#endif
#endif /* UB_PRIO_H */

/**
 * @file ub_impair.h
 * @brief Link impairment: a decorator transport that sits in front of any
 *        other transport (UDP, TCP, serial, memlink...) and loses, duplicates,
 *        reorders and delays the frames its node sends, reproducibly.
 *
 * It impairs one direction: what this node sends on the link. Two nodes that
 * both impair their end get both directions impaired, each with its own seed.
 * Decisions come from a PRNG (xorshift64*) whose state lives in the struct,
 * so a seed gives the same sequence of decisions on every run and in every
 * binding (Python uses this same code through cffi).
 *
 * Per frame the node hands to ub_impair_ops.send, in this order:
 *  0. packet MTU (`mtu`): a frame longer than the medium's packet is not sent;
 *     counted `too_big`, and refused with UB_ERR_RANGE (the node counts a
 *     tx_error: the sender learns that its link cannot carry it).
 *  1. loss (`loss_ppm`): the frame is not sent; counted `lost`. The node saw a
 *     successful send (that is what a lossy medium looks like to a sender).
 *  2. duplication (`dup_ppm`): a second copy is sent; counted `duplicated`.
 *  3. each copy waits `delay_ms` plus a uniform 0..`jitter_ms` (counted
 *     `delayed` when that is non-zero) in a bounded queue of UB_IMPAIR_DEPTH
 *     frames; ub_impair_service() releases it at its due time.
 *  4. reordering (`reorder_ppm`): the copy is held back and released right
 *     after the next frame that leaves (the paper's "sent after the next
 *     one"); counted `reordered`. If no other frame leaves within
 *     `reorder_hold_ms` (default UB_IMPAIR_REORDER_HOLD_MS) it leaves alone,
 *     so a held frame is never stuck.
 *  5. byte rate (`rate_Bps`, bytes per second): the medium carries one copy at a
 *     time, each for len / rate seconds, in the order they were sent; a copy
 *     leaves when the one before it has been carried and its own bytes have
 *     gone (then its delay and jitter): a serial radio's throughput on the
 *     injected clock, to the microsecond. Copies wait in the same bounded queue
 *     (the radio's buffer): when it is full the sender is pushed back
 *     (UB_ERR_AGAIN, counted backpressure by the node), as a modem with flow
 *     control does. A 57,600-baud UART moves 5,760 bytes/s (10 bits a byte).
 * With nothing queued and a copy due at once, it goes straight to the inner
 * transport and the inner result is returned (so backpressure and errors
 * still reach the node's counters). A copy that does not fit in the queue is
 * refused: UB_ERR_AGAIN for the original (the node counts backpressure),
 * `queue_full` for either. A queued copy the inner transport later refuses is
 * counted `inner_again` / `inner_errors`. Nothing is lost uncounted:
 *
 *     offered + duplicated == too_big + lost + queue_full + shed + passed + inner_again + inner_errors + pending
 *
 * **Priorities** (`prio` = 1, with a byte rate; ub_prio.h): frames the node sends with their class
 * (ub_impair_ops.send_class) wait in per-class queues of UB_PRIO_DEPTH_* frames (ub_config.h) instead of
 * taking the medium in send order. Whenever the medium is free it takes the oldest frame of the highest
 * class that has arrived by then, and carries it whole (a frame on the medium is never interrupted): a
 * command waits at most for the frame being carried. Bulk keeps a share under a telemetry flood: after
 * UB_PRIO_BULK_EVERY telemetry copies in a row while bulk waited, the oldest bulk copy goes (never ahead of
 * a command or control copy). A full telemetry queue drops its oldest frame for the
 * new one (counted `shed`, and reported to the node, which counts the drop `shed` on the link); a full
 * queue of another class pushes back (UB_ERR_AGAIN, `queue_full`). Frames sent without a class (send())
 * are telemetry. With `prio` 0 every frame takes the medium in send order, as before.
 *
 * where `passed` counts copies the inner transport accepted (ub_impair_check_balance()).
 *
 * Usage (ub_ports.h does this for every socket and serial port):
 *
 *     static ub_impair_t imp;          // large (UB_IMPAIR_DEPTH frames): not on a small stack
 *     ub_impair_init(&imp, &params, seed);
 *     ub_impair_wrap(&imp, &ub_udp_ops, &udp);
 *     ub_node_link_attach(&node, link_id, &ub_impair_ops, &imp);
 *     loop: ub_udp_service(&udp, &node, now); ub_impair_service(&imp, now);
 */
#ifndef UB_IMPAIR_H
#define UB_IMPAIR_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_error.h"
#include "ub_frame.h"
#include "ub_link.h"
#include "ub_prio.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Copies one impaired link can hold (delayed or held for reordering). */
#ifndef UB_IMPAIR_DEPTH
#define UB_IMPAIR_DEPTH 32
#endif
/** Longest a reordered frame waits for a successor, by default (ms). */
#define UB_IMPAIR_REORDER_HOLD_MS 50u
/** Probabilities are parts per million: 1000000 = always. */
#define UB_IMPAIR_PPM_MAX 1000000u

/** Impairment settings; all zero = a transparent decorator. */
typedef struct ub_impair_params {
    uint32_t loss_ppm;        /**< probability a frame is lost */
    uint32_t dup_ppm;         /**< probability a frame is sent twice */
    uint32_t reorder_ppm;     /**< probability a copy is held back behind the next frame */
    uint32_t delay_ms;        /**< fixed delay of every copy */
    uint32_t jitter_ms;       /**< plus a uniform 0..jitter_ms */
    uint32_t reorder_hold_ms; /**< 0 = UB_IMPAIR_REORDER_HOLD_MS */
    uint32_t rate_Bps;        /**< bytes per second the medium carries; 0 = no limit */
    uint32_t mtu;             /**< longest frame the medium carries, bytes; 0 = no limit */
    uint32_t prio;            /**< 1: with a byte rate, send by priority class (ub_prio.h); 0: in send order */
} ub_impair_params_t;

/** Counters (frames sent by this end). */
typedef struct ub_impair_stats {
    uint64_t offered;      /**< frames the node handed to send() */
    uint64_t lost;         /**< dropped by `loss` */
    uint64_t duplicated;   /**< extra copies made by `dup` */
    uint64_t reordered;    /**< copies held back behind the next frame */
    uint64_t delayed;      /**< copies queued with a non-zero delay */
    uint64_t queue_full;   /**< copies refused because the queue was full */
    uint64_t passed;       /**< copies the inner transport accepted */
    uint64_t inner_again;  /**< queued copies the inner transport refused with UB_ERR_AGAIN */
    uint64_t inner_errors; /**< queued copies the inner transport refused otherwise */
    uint64_t too_big;      /**< frames longer than `mtu`: not sent */
    uint64_t rate_waits;   /**< copies that waited for the medium (byte rate) */
    uint64_t bytes;        /**< bytes of the copies handed to the inner transport */
    uint64_t shed;         /**< `prio`: oldest telemetry copies dropped for newer ones (full telemetry queue) */
    uint64_t overtaken;    /**< `prio`: copies that took the medium ahead of an older copy of a lower class */
} ub_impair_stats_t;

typedef struct ub_impair_frame {
    uint64_t due_ms;
    uint64_t order;       /**< send order, ties and "after the next one" */
    uint8_t held;         /**< reordered: leaves after a later frame, or at due_ms + hold */
    uint8_t waiting;      /**< `prio`: waits for the medium in its class queue (due_ms not set yet) */
    uint8_t cls;          /**< priority class (ub_prio.h) */
    uint32_t delay_ms;    /**< `prio`: delay and jitter to add once the medium has carried it */
    uint64_t arrival_us;  /**< `prio`: when the node sent it */
    uint16_t len;
    uint8_t bytes[UB_FRAME_MAX];
} ub_impair_frame_t;

/** An impairment decorator. Caller-owned; treat the fields as private. */
typedef struct ub_impair {
    const ub_link_ops_t *inner_ops;
    void *inner;
    ub_impair_params_t params;
    uint64_t rng;
    uint64_t next_order;
    uint64_t busy_until_us; /**< the medium carries the last copy until then (byte rate) */
    size_t count;
    uint16_t waiting[UB_PRIO_CLASSES]; /**< `prio`: copies waiting per class */
    uint16_t tel_run;       /**< `prio`: telemetry copies taken in a row while bulk waited (bulk's share) */
    ub_impair_stats_t stats;
    ub_impair_frame_t queue[UB_IMPAIR_DEPTH];
} ub_impair_t;

/** The decorator vtable (kind "impair"; fileno is the inner transport's). */
extern const ub_link_ops_t ub_impair_ops;

/**
 * Initialises a decorator with no inner transport (sends fail with
 * UB_ERR_CLOSED until ub_impair_wrap()). `params` may be NULL (none); any
 * seed, 0 included, gives a valid sequence.
 */
void ub_impair_init(ub_impair_t *imp, const ub_impair_params_t *params, uint64_t seed);

/** Restarts the PRNG from `seed` (as ub_impair_init() would); settings, queue and counters stay. */
void ub_impair_reseed(ub_impair_t *imp, uint64_t seed);

/** Replaces the settings; the PRNG and the queue continue. */
void ub_impair_set_params(ub_impair_t *imp, const ub_impair_params_t *params);

/**
 * Puts (`ops`, `impl`) behind the decorator, replacing any previous inner
 * transport; queued copies leave through the new one (a rebind keeps them).
 * `ops` NULL unwraps (queued copies then wait).
 * @return UB_OK, or UB_ERR_INVAL (imp NULL, ops without send, or ops == &ub_impair_ops with impl == imp).
 */
UB_CHECK int ub_impair_wrap(ub_impair_t *imp, const ub_link_ops_t *ops, void *impl);

/**
 * Releases every copy due at `now_ms` (and held copies whose successor left)
 * to the inner transport, in due order.
 * @return the number of copies the inner transport accepted.
 */
size_t ub_impair_service(ub_impair_t *imp, uint64_t now_ms);

/** @return copies waiting in the queue. */
size_t ub_impair_pending(const ub_impair_t *imp);

/**
 * Earliest time something in the queue becomes due (for a poll timeout).
 * @return true and sets *due_ms when something is queued; false otherwise.
 */
bool ub_impair_next_due(const ub_impair_t *imp, uint64_t *due_ms);

/** @return the counters. */
const ub_impair_stats_t *ub_impair_stats(const ub_impair_t *imp);

/** @return true when the counters balance (see the file comment): nothing lost uncounted. */
bool ub_impair_check_balance(const ub_impair_t *imp);

/**
 * Parses the command-line form "loss=0.2,reorder=0.2,dup=0,delay=5,jitter=0,seed=1"
 * (any subset, any order; probabilities 0..1 as decimals with up to 6
 * fraction digits, times in whole ms; "hold=" sets reorder_hold_ms;
 * "rate=" bytes per second and "mtu=" bytes, whole numbers; "prio=" 0 or 1). Keys not
 * given are zero; `seed` (may be NULL) is left alone when not given.
 * @return UB_OK, or UB_ERR_INVAL with `err` saying which item is wrong and what is expected.
 */
UB_CHECK int ub_impair_parse(const char *text, ub_impair_params_t *params, uint64_t *seed, char *err,
                             size_t err_cap);

#ifdef __cplusplus
}
#endif
#endif /* UB_IMPAIR_H */

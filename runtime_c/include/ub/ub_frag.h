/**
 * @file ub_frag.h
 * @brief Large directories in numbered fragments: a directory larger than the payload limit
 *        (UB_MAX_PAYLOAD) or than the path MTU of the links it leaves on travels as FRAGMENT
 *        frames (admin code 21), each a complete frame (checked, signed like any frame when
 *        signing is on), reassembled at the destination and delivered whole or not at all
 *        (docs/wire-format.md, "Fragments").
 *
 * FRAGMENT payload (little-endian), then the fragment's bytes:
 *
 *     transfer u16   per originating node, +1 per fragmented directory
 *     index    u16   0 .. count-1
 *     count    u16   fragments of the transfer, 1 .. UB_FRAG_MAX_FRAGMENTS
 *     total    u16   bytes of the whole directory, 1 .. UB_MAX_DIRECTORY
 *
 * Fragment i carries bytes [i*c, min(total, (i+1)*c)) with c = ceil(total / count): every fragment
 * but the last has the same size, so each one says where it belongs. The frame's dir_id and
 * fingerprint are the directory's, its dest and src the DATA frame's.
 *
 * The destination keeps UB_FRAG_SLOTS reassemblies (fixed-size buffers in ub_frag_t, no
 * allocation), keyed by (handling entity, source, transfer), so fragments of several directories
 * may interleave. Duplicates are ignored (counted); a fragment that disagrees with its transfer
 * (count, total, content) restarts it (the old one counted incomplete). A transfer with no new
 * fragment for `timeout_ms` is dropped and counted. Slots are shared fairly (issue 29): one source
 * holds at most UB_FRAG_SLOTS_PER_SOURCE; its next transfer replaces its own idlest one
 * (`rx_source_limit`). When every slot is busy, a new transfer takes the slot idle longest only if
 * that one has had no new fragment for `protect_ms` (`rx_evicted`); otherwise the new transfer is
 * refused (`rx_refused`): a transfer in progress is never given up for a newcomer, so transfers that
 * never complete (a flood of forged first fragments from many sources) cannot push out a genuine
 * one whose fragments keep arriving. Nothing is retransmitted: a lost fragment loses the directory,
 * as LCM's do; periodic publications send it again.
 *
 * The sender packs the directory into one of UB_FRAG_TX_SLOTS buffers and sends fragments through
 * the node's ordinary send path; when a transport pushes back (UB_ERR_AGAIN: a full radio queue)
 * it stops and goes on at the next ub_node_tick(). Forwarders never fragment again: a frame
 * larger than an outgoing link's MTU is dropped `too_big`, so the MTU of a path is configured on
 * the links its originators send on.
 *
 * The node attaches this state with ub_node_set_frag(); src/core/ub_node_wire.c connects it to the
 * send path (fragmenting) and, as the core's "fragments" service (ub_service.h), to FRAGMENT frames,
 * the tick and entity removal (reassembly).
 */
#ifndef UB_FRAG_H
#define UB_FRAG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_catalogue.h"
#include "ub_config.h"
#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_FRAG_HEADER_LEN 8u
#define UB_FRAG_OFF_TRANSFER 0u
#define UB_FRAG_OFF_INDEX 2u
#define UB_FRAG_OFF_COUNT 4u
#define UB_FRAG_OFF_TOTAL 6u

/** Reassemblies one node keeps at once. */
#ifndef UB_FRAG_SLOTS
#define UB_FRAG_SLOTS 4
#endif
/** Reassemblies one source may hold at once (its next transfer replaces its own idlest). */
#ifndef UB_FRAG_SLOTS_PER_SOURCE
#define UB_FRAG_SLOTS_PER_SOURCE 2
#endif
/** Fragmented directories one node sends at once. */
#ifndef UB_FRAG_TX_SLOTS
#define UB_FRAG_TX_SLOTS 2
#endif
/** Fragments of one transfer at most. */
#ifndef UB_FRAG_MAX_FRAGMENTS
#define UB_FRAG_MAX_FRAGMENTS 512
#endif
/** Default reassembly timeout: a transfer with no new fragment for this long is dropped. */
#define UB_FRAG_TIMEOUT_MS 2000u

#if UB_FRAG_SLOTS_PER_SOURCE < 1 || UB_FRAG_SLOTS_PER_SOURCE > UB_FRAG_SLOTS
#error "UB_FRAG_SLOTS_PER_SOURCE must be 1..UB_FRAG_SLOTS"
#endif
#if UB_FRAG_SLOTS < 1 || UB_FRAG_TX_SLOTS < 1 || UB_FRAG_MAX_FRAGMENTS < 2 || UB_FRAG_MAX_FRAGMENTS > 65535
#error "UB_FRAG_SLOTS and UB_FRAG_TX_SLOTS must be >= 1, UB_FRAG_MAX_FRAGMENTS 2..65535"
#endif

/** A parsed FRAGMENT payload. */
typedef struct ub_frag_info {
    uint16_t transfer;
    uint16_t index;
    uint16_t count;
    uint16_t total;
    uint16_t offset;      /**< where its bytes go */
    uint16_t len;         /**< its bytes */
    const uint8_t *bytes; /**< into the payload */
} ub_frag_info_t;

/**
 * Checks a FRAGMENT payload (count, total and this fragment's size agree) and points into it.
 * @return UB_OK, or UB_ERR_INVAL.
 */
UB_CHECK int ub_frag_parse(const uint8_t *payload, size_t len, ub_frag_info_t *out);

/**
 * Plans the fragments of a `total`-byte directory when a fragment may carry at most `max_bytes`
 * of it: `*count` = ceil(total / max_bytes), each fragment but the last ceil(total / count) bytes.
 * @return UB_OK; UB_ERR_RANGE (total 0 or above UB_MAX_DIRECTORY, max_bytes 0, or more than
 *         UB_FRAG_MAX_FRAGMENTS fragments).
 */
UB_CHECK int ub_frag_plan(size_t total, size_t max_bytes, uint16_t *count);

/**
 * Writes the payload of fragment `index` of `count` of the directory `data` (`total` bytes).
 * @return the payload length, or UB_ERR_INVAL / UB_ERR_NOSPACE.
 */
UB_CHECK int ub_frag_write(uint8_t *out, size_t cap, uint16_t transfer, uint16_t index, uint16_t count,
                           const uint8_t *data, size_t total);

typedef struct ub_frag_params {
    uint32_t timeout_ms; /**< 0 = UB_FRAG_TIMEOUT_MS */
    uint32_t protect_ms; /**< a transfer with a new fragment this recently is not evicted for another source's; 0 = timeout_ms / 4 */
} ub_frag_params_t;

typedef struct ub_frag_stats {
    uint64_t tx_transfers;   /**< directories sent in fragments */
    uint64_t tx_fragments;   /**< fragments handed to the send path */
    uint64_t tx_busy;        /**< sends refused: every transmit slot busy (UB_ERR_AGAIN) */
    uint64_t tx_paused;      /**< times a transfer stopped for a transport's push back and went on later */
    uint64_t tx_abandoned;   /**< transfers given up (no route, send error) */
    uint64_t rx_started;     /**< reassemblies begun (each ends complete, timed out, evicted, restarted or source-limited, or is pending) */
    uint64_t rx_fragments;   /**< fragments taken into a reassembly */
    uint64_t rx_duplicates;  /**< fragments already held */
    uint64_t rx_complete;    /**< directories reassembled and handed on */
    uint64_t rx_timeouts;    /**< transfers dropped after timeout_ms without a new fragment */
    uint64_t rx_evicted;     /**< transfers dropped to make room (every slot busy, this one idle for protect_ms) */
    uint64_t rx_refused;     /**< fragments of new transfers refused: every slot busy with a transfer in progress */
    uint64_t rx_source_limit; /**< transfers dropped for a newer one of their source (UB_FRAG_SLOTS_PER_SOURCE) */
    uint64_t rx_restarted;   /**< transfers dropped because a fragment disagreed with them */
    uint64_t rx_bad;         /**< fragments refused (malformed) */
} ub_frag_stats_t;

/** One reassembly. */
typedef struct ub_frag_rx {
    uint8_t in_use;
    int8_t slot;                   /**< handling local entity */
    uint8_t src[UB_ENTITY_ID_LEN];
    uint8_t dir_id[UB_DIR_ID_LEN];
    uint32_t fingerprint;
    uint16_t transfer;
    uint16_t count;
    uint16_t total;
    uint16_t received;
    uint64_t last_ms;
    uint8_t have[(UB_FRAG_MAX_FRAGMENTS + 7) / 8];
    uint8_t data[UB_MAX_DIRECTORY];
} ub_frag_rx_t;

/** One directory being sent. */
typedef struct ub_frag_tx {
    uint8_t in_use;
    int8_t slot;                   /**< originating local entity */
    uint8_t dest[UB_ENTITY_ID_LEN];
    uint32_t instance;
    uint16_t transfer;
    uint16_t count;
    uint16_t next;                 /**< next fragment to send */
    uint16_t total;
    uint64_t progress_ms;          /**< last fragment the send path took; a transfer stuck for the timeout is given up */
    uint8_t data[UB_MAX_DIRECTORY];
} ub_frag_tx_t;

/** Fragment state of one node. Caller-owned and large (UB_MAX_DIRECTORY per slot): static storage. */
typedef struct ub_frag {
    ub_frag_params_t params;
    uint16_t next_transfer;
    ub_frag_stats_t stats;
    ub_frag_rx_t rx[UB_FRAG_SLOTS];
    ub_frag_tx_t tx[UB_FRAG_TX_SLOTS];
} ub_frag_t;

/** Empties `f`; `params` may be NULL (defaults). `first_transfer` seeds the transfer numbers (a restart should not reuse recent ones). */
void ub_frag_init(ub_frag_t *f, const ub_frag_params_t *params, uint16_t first_transfer);

/** What ub_frag_take() made of a fragment. */
typedef enum ub_frag_result {
    UB_FRAG_PENDING = 0,  /**< taken; the directory is not whole yet */
    UB_FRAG_COMPLETE = 1, /**< the directory is whole: `*data`, `*len` (valid until the next call) */
    UB_FRAG_DUPLICATE = 2, /**< already held: ignored */
    UB_FRAG_REFUSED = 3    /**< a fragment of a transfer not held, refused: every slot busy (rx_refused) */
} ub_frag_result_t;

/**
 * Takes one fragment (already verified, authenticated and past the duplicate window) for local
 * entity `slot` from `src`, of content `dir_id`/`fingerprint`.
 * @return a ub_frag_result_t, or UB_ERR_INVAL (malformed payload: counted rx_bad).
 */
UB_CHECK int ub_frag_take(ub_frag_t *f, int slot, const uint8_t src[UB_ENTITY_ID_LEN],
                          const uint8_t dir_id[UB_DIR_ID_LEN], uint32_t fingerprint, const uint8_t *payload,
                          size_t len, uint64_t now_ms, const uint8_t **data, size_t *total);

/** Drops reassemblies idle for the timeout. @return how many (counted rx_timeouts). */
size_t ub_frag_expire(ub_frag_t *f, uint64_t now_ms);

/** Forgets every reassembly and transfer involving local entity `slot` or, with `slot` < 0, source/destination `id`. */
void ub_frag_forget(ub_frag_t *f, int slot, const uint8_t id[UB_ENTITY_ID_LEN]);

/** @return reassemblies under way. */
size_t ub_frag_pending(const ub_frag_t *f);

#ifdef __cplusplus
}
#endif
#endif /* UB_FRAG_H */

/* cffi cdef for runtime_c/include/ub/ub_compact.h: the compact encoding of a frame (docs/wire-format.md).
 * The functions that take frame headers, decoders or rx reasons are declared in ub_node.h's cdef (the cdefs
 * load in name order; ub_frame.h comes after this one). */

#define UB_COMPACT_PACKET_MAX ...
#define UB_COMPACT_WIRE_MAX ...
#define UB_COMPACT_DICT_MAX ...
#define UB_COMPACT_PAGE ...
#define UB_COMPACT_HELLO_FIXED ...

typedef struct ub_compact_codec {
    const ub_catalogue_t *cat;
    uint64_t cat_hash;
    uint8_t content_ok;
    uint8_t entities_ok;
    uint8_t n_ids;
    const uint8_t (*ids)[12];
    uint64_t list_hash;
    ...;
} ub_compact_codec_t;

typedef struct ub_compact_ref {
    uint8_t src[...];
    uint8_t in_use;
    uint32_t seq;
    ...;
} ub_compact_ref_t;

typedef struct ub_compact_refs {
    ub_compact_ref_t ref[...];
    ...;
} ub_compact_refs_t;

typedef struct ub_compact_stats {
    uint64_t tx_frames;
    uint64_t tx_bytes;
    uint64_t tx_full_bytes;
    uint64_t tx_full_ids;
    uint64_t tx_seq32;
    uint64_t rx_frames;
    uint64_t rx_bytes;
    uint64_t garbage_bytes;
    uint64_t rejected[...];
    uint64_t hello_tx;
    uint64_t hello_rx;
    uint64_t hello_bad;
    uint64_t peer_restarts;
    uint64_t peer_lists;
    uint64_t dict_changes;
    uint64_t dict_limited;
    ...;
} ub_compact_stats_t;

typedef struct ub_compact_params {
    uint32_t hello_ms;
    uint32_t retry_ms;
    uint32_t change_min_ms;
    ...;
} ub_compact_params_t;

typedef struct ub_compact {
    ub_compact_stats_t stats;
    ...;
} ub_compact_t;

uint64_t ub_compact_catalogue_hash(const ub_catalogue_t *cat);
uint64_t ub_compact_list_hash(const uint8_t (*ids)[12], size_t n);
size_t ub_cobs_encode(const uint8_t *in, size_t n, uint8_t *out, size_t cap);
int ub_cobs_decode(const uint8_t *in, size_t n, uint8_t *out, size_t cap);
int ub_compact_encode(const ub_compact_codec_t *c, const uint8_t *frame, size_t len, bool seq32, uint8_t *pkt,
                      size_t cap);
bool ub_compact_agreed(const ub_compact_t *s);

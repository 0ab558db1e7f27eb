/* cffi cdef for runtime_c/include/ub/ub_frame.h. Struct layouts end in `...;` and arrays are sized
 * `[...]`, so the C compiler, not this file, supplies sizes and offsets. */

#define UB_WIRE_VERSION ...
#define UB_MSG_TYPE_PUBSUB ...
#define UB_FRAME_HEADER_LEN ...
#define UB_FRAME_MAX ...
#define UB_FRAME_FLAG_SIGNED ...
#define UB_FRAME_FLAG_ENCRYPTED ...
#define UB_FRAME_SIG_TRAILER_LEN ...
#define UB_FRAME_AEAD_TRAILER_LEN ...
#define UB_FRAME_TRAILER_MAX ...
#define UB_FRAME_FLAG_ORIGIN ...
#define UB_FRAME_ORIGIN_LEN ...
#define UB_FRAME_ORIGIN_TAG_LEN ...

typedef enum ub_admin_code {
    UB_ADMIN_DATA, UB_ADMIN_PUB_REQUEST, UB_ADMIN_SUB_REQUEST, UB_ADMIN_PUB_STOP,
    UB_ADMIN_SUB_STOP, UB_ADMIN_ACK, UB_ADMIN_NACK, UB_ADMIN_CHALLENGE, UB_ADMIN_CHALLENGE_REPLY,
    UB_ADMIN_HELLO, UB_ADMIN_ROUTE_UPDATE, UB_ADMIN_MEMBERSHIP, UB_ADMIN_INSPECT, UB_ADMIN_INSPECT_VALUE,
    UB_ADMIN_LINK_HELLO, UB_ADMIN_FRAGMENT, ...
} ub_admin_code_t;

typedef struct ub_frame_header {
    uint16_t msg_type;
    uint8_t flags;
    uint8_t dir_id[...];
    uint8_t dest_id[...];
    uint8_t src_id[...];
    uint8_t admin;
    uint8_t hop_limit;
    uint16_t payload_size;
    uint32_t seq;
    uint32_t fingerprint;
    uint8_t key_id;
    uint16_t counter_hi;
    uint8_t origin_hop0;
    uint8_t origin_tag[...];
    ...;
} ub_frame_header_t;

int ub_frame_finish(uint8_t *frame, size_t cap, const ub_frame_header_t *h);
int ub_frame_parse(const uint8_t *frame, size_t len, ub_frame_header_t *h);

typedef enum ub_rx_reason {
    UB_RX_BAD_HDR_CHECK, UB_RX_BAD_CRC, UB_RX_BAD_LENGTH, UB_RX_BAD_VERSION, UB_RX_BAD_SYNC,
    UB_RX_NO_DICTIONARY, UB_RX_NO_REFERENCE,
    UB_RX_REASON_COUNT, ...
} ub_rx_reason_t;

const char *ub_rx_reason_name(ub_rx_reason_t reason);
int ub_frame_parse_reason(const uint8_t *frame, size_t len, ub_frame_header_t *h, ub_rx_reason_t *reason);
int ub_frame_set_hop_limit(uint8_t *frame, size_t len, uint8_t hop_limit);

typedef struct ub_decoder_stats {
    uint64_t frames_ok;
    uint64_t bytes_in;
    uint64_t bytes_ok;
    uint64_t garbage_bytes;
    uint64_t foreign_bytes;
    uint64_t foreign_refused;
    uint64_t rejected[...];
    ...;
} ub_decoder_stats_t;

typedef void (*ub_frame_cb)(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t frame_len);

/* Private fields stay hidden: Python reads only `stats`. */
typedef struct ub_decoder {
    ub_decoder_stats_t stats;
    ...;
} ub_decoder_t;

void ub_decoder_init(ub_decoder_t *d);
size_t ub_decoder_feed(ub_decoder_t *d, const uint8_t *data, size_t len, ub_frame_cb cb, void *user);
size_t ub_decoder_pending(const ub_decoder_t *d);

uint32_t ub_crc32c(const uint8_t *data, size_t len);
uint32_t ub_crc32c_update(uint32_t crc, const uint8_t *data, size_t len);

/* Not in the C header: the Python-side ub_frame_cb that the decoder wrapper passes to C
 * (cffi's `extern "Python"`, defined with @ffi.def_extern() in uavbus._bindings.ub_frame). */
extern "Python" void ub_py_frame_sink(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t frame_len);

/* The foreign-traffic handler (issue #24): runs of bytes that are not uavbus frames. */
typedef size_t (*ub_foreign_cb)(void *user, const uint8_t *run, size_t len);
void ub_decoder_set_foreign(ub_decoder_t *d, ub_foreign_cb cb, void *user);
/* Not in the C header: the Python-side handler (defined in uavbus._bindings.ub_ports). */
extern "Python" size_t ub_py_foreign(void *user, const uint8_t *run, size_t len);

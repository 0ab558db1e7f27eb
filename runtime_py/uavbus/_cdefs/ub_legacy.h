/* cffi cdef for runtime_c/include/ub/ub_legacy.h (the legacy datalink envelope; the vectors' Python side). */

#define UB_LEGACY_HEADER_LEN ...

typedef struct ub_legacy_stats {
    uint64_t bytes_in;
    uint64_t messages;
    uint64_t message_bytes;
    uint64_t noise_bytes;
    uint64_t bad_header;
    uint64_t bad_checksum;
    uint64_t too_long;
} ub_legacy_stats_t;

typedef struct ub_legacy { ub_legacy_stats_t stats; ...; } ub_legacy_t;

typedef void (*ub_legacy_cb)(void *user, uint16_t type, const uint8_t *msg, size_t msg_len, const uint8_t *payload,
                             size_t payload_len);

void ub_legacy_init(ub_legacy_t *p);
size_t ub_legacy_pending(const ub_legacy_t *p);
int ub_legacy_feed(ub_legacy_t *p, const uint8_t *data, size_t len, ub_legacy_cb cb, void *user);
int ub_legacy_build(uint16_t type, const uint8_t *payload, size_t len, uint8_t *out, size_t cap);

/* cdefs for ub_ubx.h (u-blox UBX messages from a link's foreign runs, #24). Python reads `pvt`, `ack`,
 * `stats`; the rest of the parser is the C compiler's. */
#define UB_UBX_CLASS_NAV ...
#define UB_UBX_ID_NAV_PVT ...
#define UB_UBX_CLASS_ACK ...
#define UB_UBX_CLASS_CFG ...
#define UB_UBX_ID_CFG_RATE ...
#define UB_UBX_CFG_RATE_LEN ...
#define UB_UBX_PAYLOAD_MAX ...

typedef struct ub_ubx_pvt {
    uint32_t itow_ms;
    uint16_t year;
    uint8_t month, day, hour, min, sec, valid;
    uint8_t fix_type;
    uint8_t flags;
    uint8_t num_sv;
    int32_t lon_1e7, lat_1e7;
    int32_t height_mm;
    int32_t hmsl_mm;
    uint32_t h_acc_mm, v_acc_mm;
    int32_t vel_n_mms, vel_e_mms, vel_d_mms;
    int32_t g_speed_mms;
    int32_t head_mot_1e5;
    uint16_t p_dop_1e2;
} ub_ubx_pvt_t;

typedef struct ub_ubx_ack {
    uint8_t cls, id;
    uint8_t ok;
} ub_ubx_ack_t;

typedef struct ub_ubx_stats {
    uint64_t bytes_in;
    uint64_t noise_bytes;
    uint64_t bytes_in_messages;
    uint64_t nav_pvt;
    uint64_t bad_checksum;
    uint64_t bad_length;
    uint64_t ack;
    uint64_t nak;
    uint64_t too_long;
    uint64_t unsupported;
} ub_ubx_stats_t;

typedef struct ub_ubx {
    uint8_t cls, id;
    ub_ubx_pvt_t pvt;
    ub_ubx_ack_t ack;
    ub_ubx_stats_t stats;
    ...;
} ub_ubx_t;

typedef void (*ub_ubx_cb)(void *user, const ub_ubx_t *ubx);

void ub_ubx_init(ub_ubx_t *ubx);
int ub_ubx_feed(ub_ubx_t *ubx, const uint8_t *data, size_t len, ub_ubx_cb cb, void *user);
int ub_ubx_build(uint8_t cls, uint8_t id, const uint8_t *payload, uint16_t len, uint8_t *out, size_t cap);

/* ub_gps_fields.h's functions (ub_dir_value_t is in that file's cdefs). */
size_t ub_nmea_dir_values(const ub_nmea_t *n, ub_dir_value_t *out, size_t cap);
size_t ub_ubx_dir_values(const ub_ubx_t *u, ub_dir_value_t *out, size_t cap);

/* The CFG-RATE exchange (ub_ubx_cfg_t), shared by the C and Python adapters. */
#define UB_UBX_ACK_TIMEOUT_MS ...
typedef struct ub_ubx_rate {
    uint16_t meas_rate_ms;
    uint16_t nav_rate;
    uint16_t time_ref;
} ub_ubx_rate_t;
typedef struct ub_ubx_cfg {
    uint8_t pending;
    uint32_t sent_count, acked, naked, timeouts;
    uint16_t acked_meas_rate_ms;
    ...;
} ub_ubx_cfg_t;
void ub_ubx_cfg_init(ub_ubx_cfg_t *cfg);
int ub_ubx_cfg_poll(ub_ubx_cfg_t *cfg, const ub_ubx_rate_t *want, uint64_t now_ms, uint8_t *out, size_t cap);
void ub_ubx_cfg_sent(ub_ubx_cfg_t *cfg, const ub_ubx_rate_t *want, uint64_t now_ms);
int ub_ubx_cfg_answer(ub_ubx_cfg_t *cfg, const ub_ubx_ack_t *ack);
size_t ub_ubx_cfg_dir_values(const ub_ubx_cfg_t *c, ub_dir_value_t *out, size_t cap);

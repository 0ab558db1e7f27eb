/* cdefs for ub_nmea.h (NMEA 0183 sentences from a link's foreign runs, #24). The parser's private fields
 * are the C compiler's; Python reads `fix` and `stats`. */
#define UB_NMEA_LINE_MAX ...

typedef enum ub_nmea_kind { UB_NMEA_GGA = 0, UB_NMEA_RMC, UB_NMEA_VTG, UB_NMEA_GSA, UB_NMEA_KIND_COUNT } ub_nmea_kind_t;

typedef struct ub_nmea_fix {
    double lat_deg;
    double lon_deg;
    double alt_msl_m;
    double geoid_sep_m;
    double speed_mps;
    double course_deg;
    double hdop, pdop, vdop;
    uint32_t utc_ms;
    uint32_t date_ddmmyy;
    uint8_t quality;
    uint8_t satellites;
    uint8_t fix_type;
    uint8_t valid;
} ub_nmea_fix_t;

typedef struct ub_nmea_stats {
    uint64_t bytes_in;
    uint64_t noise_bytes;
    uint64_t bytes_in_sentences;
    uint64_t sentences_ok;
    uint64_t by_kind[4];
    uint64_t bad_checksum;
    uint64_t no_checksum;
    uint64_t malformed;
    uint64_t overlong;
    uint64_t unsupported;
} ub_nmea_stats_t;

typedef struct ub_nmea {
    ub_nmea_fix_t fix;
    ub_nmea_stats_t stats;
    ...;
} ub_nmea_t;

typedef void (*ub_nmea_cb)(void *user, ub_nmea_kind_t kind, const ub_nmea_t *nmea);

void ub_nmea_init(ub_nmea_t *nmea);
int ub_nmea_feed(ub_nmea_t *nmea, const uint8_t *data, size_t len, ub_nmea_cb cb, void *user);
const char *ub_nmea_kind_name(ub_nmea_kind_t kind);

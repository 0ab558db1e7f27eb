/* cdefs for ub_gps_fields.h: the GPS adapters' mapping into their directories, as (member, value) pairs.
 * The two functions take ub_nmea_t / ub_ubx_t, declared in later files (sorted): they are in ub_ubx.h's. */
#define UB_DIR_VALUES_MAX ...

typedef struct ub_dir_value {
    const char *member;
    double value;
    uint8_t counter;
} ub_dir_value_t;

/* The GPS adapters' field mapping as data (ub_gps_fields.h): what Python's adapters write by name. */
#include "ub/ub_gps_fields.h"

#define UB_DIR_FIX(member, ctype, expr) {#member, (double)(ctype)(expr), 0},
#define UB_DIR_COUNT(member, ctype, expr) {#member, (double)(ctype)(expr), 1},

static size_t put_values(const ub_dir_value_t *all, size_t n, ub_dir_value_t *out, size_t cap) {
    for (size_t i = 0; i < n && i < cap && out != NULL; i++) out[i] = all[i];
    return n;
}

size_t ub_nmea_dir_values(const ub_nmea_t *n, ub_dir_value_t *out, size_t cap) {
    if (n == NULL) return 0;
    const ub_dir_value_t all[] = {UB_NMEA_DIR_FIX(UB_DIR_FIX) UB_NMEA_DIR_COUNTS(UB_DIR_COUNT)};
    return put_values(all, sizeof all / sizeof all[0], out, cap);
}

size_t ub_ubx_dir_values(const ub_ubx_t *u, ub_dir_value_t *out, size_t cap) {
    if (u == NULL) return 0;
    const ub_dir_value_t all[] = {UB_UBX_DIR_FIX(UB_DIR_FIX) UB_UBX_DIR_COUNTS(UB_DIR_COUNT)};
    return put_values(all, sizeof all / sizeof all[0], out, cap);
}

size_t ub_ubx_cfg_dir_values(const ub_ubx_cfg_t *c, ub_dir_value_t *out, size_t cap) {
    if (c == NULL) return 0;
    const ub_dir_value_t all[] = {UB_UBX_DIR_CFG(UB_DIR_COUNT)};
    return put_values(all, sizeof all / sizeof all[0], out, cap);
}

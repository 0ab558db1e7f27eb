/* NMEA 0183 sentences (contracts in ub/ub_nmea.h). Numbers are parsed by hand rather than with strtod():
 * strtod follows the process locale, and a program that sets a locale with a decimal comma would read
 * "4807.038" as 4807. */
#include "ub/ub_nmea.h"

#include <stdbool.h>
#include <string.h>

#define FIELDS_MAX 24

enum { OUTSIDE = 0, INSIDE = 1, SKIPPING = 2 };

void ub_nmea_init(ub_nmea_t *nmea) {
    if (nmea == NULL) return;
    memset(nmea, 0, sizeof *nmea);
}

const char *ub_nmea_kind_name(ub_nmea_kind_t kind) {
    switch (kind) {
    case UB_NMEA_GGA: return "GGA";
    case UB_NMEA_RMC: return "RMC";
    case UB_NMEA_VTG: return "VTG";
    case UB_NMEA_GSA: return "GSA";
    case UB_NMEA_KIND_COUNT: break;
    }
    return "?";
}

typedef struct field {
    const char *p;
    size_t n;
} field_t;

static int hex_digit(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
}

/* [-]digits[.digits]; false for anything else (an empty field is the caller's to skip). */
static bool parse_decimal(field_t f, double *out) {
    size_t i = 0;
    bool neg = false;
    if (i < f.n && (f.p[i] == '-' || f.p[i] == '+')) neg = f.p[i++] == '-';
    double v = 0.0, scale = 1.0;
    bool digits = false, point = false;
    for (; i < f.n; i++) {
        char c = f.p[i];
        if (c == '.' && !point) {
            point = true;
        } else if (c >= '0' && c <= '9') {
            digits = true;
            if (point) {
                scale /= 10.0;
                v += (c - '0') * scale;
            } else {
                v = v * 10.0 + (c - '0');
            }
        } else {
            return false;
        }
    }
    if (!digits) return false;
    *out = neg ? -v : v;
    return true;
}

static bool parse_uint(field_t f, uint32_t max, uint32_t *out) {
    if (f.n == 0 || f.n > 9) return false;
    uint32_t v = 0;
    for (size_t i = 0; i < f.n; i++) {
        if (f.p[i] < '0' || f.p[i] > '9') return false;
        v = v * 10u + (uint32_t)(f.p[i] - '0');
    }
    if (v > max) return false;
    *out = v;
    return true;
}

/* ddmm.mmmm (lat) or dddmm.mmmm (lon) with its hemisphere letter into signed degrees. */
static bool parse_angle(field_t value, field_t hemi, char pos, char neg, double max_deg, double *out) {
    double v;
    if (!parse_decimal(value, &v) || v < 0.0 || hemi.n != 1 || (hemi.p[0] != pos && hemi.p[0] != neg)) return false;
    double deg = (double)(long)(v / 100.0);
    double min = v - deg * 100.0;
    if (min >= 60.0) return false;
    double d = deg + min / 60.0;
    if (d > max_deg) return false;
    *out = hemi.p[0] == neg ? -d : d;
    return true;
}

/* hhmmss[.sss] into ms of the day. */
static bool parse_time(field_t f, uint32_t *ms) {
    double v;
    if (f.n < 6 || !parse_decimal(f, &v) || v < 0.0) return false;
    uint32_t whole = (uint32_t)v;
    uint32_t hh = whole / 10000u, mm = whole / 100u % 100u, ss = whole % 100u;
    if (hh > 23 || mm > 59 || ss > 60) return false;
    *ms = ((hh * 60u + mm) * 60u + ss) * 1000u + (uint32_t)((v - whole) * 1000.0 + 0.5);
    return true;
}

/* Each parser checks every non-empty field it reads before it writes anything into the fix, so a
 * malformed sentence changes nothing. */
static bool merge_gga(ub_nmea_fix_t *fix, const field_t *f, size_t n) {
    if (n < 15) return false;
    ub_nmea_fix_t t = *fix;
    uint32_t u;
    if (f[1].n && !parse_time(f[1], &t.utc_ms)) return false;
    if ((f[2].n || f[3].n) && !parse_angle(f[2], f[3], 'N', 'S', 90.0, &t.lat_deg)) return false;
    if ((f[4].n || f[5].n) && !parse_angle(f[4], f[5], 'E', 'W', 180.0, &t.lon_deg)) return false;
    if (f[6].n) {
        if (!parse_uint(f[6], 9, &u)) return false;
        t.quality = (uint8_t)u;
    }
    if (f[7].n) {
        if (!parse_uint(f[7], 99, &u)) return false;
        t.satellites = (uint8_t)u;
    }
    if (f[8].n && !parse_decimal(f[8], &t.hdop)) return false;
    if (f[9].n && !parse_decimal(f[9], &t.alt_msl_m)) return false;
    if (f[11].n && !parse_decimal(f[11], &t.geoid_sep_m)) return false;
    *fix = t;
    return true;
}

static bool merge_rmc(ub_nmea_fix_t *fix, const field_t *f, size_t n) {
    if (n < 10) return false;
    ub_nmea_fix_t t = *fix;
    uint32_t u;
    double knots;
    if (f[1].n && !parse_time(f[1], &t.utc_ms)) return false;
    if (f[2].n) {
        if (f[2].n != 1 || (f[2].p[0] != 'A' && f[2].p[0] != 'V')) return false;
        t.valid = f[2].p[0] == 'A';
    }
    if ((f[3].n || f[4].n) && !parse_angle(f[3], f[4], 'N', 'S', 90.0, &t.lat_deg)) return false;
    if ((f[5].n || f[6].n) && !parse_angle(f[5], f[6], 'E', 'W', 180.0, &t.lon_deg)) return false;
    if (f[7].n) {
        if (!parse_decimal(f[7], &knots)) return false;
        t.speed_mps = knots * 1852.0 / 3600.0;
    }
    if (f[8].n && !parse_decimal(f[8], &t.course_deg)) return false;
    if (f[9].n) {
        if (f[9].n != 6 || !parse_uint(f[9], 311299, &u)) return false;
        t.date_ddmmyy = u;
    }
    *fix = t;
    return true;
}

static bool merge_vtg(ub_nmea_fix_t *fix, const field_t *f, size_t n) {
    if (n < 9) return false;
    ub_nmea_fix_t t = *fix;
    double knots;
    if (f[1].n && !parse_decimal(f[1], &t.course_deg)) return false;
    if (f[5].n) {
        if (!parse_decimal(f[5], &knots)) return false;
        t.speed_mps = knots * 1852.0 / 3600.0;
    }
    *fix = t;
    return true;
}

static bool merge_gsa(ub_nmea_fix_t *fix, const field_t *f, size_t n) {
    if (n < 18) return false;
    ub_nmea_fix_t t = *fix;
    uint32_t u;
    if (f[2].n) {
        if (!parse_uint(f[2], 3, &u) || u == 0) return false;
        t.fix_type = (uint8_t)u;
    }
    if (f[15].n && !parse_decimal(f[15], &t.pdop)) return false;
    if (f[16].n && !parse_decimal(f[16], &t.hdop)) return false;
    if (f[17].n && !parse_decimal(f[17], &t.vdop)) return false;
    *fix = t;
    return true;
}

/* A whole sentence line[0, len): '$' ... '*' H H. Returns 1 when a good GGA/RMC/VTG/GSA was merged. */
static int finish_sentence(ub_nmea_t *nmea, ub_nmea_cb cb, void *user) {
    const char *s = nmea->line;
    size_t len = nmea->len;
    nmea->stats.bytes_in_sentences += len;
    nmea->len = 0;
    nmea->state = OUTSIDE;
    if (len < 4 || s[len - 3] != '*') {
        nmea->stats.no_checksum++;
        return 0;
    }
    int hi = hex_digit(s[len - 2]), lo = hex_digit(s[len - 1]);
    uint8_t sum = 0;
    for (size_t i = 1; i < len - 3; i++) sum ^= (uint8_t)s[i];
    if (hi < 0 || lo < 0 || sum != (uint8_t)(hi << 4 | lo)) {
        nmea->stats.bad_checksum++;
        return 0;
    }
    field_t f[FIELDS_MAX];
    size_t n = 0, start = 1, body_end = len - 3;
    for (size_t i = 1; i <= body_end; i++) {
        if (i == body_end || s[i] == ',') {
            if (n == FIELDS_MAX) {
                nmea->stats.malformed++;
                return 0;
            }
            f[n++] = (field_t){s + start, i - start};
            start = i + 1;
        }
    }
    if (f[0].n != 5) { /* talker (2) + type (3) */
        nmea->stats.malformed++;
        return 0;
    }
    const char *type = f[0].p + 2;
    ub_nmea_kind_t kind;
    bool ok;
    if (memcmp(type, "GGA", 3) == 0) {
        kind = UB_NMEA_GGA;
        ok = merge_gga(&nmea->fix, f, n);
    } else if (memcmp(type, "RMC", 3) == 0) {
        kind = UB_NMEA_RMC;
        ok = merge_rmc(&nmea->fix, f, n);
    } else if (memcmp(type, "VTG", 3) == 0) {
        kind = UB_NMEA_VTG;
        ok = merge_vtg(&nmea->fix, f, n);
    } else if (memcmp(type, "GSA", 3) == 0) {
        kind = UB_NMEA_GSA;
        ok = merge_gsa(&nmea->fix, f, n);
    } else {
        nmea->stats.unsupported++;
        return 0;
    }
    if (!ok) {
        nmea->stats.malformed++;
        return 0;
    }
    nmea->stats.sentences_ok++;
    nmea->stats.by_kind[kind]++;
    if (cb != NULL) cb(user, kind, nmea);
    return 1;
}

int ub_nmea_feed(ub_nmea_t *nmea, const uint8_t *data, size_t len, ub_nmea_cb cb, void *user) {
    if (nmea == NULL || (data == NULL && len != 0)) return UB_ERR_INVAL;
    nmea->stats.bytes_in += len;
    int merged = 0;
    for (size_t i = 0; i < len; i++) {
        char c = (char)data[i];
        if (c == '$') { /* a new sentence; one still open was cut short */
            if (nmea->state == INSIDE) merged += finish_sentence(nmea, cb, user);
            nmea->state = INSIDE;
            nmea->len = 0;
        }
        switch (nmea->state) {
        case OUTSIDE:
            nmea->stats.noise_bytes++;
            break;
        case SKIPPING:
            if (c == '\r' || c == '\n') {
                nmea->state = OUTSIDE;
                nmea->stats.noise_bytes++;
            } else {
                nmea->stats.bytes_in_sentences++;
            }
            break;
        default:
            if (c == '\r' || c == '\n') {
                merged += finish_sentence(nmea, cb, user);
                nmea->stats.noise_bytes++; /* the line end itself */
            } else if (nmea->len == sizeof nmea->line) {
                nmea->stats.overlong++;
                nmea->stats.bytes_in_sentences += nmea->len + 1;
                nmea->len = 0;
                nmea->state = SKIPPING;
            } else {
                nmea->line[nmea->len++] = c;
            }
        }
    }
    return merged;
}

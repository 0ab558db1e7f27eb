/* NMEA 0183 parser (ub_nmea.h): the four sentences the GPS adapter merges, with the textbook examples
 * (checksums as published), fed whole and byte by byte; corrupted, cut, overlong and unknown sentences are
 * counted and change nothing; the byte accounting holds. The test against an independent encoder
 * (pynmea2) is tests/system/test_nmea_gps.py. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <string.h>

#include "ub/ub_nmea.h"

static const char k_gga[] = "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n";
static const char k_rmc[] = "$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A\r\n";
static const char k_vtg[] = "$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48\r\n";
static const char k_gsa[] = "$GPGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3,2.1*39\r\n";
static const char k_gsv[] = "$GPGSV,1,1,01,01,40,083,46*44\r\n";

typedef struct seen {
    unsigned calls[UB_NMEA_KIND_COUNT];
} seen_t;

static void on_sentence(void *user, ub_nmea_kind_t kind, const ub_nmea_t *nmea) {
    (void)nmea;
    ((seen_t *)user)->calls[kind]++;
}

static void feed_text(ub_nmea_t *n, const char *text, int bytewise, seen_t *seen) {
    size_t len = strlen(text);
    if (!bytewise) {
        assert_true(ub_nmea_feed(n, (const uint8_t *)text, len, on_sentence, seen) >= 0);
        return;
    }
    for (size_t i = 0; i < len; i++) assert_true(ub_nmea_feed(n, (const uint8_t *)text + i, 1, on_sentence, seen) >= 0);
}

static void check_accounting(const ub_nmea_t *n) {
    assert_int_equal(n->stats.bytes_in, n->stats.noise_bytes + n->stats.bytes_in_sentences + (n->state == 1 ? n->len : 0));
}

static void test_four_sentences_merge_into_one_fix(void **state) {
    (void)state;
    for (int bytewise = 0; bytewise < 2; bytewise++) {
        ub_nmea_t n;
        ub_nmea_init(&n);
        seen_t seen = {{0}};
        feed_text(&n, k_gga, bytewise, &seen);
        feed_text(&n, k_rmc, bytewise, &seen);
        feed_text(&n, k_vtg, bytewise, &seen);
        feed_text(&n, k_gsa, bytewise, &seen);
        for (int k = 0; k < UB_NMEA_KIND_COUNT; k++) assert_int_equal(seen.calls[k], 1);
        assert_int_equal(n.stats.sentences_ok, 4);
        const ub_nmea_fix_t *f = &n.fix;
        assert_float_equal(f->lat_deg, 48.0 + 7.038 / 60.0, 1e-9);
        assert_float_equal(f->lon_deg, 11.0 + 31.0 / 60.0, 1e-9);
        assert_float_equal(f->alt_msl_m, 545.4, 1e-9);
        assert_float_equal(f->geoid_sep_m, 46.9, 1e-9);
        assert_int_equal(f->quality, 1);
        assert_int_equal(f->satellites, 8);
        assert_int_equal(f->utc_ms, (12u * 3600u + 35u * 60u + 19u) * 1000u);
        assert_int_equal(f->date_ddmmyy, 230394);
        assert_int_equal(f->valid, 1);
        assert_float_equal(f->course_deg, 54.7, 1e-9); /* VTG came after RMC's 84.4 */
        assert_float_equal(f->speed_mps, 5.5 * 1852.0 / 3600.0, 1e-9);
        assert_int_equal(f->fix_type, 3);
        assert_float_equal(f->pdop, 2.5, 1e-9);
        assert_float_equal(f->hdop, 1.3, 1e-9); /* GSA after GGA's 0.9 */
        assert_float_equal(f->vdop, 2.1, 1e-9);
        assert_int_equal(n.stats.noise_bytes, 8); /* four CR LF */
        check_accounting(&n);
    }
}

static void test_bad_sentences_are_counted_not_merged(void **state) {
    (void)state;
    ub_nmea_t n;
    ub_nmea_init(&n);
    seen_t seen = {{0}};
    char bad[sizeof k_gga];
    memcpy(bad, k_gga, sizeof k_gga);
    bad[20] = '9'; /* latitude digit changed in transit: checksum no longer matches */
    feed_text(&n, bad, 0, &seen);
    assert_int_equal(n.stats.bad_checksum, 1);
    feed_text(&n, "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\r\n", 0, &seen);
    assert_int_equal(n.stats.no_checksum, 1);
    feed_text(&n, "$GPGGA,1235", 0, &seen); /* cut short by the next sentence */
    feed_text(&n, k_gsv, 0, &seen);
    assert_int_equal(n.stats.no_checksum, 2);
    assert_int_equal(n.stats.unsupported, 1);
    /* Checksum right, a field wrong (latitude minutes 61): malformed, and nothing of it merged. */
    feed_text(&n, "$GPGGA,123519,4861.000,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*4C\r\n", 0, &seen);
    assert_int_equal(n.stats.malformed, 1);
    char overlong[200];
    memset(overlong, 'A', sizeof overlong);
    overlong[0] = '$';
    memcpy(overlong + sizeof overlong - 3, "\r\n", 3);
    feed_text(&n, overlong, 0, &seen);
    assert_int_equal(n.stats.overlong, 1);
    feed_text(&n, "noise between sentences", 0, &seen);
    for (int k = 0; k < UB_NMEA_KIND_COUNT; k++) assert_int_equal(seen.calls[k], 0);
    assert_int_equal(n.stats.sentences_ok, 0);
    assert_float_equal(n.fix.lat_deg, 0.0, 0.0);
    check_accounting(&n);
    feed_text(&n, k_gga, 0, &seen); /* and it recovers on the next good one */
    assert_int_equal(seen.calls[UB_NMEA_GGA], 1);
    check_accounting(&n);
    assert_int_equal(ub_nmea_feed(NULL, NULL, 0, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_nmea_feed(&n, NULL, 1, NULL, NULL), UB_ERR_INVAL);
    assert_string_equal(ub_nmea_kind_name(UB_NMEA_VTG), "VTG");
    assert_string_equal(ub_nmea_kind_name(UB_NMEA_KIND_COUNT), "?");
}

static void test_southern_western_hemispheres_and_empty_fields(void **state) {
    (void)state;
    ub_nmea_t n;
    ub_nmea_init(&n);
    /* The checksum is computed here, over the body below. */
    static const char s[] = "$GNRMC,000001.50,V,3345.500,S,07030.250,W,,,010125,,*%02X\r\n";
    char text[128];
    const char *body = "GNRMC,000001.50,V,3345.500,S,07030.250,W,,,010125,,";
    unsigned sum = 0;
    for (const char *p = body; *p; p++) sum ^= (unsigned char)*p;
    snprintf(text, sizeof text, s, sum);
    assert_int_equal(ub_nmea_feed(&n, (const uint8_t *)text, strlen(text), NULL, NULL), 1);
    assert_float_equal(n.fix.lat_deg, -(33.0 + 45.5 / 60.0), 1e-9);
    assert_float_equal(n.fix.lon_deg, -(70.0 + 30.25 / 60.0), 1e-9);
    assert_int_equal(n.fix.valid, 0);
    assert_int_equal(n.fix.utc_ms, 1500);
    assert_int_equal(n.fix.date_ddmmyy, 10125);
    assert_float_equal(n.fix.speed_mps, 0.0, 0.0); /* empty: unchanged */
}

/* Sentences with a right checksum (computed here) and one field that does not parse: each counted
 * malformed, none merged, the fix unchanged (issue #29 item 6: every refusal counted). Then the good edge
 * cases: empty fields, a lower-case checksum, southern and western hemispheres. */
static void sealed(char *out, size_t cap, const char *body) {
    uint8_t sum = 0;
    for (const char *c = body; *c; c++) sum ^= (uint8_t)*c;
    snprintf(out, cap, "$%s*%02X\r\n", body, sum);
}

static void test_malformed_fields_each_counted(void **state) {
    (void)state;
    static const char *const bad[] = {
        "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M",            /* too few fields */
        "GPGGA,1235,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",            /* short time */
        "GPGGA,253519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",          /* hour 25 */
        "GPGGA,126019,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",          /* minute 60 */
        "GPGGA,123519,9107.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",          /* latitude 91 */
        "GPGGA,123519,4807.038,X,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",          /* hemisphere X */
        "GPGGA,123519,4807.038,N,18131.000,E,1,08,0.9,545.4,M,46.9,M,,",          /* longitude 181 */
        "GPGGA,123519,4807.038,N,01131.000,EW,1,08,0.9,545.4,M,46.9,M,,",         /* two letters */
        "GPGGA,123519,-4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",         /* negative angle */
        "GPGGA,123519,4807.038,N,01131.000,E,x,08,0.9,545.4,M,46.9,M,,",          /* quality x */
        "GPGGA,123519,4807.038,N,01131.000,E,1,100,0.9,545.4,M,46.9,M,,",         /* 100 satellites */
        "GPGGA,123519,4807.038,N,01131.000,E,1,0123456789,0.9,545.4,M,46.9,M,,",  /* ten digits */
        "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9.1,545.4,M,46.9,M,,",        /* two points */
        "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,abc,M,46.9,M,,",            /* altitude abc */
        "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,-,M,,",             /* a sign alone */
        "GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4",                       /* too few fields */
        "GPRMC,123519,Q,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W",        /* status Q */
        "GPRMC,123519,A,4807.038,N,01131.000,E,fast,084.4,230394,003.1,W",         /* speed */
        "GPRMC,123519,A,4807.038,N,01131.000,E,022.4,east,230394,003.1,W",         /* course */
        "GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,2303,003.1,W",          /* short date */
        "GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,999999,003.1,W",        /* date out of range */
        "GPRMC,1x3519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W",        /* time */
        "GPRMC,123519,A,4807.038,N,01131.000,Z,022.4,084.4,230394,003.1,W",        /* hemisphere Z */
        "GPVTG,054.7,T,034.4,M,005.5,N,010.2",                                     /* too few fields */
        "GPVTG,north,T,034.4,M,005.5,N,010.2,K",                                   /* course */
        "GPVTG,054.7,T,034.4,M,slow,N,010.2,K",                                    /* speed */
        "GPGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3",                                 /* too few fields */
        "GPGSA,A,0,04,05,,09,12,,,24,,,,,2.5,1.3,2.1",                             /* fix mode 0 */
        "GPGSA,A,4,04,05,,09,12,,,24,,,,,2.5,1.3,2.1",                             /* fix mode 4 */
        "GPGSA,A,3,04,05,,09,12,,,24,,,,,x,1.3,2.1",                               /* pdop */
        "GPGSA,A,3,04,05,,09,12,,,24,,,,,2.5,x,2.1",                               /* hdop */
        "GPGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3,x",                               /* vdop */
        "GPGGAX,123519",                                                           /* a type of 4 letters */
    };
    ub_nmea_t n;
    ub_nmea_init(&n);
    seen_t seen = {{0}};
    char line[160];
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        sealed(line, sizeof line, bad[i]);
        uint64_t ok = n.stats.sentences_ok;
        feed_text(&n, line, 0, &seen);
        check_accounting(&n);
        if (n.stats.sentences_ok != ok) fail_msg("accepted: %s", bad[i]);
    }
    assert_int_equal(n.stats.sentences_ok, 0);
    assert_int_equal(n.stats.malformed, sizeof bad / sizeof bad[0]);
    assert_int_equal(n.stats.bad_checksum, 0);
    for (int k = 0; k < UB_NMEA_KIND_COUNT; k++) assert_int_equal(seen.calls[k], 0);
    assert_float_equal(n.fix.lat_deg, 0.0, 0.0);

    /* Empty fields are "not reported", a lower-case checksum is a checksum, S and W are negative. */
    sealed(line, sizeof line, "GPGGA,,3345.000,S,08420.000,W,,,,,,,,,");
    for (char *c = line; *c; c++)
        if (*c >= 'A' && *c <= 'F' && c > strchr(line, '*')) *c = (char)(*c - 'A' + 'a');
    feed_text(&n, line, 0, &seen);
    assert_int_equal(n.stats.sentences_ok, 1);
    assert_float_equal(n.fix.lat_deg, -(33.0 + 45.0 / 60.0), 1e-9);
    assert_float_equal(n.fix.lon_deg, -(84.0 + 20.0 / 60.0), 1e-9);
    sealed(line, sizeof line, "GPRMC,,,,,,,,,,,");
    feed_text(&n, line, 0, &seen);
    sealed(line, sizeof line, "GPVTG,,T,,M,,N,,K");
    feed_text(&n, line, 0, &seen);
    assert_int_equal(n.stats.sentences_ok, 3);
    check_accounting(&n);
    assert_int_equal(ub_nmea_feed(NULL, (const uint8_t *)line, 1, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_nmea_feed(&n, NULL, 1, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_nmea_feed(&n, NULL, 0, NULL, NULL), 0);
    ub_nmea_init(NULL);
    assert_string_equal(ub_nmea_kind_name((ub_nmea_kind_t)99), "?");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_malformed_fields_each_counted),
        cmocka_unit_test(test_four_sentences_merge_into_one_fix),
        cmocka_unit_test(test_bad_sentences_are_counted_not_merged),
        cmocka_unit_test(test_southern_western_hemispheres_and_empty_fields),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

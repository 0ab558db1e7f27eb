/* The GPS adapters' field mapping as data (ub_gps_fields.h): what Python's adapters write by name is what the
 * C adapters assign, member by member (same expression, same C type, then widened to double), with the
 * counters flagged, NULL and a short `cap` handled as the contract says. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_gps_fields.h"
#include "ub/ub_wire.h"

static const ub_dir_value_t *find(const ub_dir_value_t *v, size_t n, const char *member) {
    for (size_t i = 0; i < n; i++)
        if (strcmp(v[i].member, member) == 0) return &v[i];
    fail_msg("member %s not in the list", member);
    return NULL;
}

static void test_nmea_values_are_the_fix_and_the_counters(void **state) {
    (void)state;
    ub_nmea_t n;
    ub_nmea_init(&n);
    static const char text[] = "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n"
                               "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*48\r\n";
    assert_int_equal(ub_nmea_feed(&n, (const uint8_t *)text, strlen(text), NULL, NULL), 1);
    ub_dir_value_t v[UB_DIR_VALUES_MAX];
    size_t count = ub_nmea_dir_values(&n, v, UB_DIR_VALUES_MAX);
    assert_int_equal(count, 18); /* the 18 members of nmeaGps_t after its time tag */
    assert_float_equal(find(v, count, "latitudeDeg")->value, 48.0 + 7.038 / 60.0, 1e-12);
    assert_true(find(v, count, "hdop")->value == (double)(float)0.9); /* the member's type first: float */
    assert_float_equal(find(v, count, "utcMilliseconds")->value, 45319000.0, 0.0);
    assert_float_equal(find(v, count, "satellitesUsed")->value, 8.0, 0.0);
    const ub_dir_value_t *ok = find(v, count, "sentencesOk"), *bad = find(v, count, "badChecksums");
    assert_true(ok->counter && bad->counter && !find(v, count, "altitudeMsl")->counter);
    assert_float_equal(ok->value, 1.0, 0.0);
    assert_float_equal(bad->value, 1.0, 0.0);
    for (size_t i = 1; i < count; i++) assert_true(v[i - 1].counter <= v[i].counter); /* fix, then counters */
}

static void test_ubx_values_are_the_last_nav_pvt(void **state) {
    (void)state;
    uint8_t p[UB_UBX_NAV_PVT_LEN] = {0}, msg[8 + UB_UBX_NAV_PVT_LEN];
    ub_put_u32le(p + 0, 100200u);              /* iTOW */
    ub_put_u16le(p + 4, 2026u);                /* year */
    p[10] = 59;                                /* sec */
    p[20] = 3;                                 /* fixType */
    p[23] = 11;                                /* numSV */
    ub_put_u32le(p + 24, (uint32_t)-849664000); /* lon * 1e7 */
    ub_put_u32le(p + 28, 323738000u);          /* lat * 1e7 */
    ub_put_u32le(p + 36, 120010u);             /* hMSL mm */
    ub_put_u32le(p + 52, (uint32_t)-200);      /* velE mm/s */
    ub_put_u16le(p + 76, 181u);                /* pDOP * 100 */
    int len = ub_ubx_build(UB_UBX_CLASS_NAV, UB_UBX_ID_NAV_PVT, p, sizeof p, msg, sizeof msg);
    assert_int_equal(len, (int)sizeof msg);
    ub_ubx_t u;
    ub_ubx_init(&u);
    assert_int_equal(ub_ubx_feed(&u, msg, (size_t)len, NULL, NULL), 1);
    ub_dir_value_t v[UB_DIR_VALUES_MAX];
    size_t count = ub_ubx_dir_values(&u, v, UB_DIR_VALUES_MAX);
    assert_int_equal(count, 24);
    assert_float_equal(find(v, count, "latitudeDeg")->value, 32.3738, 1e-12);
    assert_float_equal(find(v, count, "longitudeDeg")->value, -84.9664, 1e-12);
    assert_float_equal(find(v, count, "altitudeMsl")->value, 120.01, 1e-12);
    assert_true(find(v, count, "velEast")->value == (double)(float)-0.2);
    assert_true(find(v, count, "pdop")->value == (double)(float)1.81);
    assert_float_equal(find(v, count, "iTowMs")->value, 100200.0, 0.0);
    assert_float_equal(find(v, count, "year")->value, 2026.0, 0.0);
    assert_float_equal(find(v, count, "second")->value, 59.0, 0.0);
    assert_float_equal(find(v, count, "satellitesUsed")->value, 11.0, 0.0);
    assert_float_equal(find(v, count, "navPvtOk")->value, 1.0, 0.0);
    assert_true(find(v, count, "navPvtOk")->counter);
}

static void test_short_cap_and_null(void **state) {
    (void)state;
    ub_nmea_t n;
    ub_nmea_init(&n);
    ub_dir_value_t v[3];
    memset(v, 0, sizeof v);
    assert_int_equal(ub_nmea_dir_values(&n, v, 2), 18); /* all counted, two written */
    assert_string_equal(v[0].member, "latitudeDeg");
    assert_null(v[2].member);
    assert_int_equal(ub_nmea_dir_values(&n, NULL, 0), 18);
    assert_int_equal(ub_nmea_dir_values(&n, NULL, 5), 18); /* a cap but nowhere to write: counted only */
    assert_int_equal(ub_nmea_dir_values(NULL, v, 3), 0);
    assert_int_equal(ub_ubx_dir_values(NULL, v, 3), 0);
    assert_int_equal(ub_ubx_cfg_dir_values(NULL, v, 3), 0);
    assert_null(v[2].member);
}

/* The CFG-RATE exchange both adapters run: sent when the wanted rate changes, not again once answered, a NAK
 * not retried, a time-out counted and sent again, and a stale (earlier) clock never taken for "overdue". */
static void test_cfg_rate_exchange(void **state) {
    (void)state;
    ub_ubx_cfg_t c;
    ub_ubx_cfg_init(&c);
    uint8_t msg[8 + UB_UBX_CFG_RATE_LEN];
    ub_ubx_rate_t want = {0, 1, 0};
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 0, msg, sizeof msg), 0); /* measRateMs 0: nothing */
    want.meas_rate_ms = 200;
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 10, msg, sizeof msg), (int)sizeof msg);
    assert_int_equal(msg[2], UB_UBX_CLASS_CFG);
    assert_int_equal(msg[3], UB_UBX_ID_CFG_RATE);
    assert_int_equal(msg[6] | msg[7] << 8, 200);
    ub_ubx_cfg_sent(&c, &want, 10);
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 5, msg, sizeof msg), 0);    /* stale clock: not overdue */
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 1009, msg, sizeof msg), 0); /* still waiting */
    ub_ubx_ack_t other = {UB_UBX_CLASS_NAV, UB_UBX_ID_NAV_PVT, 1}, ack = {UB_UBX_CLASS_CFG, UB_UBX_ID_CFG_RATE, 1};
    assert_int_equal(ub_ubx_cfg_answer(&c, &other), 0);
    assert_int_equal(ub_ubx_cfg_answer(&c, &ack), 1);
    assert_int_equal(ub_ubx_cfg_answer(&c, &ack), 0); /* nothing pending any more */
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 5000, msg, sizeof msg), 0); /* answered: not sent again */
    assert_int_equal(c.acked, 1);
    assert_int_equal(c.acked_meas_rate_ms, 200);
    want.meas_rate_ms = 25; /* refused */
    assert_true(ub_ubx_cfg_poll(&c, &want, 6000, msg, sizeof msg) > 0);
    ub_ubx_cfg_sent(&c, &want, 6000);
    ack.ok = 0;
    assert_int_equal(ub_ubx_cfg_answer(&c, &ack), 1);
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 9000, msg, sizeof msg), 0); /* a NAK is not retried */
    assert_int_equal(c.naked, 1);
    assert_int_equal(c.acked_meas_rate_ms, 200);
    want.meas_rate_ms = 1000; /* no answer */
    assert_true(ub_ubx_cfg_poll(&c, &want, 10000, msg, sizeof msg) > 0);
    ub_ubx_cfg_sent(&c, &want, 10000);
    assert_true(ub_ubx_cfg_poll(&c, &want, 11000, msg, sizeof msg) > 0);
    assert_int_equal(c.timeouts, 1);
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 11000, msg, 4), UB_ERR_NOSPACE);
    ub_dir_value_t v[UB_DIR_VALUES_MAX];
    size_t count = ub_ubx_cfg_dir_values(&c, v, UB_DIR_VALUES_MAX);
    assert_int_equal(count, 5);
    assert_float_equal(find(v, count, "cfgSent")->value, 3.0, 0.0);
    assert_float_equal(find(v, count, "cfgMeasRateMs")->value, 200.0, 0.0);
    assert_int_equal(ub_ubx_cfg_poll(NULL, &want, 0, msg, sizeof msg), UB_ERR_INVAL);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nmea_values_are_the_fix_and_the_counters),
        cmocka_unit_test(test_ubx_values_are_the_last_nav_pvt),
        cmocka_unit_test(test_short_cap_and_null),
        cmocka_unit_test(test_cfg_rate_exchange),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/* u-blox UBX parser (ub_ubx.h): a NAV-PVT built here byte by byte from the interface description's layout
 * (the independent encoder is pyubx2, in tests/system/test_nmea_gps.py's UBX test), fed whole and byte by
 * byte between noise; a corrupted copy, another message and a wrong-length NAV-PVT are counted, not decoded. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_ubx.h"
#include "ub/ub_wire.h"

static size_t message(uint8_t *out, uint8_t cls, uint8_t id, const uint8_t *payload, uint16_t len) {
    out[0] = UB_UBX_SYNC1;
    out[1] = UB_UBX_SYNC2;
    out[2] = cls;
    out[3] = id;
    ub_put_u16le(out + 4, len);
    memcpy(out + 6, payload, len);
    uint8_t a = 0, b = 0;
    for (size_t i = 2; i < 6u + len; i++) {
        a = (uint8_t)(a + out[i]);
        b = (uint8_t)(b + a);
    }
    out[6 + len] = a;
    out[7 + len] = b;
    return 8u + len;
}

static size_t pvt_message(uint8_t *out) {
    uint8_t p[UB_UBX_NAV_PVT_LEN] = {0};
    ub_put_u32le(p + 0, 123000);
    ub_put_u16le(p + 4, 2026);
    p[6] = 11;
    p[7] = 26;
    p[20] = 3;
    p[23] = 9;
    ub_put_u32le(p + 24, (uint32_t)-849664000);
    ub_put_u32le(p + 28, 323738000);
    ub_put_u32le(p + 36, 120000);
    ub_put_u32le(p + 60, 5500);
    ub_put_u32le(p + 64, 8150000);
    ub_put_u16le(p + 76, 180);
    return message(out, UB_UBX_CLASS_NAV, UB_UBX_ID_NAV_PVT, p, sizeof p);
}

static unsigned g_calls;
static void on_pvt(void *user, const ub_ubx_t *ubx) {
    (void)user;
    (void)ubx;
    g_calls++;
}

static void test_nav_pvt_decoded_in_any_cut(void **state) {
    (void)state;
    uint8_t buf[512];
    size_t n = 0;
    const uint8_t noise[] = {0x00, UB_UBX_SYNC1, 0x11, UB_UBX_SYNC1, UB_UBX_SYNC1};
    memcpy(buf, noise, sizeof noise);
    n += sizeof noise;
    n += pvt_message(buf + n);
    for (int bytewise = 0; bytewise < 2; bytewise++) {
        ub_ubx_t u;
        ub_ubx_init(&u);
        g_calls = 0;
        if (bytewise) {
            for (size_t i = 0; i < n; i++) assert_true(ub_ubx_feed(&u, buf + i, 1, on_pvt, NULL) >= 0);
        } else {
            assert_int_equal(ub_ubx_feed(&u, buf, n, on_pvt, NULL), 1);
        }
        assert_int_equal(g_calls, 1);
        assert_int_equal(u.pvt.itow_ms, 123000);
        assert_int_equal(u.pvt.year, 2026);
        assert_int_equal(u.pvt.fix_type, 3);
        assert_int_equal(u.pvt.num_sv, 9);
        assert_int_equal(u.pvt.lon_1e7, -849664000);
        assert_int_equal(u.pvt.lat_1e7, 323738000);
        assert_int_equal(u.pvt.hmsl_mm, 120000);
        assert_int_equal(u.pvt.g_speed_mms, 5500);
        assert_int_equal(u.pvt.head_mot_1e5, 8150000);
        assert_int_equal(u.pvt.p_dop_1e2, 180);
        assert_int_equal(u.stats.noise_bytes, sizeof noise); /* false starts are noise; the message has its own sync */
        assert_int_equal(u.stats.bytes_in, u.stats.noise_bytes + u.stats.bytes_in_messages);
    }
}

static void test_bad_messages_counted_not_decoded(void **state) {
    (void)state;
    uint8_t buf[512];
    ub_ubx_t u;
    ub_ubx_init(&u);
    g_calls = 0;
    size_t n = pvt_message(buf);
    buf[6 + 28] ^= 0x01; /* latitude changed in transit */
    assert_int_equal(ub_ubx_feed(&u, buf, n, on_pvt, NULL), 0);
    assert_int_equal(u.stats.bad_checksum, 1);
    const uint8_t ack[2] = {0x06, 0x8A};
    n = message(buf, 0x05, 0x01, ack, sizeof ack); /* ACK-ACK: decoded, called back, not a NAV-PVT */
    assert_int_equal(ub_ubx_feed(&u, buf, n, on_pvt, NULL), 0);
    assert_int_equal(u.stats.ack, 1);
    assert_int_equal(g_calls, 1);
    assert_int_equal(u.ack.cls, 0x06);
    assert_int_equal(u.ack.id, 0x8A);
    assert_int_equal(u.ack.ok, 1);
    g_calls = 0;
    n = message(buf, 0x0A, 0x04, ack, sizeof ack); /* MON-VER-like: good, unsupported */
    assert_int_equal(ub_ubx_feed(&u, buf, n, on_pvt, NULL), 0);
    assert_int_equal(u.stats.unsupported, 1);
    uint8_t shortp[40] = {0};
    n = message(buf, UB_UBX_CLASS_NAV, UB_UBX_ID_NAV_PVT, shortp, sizeof shortp);
    assert_int_equal(ub_ubx_feed(&u, buf, n, on_pvt, NULL), 0);
    assert_int_equal(u.stats.bad_length, 1);
    uint8_t big[200] = {0};
    n = message(buf, 0x0A, 0x04, big, sizeof big);
    assert_int_equal(ub_ubx_feed(&u, buf, n, on_pvt, NULL), 0);
    assert_int_equal(u.stats.too_long, 1);
    assert_int_equal(g_calls, 0);
    assert_int_equal(u.pvt.lat_1e7, 0);
    assert_int_equal(u.stats.bytes_in, u.stats.noise_bytes + u.stats.bytes_in_messages);
    assert_int_equal(ub_ubx_feed(NULL, NULL, 0, NULL, NULL), UB_ERR_INVAL);
}

/* ub_ubx_build() against message() above (written from the interface description): the same bytes, and the
 * parser reads its CFG-RATE back as a good message. */
static void test_build_matches_layout(void **state) {
    (void)state;
    const uint8_t rate[UB_UBX_CFG_RATE_LEN] = {0xC8, 0x00, 0x01, 0x00, 0x01, 0x00}; /* 200 ms, 1 cycle, GPS */
    uint8_t want[32], got[32];
    size_t n = message(want, UB_UBX_CLASS_CFG, UB_UBX_ID_CFG_RATE, rate, sizeof rate);
    assert_int_equal(ub_ubx_build(UB_UBX_CLASS_CFG, UB_UBX_ID_CFG_RATE, rate, sizeof rate, got, sizeof got), (int)n);
    assert_memory_equal(got, want, n);
    assert_int_equal(ub_ubx_build(UB_UBX_CLASS_CFG, UB_UBX_ID_CFG_RATE, rate, sizeof rate, got, n - 1), UB_ERR_NOSPACE);
    ub_ubx_t u;
    ub_ubx_init(&u);
    assert_int_equal(ub_ubx_feed(&u, got, n, NULL, NULL), 0);
    assert_int_equal(u.stats.unsupported, 1);
    assert_int_equal(u.stats.bad_checksum, 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nav_pvt_decoded_in_any_cut),
        cmocka_unit_test(test_bad_messages_counted_not_decoded),
        cmocka_unit_test(test_build_matches_layout),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

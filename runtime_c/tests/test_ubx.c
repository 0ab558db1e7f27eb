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

/* The messages around a CFG exchange (issue #29 item 6): an ACK-NAK decoded as a refusal, an ACK of the wrong
 * length counted and not decoded, another ACK id and another NAV message unsupported, a message without
 * payload (a poll request) read whole, a parser without callback counting all the same; NULL refusals. */
static void test_acks_and_short_messages(void **state) {
    (void)state;
    uint8_t buf[64];
    ub_ubx_t u;
    ub_ubx_init(&u);
    g_calls = 0;
    const uint8_t answered[3] = {UB_UBX_CLASS_CFG, UB_UBX_ID_CFG_RATE, 0};
    size_t n = message(buf, UB_UBX_CLASS_ACK, UB_UBX_ID_ACK_NAK, answered, 2);
    assert_int_equal(ub_ubx_feed(&u, buf, n, on_pvt, NULL), 0);
    assert_int_equal(g_calls, 1);
    assert_int_equal(u.stats.nak, 1);
    assert_int_equal(u.ack.ok, 0);
    assert_int_equal(u.ack.cls, UB_UBX_CLASS_CFG);
    assert_int_equal(u.ack.id, UB_UBX_ID_CFG_RATE);
    n = message(buf, UB_UBX_CLASS_ACK, UB_UBX_ID_ACK_ACK, (const uint8_t[3]){UB_UBX_CLASS_NAV, 0x99, 0}, 3);
    assert_int_equal(ub_ubx_feed(&u, buf, n, on_pvt, NULL), 0);
    assert_int_equal(u.stats.bad_length, 1);
    assert_int_equal(u.ack.id, UB_UBX_ID_CFG_RATE); /* the wrong-length ACK was not decoded */
    assert_int_equal(g_calls, 1);
    n = message(buf, UB_UBX_CLASS_ACK, 0x02, answered, 2); /* neither ACK nor NAK */
    assert_int_equal(ub_ubx_feed(&u, buf, n, on_pvt, NULL), 0);
    n = message(buf, UB_UBX_CLASS_NAV, 0x03, answered, 2); /* NAV-STATUS-like: not NAV-PVT */
    assert_int_equal(ub_ubx_feed(&u, buf, n, on_pvt, NULL), 0);
    assert_int_equal(u.stats.unsupported, 2);
    /* a poll request has no payload: its checksum follows the length at once */
    int m = ub_ubx_build(UB_UBX_CLASS_CFG, UB_UBX_ID_CFG_RATE, NULL, 0, buf, sizeof buf);
    assert_int_equal(m, 8);
    assert_int_equal(buf[4] | buf[5] << 8, 0);
    assert_int_equal(ub_ubx_feed(&u, buf, (size_t)m, on_pvt, NULL), 0);
    assert_int_equal(u.stats.unsupported, 3);
    assert_int_equal(u.stats.bad_checksum, 0);
    /* no callback: an ACK still decoded and counted */
    n = message(buf, UB_UBX_CLASS_ACK, UB_UBX_ID_ACK_ACK, answered, 2);
    assert_int_equal(ub_ubx_feed(&u, buf, n, NULL, NULL), 0);
    assert_int_equal(u.stats.ack, 1);
    assert_int_equal(u.ack.ok, 1);
    assert_int_equal(g_calls, 1);
    assert_int_equal(u.stats.bytes_in, u.stats.noise_bytes + u.stats.bytes_in_messages);
    assert_int_equal(u.stats.noise_bytes, 0);
    /* refusals */
    uint64_t in = u.stats.bytes_in;
    assert_int_equal(ub_ubx_feed(&u, NULL, 1, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_ubx_feed(&u, NULL, 0, NULL, NULL), 0);
    assert_int_equal(u.stats.bytes_in, in);
    assert_int_equal(ub_ubx_build(1, 2, NULL, 0, NULL, 64), UB_ERR_INVAL);
    assert_int_equal(ub_ubx_build(1, 2, NULL, 4, buf, sizeof buf), UB_ERR_INVAL);
    ub_ubx_init(NULL);
}

/* The CFG-RATE exchange beside test_gps_fields' (issue #29 item 6): a wanted rate that differs from the
 * answered one only in its navigation rate, or only in its time reference, is written again; an ACK of
 * another CFG message does not settle it; the NULL refusals change nothing. */
static void test_cfg_rate_every_field_counts(void **state) {
    (void)state;
    ub_ubx_cfg_t c;
    ub_ubx_cfg_init(&c);
    uint8_t msg[8 + UB_UBX_CFG_RATE_LEN];
    ub_ubx_rate_t want = {200, 1, 0};
    ub_ubx_ack_t ack = {UB_UBX_CLASS_CFG, UB_UBX_ID_CFG_RATE, 1};
    ub_ubx_ack_t other_cfg = {UB_UBX_CLASS_CFG, 0x01 /* CFG-MSG */, 1};
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 0, msg, sizeof msg), (int)sizeof msg);
    ub_ubx_cfg_sent(&c, &want, 0);
    assert_int_equal(ub_ubx_cfg_answer(&c, &other_cfg), 0);
    assert_int_equal(c.pending, 1);
    assert_int_equal(ub_ubx_cfg_answer(&c, &ack), 1);
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 10, msg, sizeof msg), 0); /* applied: nothing to write */
    want.nav_rate = 2;
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 20, msg, sizeof msg), (int)sizeof msg);
    assert_int_equal(msg[8] | msg[9] << 8, 2);
    ub_ubx_cfg_sent(&c, &want, 20);
    assert_int_equal(ub_ubx_cfg_answer(&c, &ack), 1);
    want.time_ref = 1;
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 30, msg, sizeof msg), (int)sizeof msg);
    assert_int_equal(msg[10] | msg[11] << 8, 1);
    assert_int_equal(c.sent_count, 2);
    /* refusals and NULLs: nothing moves */
    assert_int_equal(ub_ubx_cfg_poll(&c, NULL, 30, msg, sizeof msg), UB_ERR_INVAL);
    assert_int_equal(ub_ubx_cfg_poll(&c, &want, 30, NULL, sizeof msg), UB_ERR_INVAL);
    ub_ubx_cfg_sent(NULL, &want, 30);
    ub_ubx_cfg_sent(&c, NULL, 30);
    assert_int_equal(c.sent_count, 2);
    assert_int_equal(c.pending, 0);
    assert_int_equal(ub_ubx_cfg_answer(NULL, &ack), 0);
    assert_int_equal(ub_ubx_cfg_answer(&c, NULL), 0);
    ub_ubx_cfg_init(NULL);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nav_pvt_decoded_in_any_cut),
        cmocka_unit_test(test_bad_messages_counted_not_decoded),
        cmocka_unit_test(test_build_matches_layout),
        cmocka_unit_test(test_acks_and_short_messages),
        cmocka_unit_test(test_cfg_rate_every_field_counts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

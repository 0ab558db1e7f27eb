/* u-blox UBX messages (contracts in ub/ub_ubx.h). Little-endian fields read with ub_wire.h's shifts. */
#include "ub/ub_ubx.h"

#include <string.h>

#include "ub/ub_wire.h"

enum { S_SYNC1 = 0, S_SYNC2, S_CLASS, S_ID, S_LEN1, S_LEN2, S_PAYLOAD, S_CK_A, S_CK_B };

void ub_ubx_init(ub_ubx_t *ubx) {
    if (ubx == NULL) return;
    memset(ubx, 0, sizeof *ubx);
}

static void checksum(ub_ubx_t *u, uint8_t b) {
    u->ck_a = (uint8_t)(u->ck_a + b);
    u->ck_b = (uint8_t)(u->ck_b + u->ck_a);
}

static void decode_pvt(ub_ubx_pvt_t *p, const uint8_t *b) {
    p->itow_ms = ub_get_u32le(b + 0);
    p->year = ub_get_u16le(b + 4);
    p->month = b[6];
    p->day = b[7];
    p->hour = b[8];
    p->min = b[9];
    p->sec = b[10];
    p->valid = b[11];
    p->fix_type = b[20];
    p->flags = b[21];
    p->num_sv = b[23];
    p->lon_1e7 = (int32_t)ub_get_u32le(b + 24);
    p->lat_1e7 = (int32_t)ub_get_u32le(b + 28);
    p->height_mm = (int32_t)ub_get_u32le(b + 32);
    p->hmsl_mm = (int32_t)ub_get_u32le(b + 36);
    p->h_acc_mm = ub_get_u32le(b + 40);
    p->v_acc_mm = ub_get_u32le(b + 44);
    p->vel_n_mms = (int32_t)ub_get_u32le(b + 48);
    p->vel_e_mms = (int32_t)ub_get_u32le(b + 52);
    p->vel_d_mms = (int32_t)ub_get_u32le(b + 56);
    p->g_speed_mms = (int32_t)ub_get_u32le(b + 60);
    p->head_mot_1e5 = (int32_t)ub_get_u32le(b + 64);
    p->p_dop_1e2 = ub_get_u16le(b + 76);
}

/* The message ends (both check bytes read): judge it. Returns 1 for a good NAV-PVT. */
static int finish(ub_ubx_t *u, ub_ubx_cb cb, void *user) {
    u->state = S_SYNC1;
    u->stats.bytes_in_messages += 8u + u->len;
    if (u->len > UB_UBX_PAYLOAD_MAX) {
        u->stats.too_long++;
        return 0;
    }
    if (u->ck_bad) { /* the check bytes were compared as they came */
        u->stats.bad_checksum++;
        return 0;
    }
    if (u->cls == UB_UBX_CLASS_ACK && (u->id == UB_UBX_ID_ACK_ACK || u->id == UB_UBX_ID_ACK_NAK)) {
        if (u->len != 2u) {
            u->stats.bad_length++;
            return 0;
        }
        u->ack.cls = u->payload[0];
        u->ack.id = u->payload[1];
        u->ack.ok = u->id == UB_UBX_ID_ACK_ACK;
        if (u->ack.ok) u->stats.ack++;
        else u->stats.nak++;
        if (cb != NULL) cb(user, u);
        return 0;
    }
    if (u->cls != UB_UBX_CLASS_NAV || u->id != UB_UBX_ID_NAV_PVT) {
        u->stats.unsupported++;
        return 0;
    }
    if (u->len != UB_UBX_NAV_PVT_LEN) {
        u->stats.bad_length++;
        return 0;
    }
    decode_pvt(&u->pvt, u->payload);
    u->stats.nav_pvt++;
    if (cb != NULL) cb(user, u);
    return 1;
}

int ub_ubx_feed(ub_ubx_t *u, const uint8_t *data, size_t len, ub_ubx_cb cb, void *user) {
    if (u == NULL || (data == NULL && len != 0)) return UB_ERR_INVAL;
    u->stats.bytes_in += len;
    int decoded = 0;
    for (size_t i = 0; i < len; i++) {
        uint8_t b = data[i];
        switch (u->state) {
        case S_SYNC1:
            if (b == UB_UBX_SYNC1) u->state = S_SYNC2;
            else u->stats.noise_bytes++;
            break;
        case S_SYNC2:
            if (b == UB_UBX_SYNC2) {
                u->state = S_CLASS;
                u->ck_a = u->ck_b = 0;
                u->ck_bad = 0;
            } else { /* the held SYNC1 was noise; this byte may start a message */
                u->stats.noise_bytes++;
                if (b == UB_UBX_SYNC1) break;
                u->stats.noise_bytes++;
                u->state = S_SYNC1;
            }
            break;
        case S_CLASS:
            u->cls = b;
            checksum(u, b);
            u->state = S_ID;
            break;
        case S_ID:
            u->id = b;
            checksum(u, b);
            u->state = S_LEN1;
            break;
        case S_LEN1:
            u->len = b;
            checksum(u, b);
            u->state = S_LEN2;
            break;
        case S_LEN2:
            u->len = (uint16_t)(u->len | b << 8);
            checksum(u, b);
            u->have = 0;
            u->state = u->len == 0 ? S_CK_A : S_PAYLOAD;
            break;
        case S_PAYLOAD:
            checksum(u, b);
            if (u->have < UB_UBX_PAYLOAD_MAX) u->payload[u->have] = b;
            if (++u->have == u->len) u->state = S_CK_A;
            break;
        case S_CK_A:
            if (b != u->ck_a) u->ck_bad = 1;
            u->state = S_CK_B;
            break;
        default: /* S_CK_B */
            if (b != u->ck_b) u->ck_bad = 1;
            decoded += finish(u, cb, user);
            break;
        }
    }
    return decoded;
}

int ub_ubx_build(uint8_t cls, uint8_t id, const uint8_t *payload, uint16_t len, uint8_t *out, size_t cap) {
    if (out == NULL || (payload == NULL && len != 0)) return UB_ERR_INVAL;
    if (cap < 8u + (size_t)len) return UB_ERR_NOSPACE;
    out[0] = UB_UBX_SYNC1;
    out[1] = UB_UBX_SYNC2;
    out[2] = cls;
    out[3] = id;
    ub_put_u16le(out + 4, len);
    if (len != 0) memcpy(out + 6, payload, len);
    uint8_t a = 0, b = 0;
    for (size_t i = 2; i < 6u + len; i++) {
        a = (uint8_t)(a + out[i]);
        b = (uint8_t)(b + a);
    }
    out[6 + len] = a;
    out[7 + len] = b;
    return (int)(8u + len);
}

void ub_ubx_cfg_init(ub_ubx_cfg_t *cfg) {
    if (cfg != NULL) memset(cfg, 0, sizeof *cfg);
}

static int same_rate(const ub_ubx_rate_t *x, const ub_ubx_rate_t *y) {
    return x->meas_rate_ms == y->meas_rate_ms && x->nav_rate == y->nav_rate && x->time_ref == y->time_ref;
}

int ub_ubx_cfg_poll(ub_ubx_cfg_t *cfg, const ub_ubx_rate_t *want, uint64_t now_ms, uint8_t *out, size_t cap) {
    if (cfg == NULL || want == NULL || out == NULL) return UB_ERR_INVAL;
    if (cfg->pending) {
        /* not `now - sent < timeout`: a clock read before the sending one (a caller's stale now) must not
         * wrap around into "overdue" and resend at every call */
        if (now_ms < cfg->sent_ms + UB_UBX_ACK_TIMEOUT_MS) return 0;
        cfg->pending = 0; /* no answer: counted, and sent again below */
        cfg->timeouts++;
    } else if (same_rate(want, &cfg->applied)) {
        return 0;
    }
    if (want->meas_rate_ms == 0) return 0;
    uint8_t payload[UB_UBX_CFG_RATE_LEN];
    ub_put_u16le(payload + 0, want->meas_rate_ms);
    ub_put_u16le(payload + 2, want->nav_rate);
    ub_put_u16le(payload + 4, want->time_ref);
    return ub_ubx_build(UB_UBX_CLASS_CFG, UB_UBX_ID_CFG_RATE, payload, sizeof payload, out, cap);
}

void ub_ubx_cfg_sent(ub_ubx_cfg_t *cfg, const ub_ubx_rate_t *want, uint64_t now_ms) {
    if (cfg == NULL || want == NULL) return;
    cfg->sent = *want;
    cfg->sent_ms = now_ms;
    cfg->pending = 1;
    cfg->sent_count++;
}

int ub_ubx_cfg_answer(ub_ubx_cfg_t *cfg, const ub_ubx_ack_t *ack) {
    if (cfg == NULL || ack == NULL || !cfg->pending || ack->cls != UB_UBX_CLASS_CFG || ack->id != UB_UBX_ID_CFG_RATE)
        return 0;
    cfg->pending = 0;
    cfg->applied = cfg->sent;
    if (ack->ok) {
        cfg->acked++;
        cfg->acked_meas_rate_ms = cfg->sent.meas_rate_ms;
    } else {
        cfg->naked++;
    }
    return 1;
}

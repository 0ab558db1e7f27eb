#include "ub_test_authz.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ub/ub_wire.h"
#include "ub/ub_admin_wire.h" /* admin payload layouts */

/* ---- catalogue: gpsOut, imuOut and the cells ------------------------------------------------ */

static int pack_cell(const void *obj, uint8_t *buf, size_t cap) {
    if (cap < 4) return UB_ERR_NOSPACE;
    ub_put_u32le(buf, *(const uint32_t *)obj);
    return 4;
}

static int unpack_cell(void *obj, const uint8_t *buf, size_t len) {
    if (len < 4) return UB_ERR_TRUNCATED;
    *(uint32_t *)obj = ub_get_u32le(buf);
    return 4;
}

static const ub_type_desc_t cell_type = {"struct test_cell", 0x0CE11C0Du, 4, sizeof(uint32_t), pack_cell, unpack_cell};

/* Built once per test program (the catalogue must be sorted by ID); read-only afterwards. */
static char cell_names[AUTHZ_CELLS][8];
static ub_instance_desc_t instances[2 + AUTHZ_CELLS];

static int by_id(const void *x, const void *y) {
    return memcmp(((const ub_instance_desc_t *)x)->id, ((const ub_instance_desc_t *)y)->id, UB_DIR_ID_LEN);
}

static void build_catalogue(ub_catalogue_t *cat) {
    if (instances[0].type == NULL) {
        instances[0] = (ub_instance_desc_t){.name = "gpsOut", .type = &ub_test_cat.types[0]};
        instances[1] = (ub_instance_desc_t){.name = "imuOut", .type = &ub_test_cat.types[1]};
        for (int i = 0; i < AUTHZ_CELLS; i++) {
            (void)snprintf(cell_names[i], sizeof cell_names[i], "cell%02d", i);
            instances[2 + i] = (ub_instance_desc_t){.name = cell_names[i], .type = &cell_type};
        }
        for (size_t i = 0; i < 2 + AUTHZ_CELLS; i++) ub_dir_id_paper(instances[i].name, instances[i].id);
        qsort(instances, 2 + AUTHZ_CELLS, sizeof instances[0], by_id);
    }
    *cat = (ub_catalogue_t){"authz", UB_ID_SCHEME_PAPER, UB_CATALOGUE_ABI_VERSION, NULL, 0,
                            instances, 2 + AUTHZ_CELLS, 28, NULL, 0};
}

uint32_t authz_instance(const authz_t *a, const char *name) {
    int idx = ub_catalogue_find_name(&a->cat, name);
    assert_true(idx >= 0);
    return (uint32_t)idx;
}

/* ---- the rogue's radio: counts what veh1 sends it ---------------------------------------------- */

static int rogue_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    rogue_t *r = impl;
    ub_frame_header_t h;
    assert_int_equal(ub_frame_parse(frame, len, &h), UB_OK);
    r->frames++;
    r->bytes += len;
    const uint8_t *payload = frame + UB_FRAME_HEADER_LEN;
    if (h.admin == UB_ADMIN_DATA) {
        r->data++;
        r->last_data_ms = now_ms;
    } else if (h.admin == UB_ADMIN_ACK) {
        r->acks++;
    } else if (h.admin == UB_ADMIN_NACK) {
        r->nacks[payload[UB_PL_REPLY_DETAIL] & 7u]++;
    }
    return UB_OK;
}

static const ub_link_ops_t rogue_ops = {.kind = "rogue", .send = rogue_send, .fileno = NULL};

/* ---- the world --------------------------------------------------------------------------------- */

static int add(ub_node_t *n, const char *name, bool local) {
    int e = ub_node_add_entity_name(n, name, local);
    assert_true(e >= 0);
    return e;
}

static void mask(ub_node_t *n, int from, const char *to, uint8_t bits) {
    uint8_t id[UB_ENTITY_ID_LEN];
    test_eid(to, id);
    assert_int_equal(ub_node_set_mask(n, from, ub_node_find_entity(n, id), bits), UB_OK);
}

void authz_init(authz_t *a, uint64_t seed) {
    memset(a, 0, sizeof *a);
    build_catalogue(&a->cat);
    ub_node_options_t opt = {.random_seed = seed};
    a->gcs = world_node(&a->w, &a->cat, &opt);
    opt.random_seed = seed + 1;
    a->veh = world_node(&a->w, &a->cat, &opt);
    opt.random_seed = seed + 2;
    a->obs = world_node(&a->w, &a->cat, &opt);
    static const char *const names[] = {"gcs1", "veh1", "obs1", "mallory"};
    ub_node_t *nodes[] = {a->gcs, a->veh, a->obs};
    int *own[] = {&a->e_gcs, &a->e_veh, &a->e_obs};
    for (int n = 0; n < 3; n++) {
        for (int e = 0; e < 4; e++) {
            int idx = add(nodes[n], names[e], e == n);
            if (e == n) *own[n] = idx;
        }
    }
    a->gcs_link = ub_node_add_link(a->gcs, a->e_gcs, 0, "gcsToVeh");
    a->obs_link = ub_node_add_link(a->obs, a->e_obs, 0, "obsToVeh");
    a->veh_link_gcs = ub_node_add_link(a->veh, a->e_veh, 0, "vehToGcs");
    a->veh_link_obs = ub_node_add_link(a->veh, a->e_veh, 1, "vehToObs");
    a->veh_link_rogue = ub_node_add_link(a->veh, a->e_veh, 2, "vehRadio");
    mask(a->gcs, a->e_gcs, "veh1", 0x1);
    mask(a->gcs, a->e_gcs, "obs1", 0x1);
    mask(a->gcs, a->e_gcs, "mallory", 0x1);
    mask(a->obs, a->e_obs, "veh1", 0x1);
    mask(a->obs, a->e_obs, "gcs1", 0x1);
    mask(a->veh, a->e_veh, "gcs1", 0x1);
    mask(a->veh, a->e_veh, "obs1", 0x2);
    mask(a->veh, a->e_veh, "mallory", 0x4);
    (void)world_connect(&a->w, a->gcs, a->gcs_link, a->veh, a->veh_link_gcs, NULL, seed);
    (void)world_connect(&a->w, a->obs, a->obs_link, a->veh, a->veh_link_obs, NULL, seed + 7);
    assert_int_equal(ub_node_link_attach(a->veh, a->veh_link_rogue, &rogue_ops, &a->rogue), UB_OK);

    uint32_t gps = authz_instance(a, "gpsOut"), imu = authz_instance(a, "imuOut");
    a->veh_gps = (struct test_gps){33.78, -84.40, 300.0f, 3};
    assert_int_equal(ub_node_bind(a->veh, gps, &a->veh_gps), UB_OK);
    assert_int_equal(ub_node_bind(a->veh, imu, &a->veh_imu), UB_OK);
    assert_int_equal(ub_node_bind(a->gcs, gps, &a->gcs_gps), UB_OK);
    assert_int_equal(ub_node_bind(a->gcs, imu, &a->gcs_imu), UB_OK);
    assert_int_equal(ub_node_bind(a->obs, gps, &a->obs_gps), UB_OK);
    assert_int_equal(ub_node_bind(a->obs, imu, &a->obs_imu), UB_OK);
    char name[8];
    for (int i = 0; i < AUTHZ_CELLS; i++) {
        (void)snprintf(name, sizeof name, "cell%02d", i);
        uint32_t inst = authz_instance(a, name);
        a->veh_cells[i] = 1000u + (uint32_t)i;
        assert_int_equal(ub_node_bind(a->veh, inst, &a->veh_cells[i]), UB_OK);
        assert_int_equal(ub_node_bind(a->gcs, inst, &a->gcs_cells[i]), UB_OK);
        assert_int_equal(ub_node_bind(a->obs, inst, &a->obs_cells[i]), UB_OK);
    }
    ub_node_set_deliver_hook(a->gcs, delivery_log_hook, &a->gcs_log);
    ub_node_set_deliver_hook(a->obs, delivery_log_hook, &a->obs_log);
    assert_int_equal(ub_admin_init(&a->admin, a->gcs, a->e_gcs, NULL), UB_OK);

    ub_policy_init(&a->policy);
    uint8_t id[UB_ENTITY_ID_LEN];
    test_eid("gcs1", id);
    assert_int_equal(ub_policy_add_admin(&a->policy, id), UB_OK);
    for (int n = 0; n < 3; n++) ub_node_set_policy(nodes[n], &a->policy);
    a->seq = 5000;
}

authz_t *authz_new(uint64_t seed) {
    authz_t *a = calloc(1, sizeof *a);
    assert_non_null(a);
    authz_init(a, seed);
    return a;
}

/* ---- forging ----------------------------------------------------------------------------------- */

void authz_forge(authz_t *a, ub_node_t *node, int link, ub_admin_code_t code, uint32_t instance, const char *src,
                 const char *dest, const uint8_t *payload, uint16_t len) {
    uint8_t frame[UB_FRAME_MAX];
    const ub_instance_desc_t *inst = &a->cat.instances[instance];
    bool reply = code == UB_ADMIN_ACK || code == UB_ADMIN_NACK;
    size_t n = make_frame(frame, code, inst->id, src, dest, a->seq++, 8, reply ? 0 : inst->type->fingerprint,
                          payload, len);
    assert_int_equal(ub_node_rx_frame(node, link, frame, n, a->w.now_ms), UB_OK);
}

void authz_request(authz_t *a, ub_admin_code_t code, uint32_t instance, const char *src, const char *peer,
                   uint32_t period_ms, uint32_t lease_ms, uint32_t request_id) {
    uint8_t p[UB_PL_REQUEST_LEN];
    ub_put_u32le(p + UB_PL_REQUEST_ID, request_id);
    ub_put_u32le(p + UB_PL_REQUEST_PERIOD, period_ms);
    ub_put_u32le(p + UB_PL_REQUEST_LEASE, lease_ms);
    test_eid(peer, p + UB_PL_REQUEST_PEER);
    authz_forge(a, a->veh, a->veh_link_rogue, code, instance, src, "veh1", p, sizeof p);
}

void authz_stop(authz_t *a, ub_admin_code_t code, uint32_t instance, const char *src, const char *peer,
                uint32_t request_id) {
    uint8_t p[UB_PL_STOP_LEN];
    ub_put_u32le(p + UB_PL_STOP_ID, request_id);
    test_eid(peer, p + UB_PL_STOP_PEER);
    authz_forge(a, a->veh, a->veh_link_rogue, code, instance, src, "veh1", p, sizeof p);
}

void authz_reply(authz_t *a, bool nack, uint32_t instance, const char *src, const char *dest, uint32_t request_id,
                 ub_admin_code_t answered, uint8_t detail) {
    uint8_t p[UB_PL_REPLY_LEN] = {0};
    ub_put_u32le(p + UB_PL_REPLY_ID, request_id);
    p[UB_PL_REPLY_CODE] = (uint8_t)answered;
    p[UB_PL_REPLY_DETAIL] = detail;
    bool to_gcs = strcmp(dest, "gcs1") == 0;
    authz_forge(a, to_gcs ? a->gcs : a->obs, to_gcs ? a->gcs_link : a->obs_link, nack ? UB_ADMIN_NACK : UB_ADMIN_ACK,
                instance, src, dest, p, sizeof p);
}

void authz_data_to(authz_t *a, ub_node_t *node, int link, const char *dest, uint32_t instance, const char *src,
                   const uint8_t *bytes) {
    uint8_t frame[UB_FRAME_MAX];
    const ub_instance_desc_t *inst = &a->cat.instances[instance];
    size_t n = make_frame(frame, UB_ADMIN_DATA, inst->id, src, dest, a->seq++, 8, inst->type->fingerprint, bytes,
                          (uint16_t)inst->type->packed_size);
    assert_int_equal(ub_node_rx_frame(node, link, frame, n, a->w.now_ms), UB_OK);
}

void authz_data(authz_t *a, uint32_t instance, const char *src, const uint8_t *bytes) {
    authz_data_to(a, a->veh, a->veh_link_rogue, "veh1", instance, src, bytes);
}

int authz_rows_owned(const authz_t *a, const char *owner) {
    uint8_t id[UB_ENTITY_ID_LEN];
    test_eid(owner, id);
    int n = 0;
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        const ub_ps_row_t *row = ub_pubsub_row(a->veh, a->e_veh, r);
        n += row->kind != UB_PS_FREE && memcmp(row->owner, id, UB_ENTITY_ID_LEN) == 0;
    }
    return n;
}

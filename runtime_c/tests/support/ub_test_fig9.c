#include "ub_test_fig9.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "ub/ub_link.h"
#include "ub/ub_node.h"

/* Table 1, verbatim: rows = entities, columns = linktoentity[0..3]. */
const char *const table1_masks[4][4] = {
    {"0x00000000", "0x00000001", "0x00000001", "0x00000110"},
    {"0x00000001", "0x00000000", "0x00000010", "0x00000001"},
    {"0x00000001", "0x00000001", "0x00000000", "0x00000001"},
    {"0x00000011", "0x00000011", "0x00000011", "0x00000000"},
};
const char *const table1_links[4][3] = {
    {"e0Toe1", "e0Toe3a", "e0Toe3b"},
    {"e1Toe0", "e1Toe2", NULL},
    {"e2Toe1", NULL, NULL},
    {"e3Toe0a", "e3Toe0b", NULL},
};

static int link_of(const fig9_t *f, int entity, int index) {
    return ub_node_find_link(f->node[entity], table1_links[entity][index]);
}

void fig9_init(fig9_t *f, world_t *w, const ub_memlink_faults_t *faults, uint64_t seed) {
    memset(f, 0, sizeof *f);
    memset(w, 0, sizeof *w);
    f->w = w;
    ub_node_t *a = world_node(f->w, &ub_test_cat, NULL);
    ub_node_t *b = world_node(f->w, &ub_test_cat, NULL);
    ub_node_t *c = world_node(f->w, &ub_test_cat, NULL);
    ub_node_t *host[4] = {a, a, b, c};
    for (int e = 0; e < 4; e++) {
        char name[8] = "entity0";
        name[6] = (char)('0' + e);
        test_eid(name, f->id[e]);
        f->node[e] = host[e];
    }
    /* Every node lists all four entities in the paper's order; its own ones are local. */
    ub_node_t *nodes[3] = {a, b, c};
    for (int n = 0; n < 3; n++) {
        for (int e = 0; e < 4; e++) {
            int idx = ub_node_add_entity(nodes[n], f->id[e], host[e] == nodes[n]);
            assert_int_equal(idx, e);
            if (host[e] == nodes[n]) f->ent[e] = idx;
        }
    }
    for (int e = 0; e < 4; e++) {
        for (unsigned i = 0; i < 3 && table1_links[e][i] != NULL; i++)
            assert_true(ub_node_add_link(f->node[e], f->ent[e], i, table1_links[e][i]) >= 0);
        for (int d = 0; d < 4; d++) {
            uint8_t mask;
            assert_int_equal(ub_link_mask_parse(table1_masks[e][d], &mask), UB_OK);
            assert_int_equal(ub_node_set_mask(f->node[e], f->ent[e], d, mask), UB_OK);
        }
    }
    /* Figure 9's wires. */
    world_connect(f->w, a, link_of(f, 0, 0), a, link_of(f, 1, 0), faults, seed + 1);
    world_connect(f->w, a, link_of(f, 1, 1), b, link_of(f, 2, 0), faults, seed + 2);
    world_connect(f->w, a, link_of(f, 0, 1), c, link_of(f, 3, 0), faults, seed + 3);
    world_connect(f->w, a, link_of(f, 0, 2), c, link_of(f, 3, 1), faults, seed + 4);

    f->imu_src = (struct test_imu){{1.0f, 2.0f, 3.0f}, {0.25f, 0.5f, 0.75f}, 4242};
    assert_int_equal(ub_node_bind(c, TEST_IMU, &f->imu_src), UB_OK);
    assert_int_equal(ub_node_bind(b, TEST_IMU, &f->imu_dst), UB_OK);
    ub_node_set_deliver_hook(b, delivery_log_hook, &f->log);
    assert_int_equal(ub_admin_init(&f->admin, a, f->ent[1], NULL), UB_OK);
}

fig9_t *fig9_build(const ub_memlink_faults_t *faults, uint64_t seed) {
    fig9_t *f = calloc(1, sizeof *f);
    assert_non_null(f);
    fig9_init(f, world_new(), faults, seed);
    return f;
}

void fig9_free(fig9_t *f) {
    free(f->w);
    free(f);
}

ub_admin_row_info_t fig9_row_info(const fig9_t *f, int row) {
    ub_admin_row_info_t info;
    assert_int_equal(ub_admin_row_status(&f->admin, row, &info), UB_OK);
    return info;
}

/* Runs 1 ms steps until the row is acknowledged (or active); returns the time of the ACK. */
uint64_t fig9_run_until_acked(fig9_t *f, int row, uint64_t limit_ms) {
    while (f->w->now_ms < limit_ms) {
        world_run(f->w, f->w->now_ms + 1, 1);
        ub_admin_row_info_t info = fig9_row_info(f, row);
        if (info.status == UB_ADMIN_ACKNOWLEDGED || info.status == UB_ADMIN_ACTIVE) return info.acked_at_ms;
    }
    fail_msg("row %d not acknowledged by %llu ms", row, (unsigned long long)limit_ms);
    return 0;
}

uint64_t fig9_first_delivery_after(const fig9_t *f, uint64_t t_ms) {
    for (size_t i = 0; i < f->log.n; i++)
        if (f->log.d[i].at_ms >= t_ms) return f->log.d[i].at_ms;
    return UINT64_MAX;
}

int fig9_admin_row(fig9_t *f, ub_admin_row_type_t type) {
    ub_admin_row_spec_t spec = {.instance = TEST_IMU, .period_ms = PERIOD_MS, .type = type};
    memcpy(spec.source, f->id[3], UB_ENTITY_ID_LEN);
    memcpy(spec.destination, f->id[2], UB_ENTITY_ID_LEN);
    int row = ub_admin_add_row(&f->admin, &spec);
    assert_true(row >= 0);
    assert_int_equal(fig9_row_info(f, row).status, UB_ADMIN_INACTIVE);
    assert_int_equal(ub_admin_set_active(&f->admin, row, true, f->w->now_ms), UB_OK);
    return row;
}

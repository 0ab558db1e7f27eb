/*
 * The paper's Table 1 / Figure 9 system, built over memlinks (shared by
 * test_table1 and test_faults):
 *
 *   node A: Entity 0 (e0Toe1, e0Toe3a, e0Toe3b) + Entity 1 (e1Toe0, e1Toe2), admin table on Entity 1
 *   node B: Entity 2 (e2Toe1)
 *   node C: Entity 3 (e3Toe0a, e3Toe0b)
 *
 * The link masks are the paper's hex strings, parsed with ub_link_mask_parse().
 * Entities 0 and 1 share node A; their e0Toe1/e1Toe0 link is a memlink from
 * node A to itself. Entity 3 hosts imuOut; Entity 2 binds storage for it.
 */
#ifndef UB_TEST_FIG9_H
#define UB_TEST_FIG9_H

#include "ub_test_world.h"
#include "ub/ub_admin.h"

#define PERIOD_MS 100u

extern const char *const table1_masks[4][4];
extern const char *const table1_links[4][3];

typedef struct fig9 {
    world_t *w;
    ub_node_t *node[4]; /* node hosting entity i (A, A, B, C) */
    int ent[4];         /* entity i's index in its hosting node's table */
    uint8_t id[4][UB_ENTITY_ID_LEN];
    ub_admin_t admin;
    struct test_imu imu_src; /* Entity 3's directory */
    struct test_imu imu_dst; /* where Entity 2 receives it */
    delivery_log_t log;      /* deliveries at node B */
} fig9_t;

/* Builds the system into caller memory without allocating (`w` is zeroed first). */
void fig9_init(fig9_t *f, world_t *w, const ub_memlink_faults_t *faults, uint64_t seed);
/* Builds the system in calloc'ed memory; every memlink gets `faults` (NULL = none) and a seed derived from `seed`. */
fig9_t *fig9_build(const ub_memlink_faults_t *faults, uint64_t seed);
void fig9_free(fig9_t *f);

/* Adds an admin row (imuOut from Entity 3 to Entity 2 at PERIOD_MS) of `type` and activates it now. */
int fig9_admin_row(fig9_t *f, ub_admin_row_type_t type);

ub_admin_row_info_t fig9_row_info(const fig9_t *f, int row);

/* Runs 1 ms steps until the row is acknowledged or active; returns the time of its first ACK. Fails at `limit_ms`. */
uint64_t fig9_run_until_acked(fig9_t *f, int row, uint64_t limit_ms);

/* Time of the first delivery at node B at or after `t_ms`, or UINT64_MAX. */
uint64_t fig9_first_delivery_after(const fig9_t *f, uint64_t t_ms);

#endif /* UB_TEST_FIG9_H */

/*
 * Test support for the router tests (test_node, test_router, test_pubsub, ...):
 *
 *  - three hand-written catalogues in the shape `uavbus gen` emits:
 *      ub_test_cat          gpsOut (struct test_gps), imuOut (struct test_imu)
 *      ub_test_cat_newer    the same plus newMsg, which older builds do not know
 *      ub_test_cat_changed  gpsOut built from a changed struct (test_gps_v2:
 *                           altitude became a double -> other fingerprint and size)
 *  - a "world": several nodes and memlinks in one process, stepped on a
 *    simulated clock (tick every node, then pump every memlink until quiet).
 *
 * Memlinks are large (2 x UB_MEMLINK_DEPTH frames), so worlds are allocated by
 * the test with calloc (test code may allocate; the library may not).
 */
#ifndef UB_TEST_WORLD_H
#define UB_TEST_WORLD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub/ub_catalogue.h"
#include "ub/ub_memlink.h"
#include "ub/ub_node.h"

/* Instance indexes (the catalogues are sorted by ID: gpsOut < imuOut < newMsg). */
#define TEST_GPS 0u
#define TEST_IMU 1u
#define TEST_NEW 2u /* only in ub_test_cat_newer */

struct test_gps {
    double lat;
    double lon;
    float alt;
    uint32_t fix;
};

/* The "changed definition" of gpsOut: one field changed type. */
struct test_gps_v2 {
    double lat;
    double lon;
    double alt;
    uint32_t fix;
};

struct test_imu {
    float acc[3];
    float gyro[3];
    uint32_t t_ms;
};

struct test_new {
    uint32_t a;
    uint32_t b;
};

extern const ub_catalogue_t ub_test_cat;
extern const ub_catalogue_t ub_test_cat_newer;
extern const ub_catalogue_t ub_test_cat_changed;

/* ub_entity_id() that cannot fail for the test names. */
void test_eid(const char *name, uint8_t out[UB_ENTITY_ID_LEN]);

#define WORLD_MAX_NODES 10
#define WORLD_MAX_LINKS 16

typedef struct world {
    ub_node_t nodes[WORLD_MAX_NODES];
    size_t n_nodes;
    ub_memlink_t links[WORLD_MAX_LINKS];
    size_t n_links;
    uint64_t now_ms;
} world_t;

/* calloc'ed, zeroed world; free() it. */
world_t *world_new(void);

/* Initialises the next node; returns it. Asserts on failure. */
ub_node_t *world_node(world_t *w, const ub_catalogue_t *cat, const ub_node_options_t *opt);

/* Joins link slot `la` of `a` and `lb` of `b` with the next memlink. Returns it. */
ub_memlink_t *world_connect(world_t *w, ub_node_t *a, int la, ub_node_t *b, int lb,
                            const ub_memlink_faults_t *faults, uint64_t seed);

/* Advances the clock to `until_ms` in `step_ms` steps: at each step every node ticks, then every
 * memlink is pumped until none delivers (frames relayed over several hops arrive in one step). */
void world_run(world_t *w, uint64_t until_ms, uint64_t step_ms);

/* Delivery recorder: counts DATA deliveries per (entity, instance) and each sequence number seen. */
#define REC_MAX 4096
typedef struct delivery_log {
    size_t n;
    struct {
        int entity;
        uint32_t instance;
        uint32_t seq;
        uint8_t src[UB_ENTITY_ID_LEN];
        uint64_t at_ms;
    } d[REC_MAX];
} delivery_log_t;

void delivery_log_hook(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms);

/* Deliveries of `instance` to `entity` with at_ms in [from, to). */
size_t delivery_count(const delivery_log_t *log, int entity, uint32_t instance, uint64_t from_ms, uint64_t to_ms);

/* Number of (entity, instance, src, seq) keys recorded more than once. */
size_t delivery_repeats(const delivery_log_t *log);

/* A transport that records what the node sends (or refuses it with `rc` when rc < 0). */
#define CAPTURE_MAX 32
typedef struct capture {
    int rc;
    size_t n;
    size_t len[CAPTURE_MAX];
    uint8_t frame[CAPTURE_MAX][UB_FRAME_MAX];
} capture_t;

extern const ub_link_ops_t capture_ops;

/* Builds a verified frame into `out` (UB_FRAME_MAX bytes) and returns its length. */
size_t make_frame(uint8_t *out, ub_admin_code_t admin, const uint8_t dir_id[UB_DIR_ID_LEN], const char *src,
                  const char *dest, uint32_t seq, uint8_t hop_limit, uint32_t fingerprint, const uint8_t *payload,
                  uint16_t payload_len);

/* A started security context with key 1 = `key` that signs, counters from `wall`, attached to `node` (if not
 * NULL), which then requires signed frames when `require`. */
struct ub_sec;
void test_sec_on(struct ub_sec *sec, ub_node_t *node, const uint8_t key[32], uint64_t wall, bool require);

#endif /* UB_TEST_WORLD_H */

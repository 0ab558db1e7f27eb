/*
 * A world for the authorization tests (test_authz, test_noalloc): three nodes on memlinks and a rogue.
 *
 *   gcs1 (node gcs, administrator, admin table) --link0-- veh1 (node veh, the source) --link1-- obs1 (node obs)
 *                                                          |
 *                                                          link2: the rogue's radio. Frames veh1 sends there
 *                                                          land in `rogue` (counted); frames the rogue forges
 *                                                          are handed to veh1 as received on that link.
 *
 * mallory is an entity every node knows (veh1 routes to it over link2) and no policy lists as administrator:
 * it claims nothing it is not. The catalogue holds gpsOut and imuOut (the router tests' types) plus
 * AUTHZ_CELLS small "cellNN" directories, so one requester can ask for more rows than a table holds.
 * veh1 binds everything; gcs1 and obs1 bind what they receive. The policy (administrators: gcs1) is
 * attached to all three nodes unless the test detaches it.
 */
#ifndef UB_TEST_AUTHZ_H
#define UB_TEST_AUTHZ_H

#include "ub_test_world.h"
#include "ub/ub_admin.h"
#include "ub/ub_policy.h"

#define AUTHZ_CELLS 40

/* What veh1 sent to the rogue, by kind. */
typedef struct rogue {
    uint64_t frames, bytes, data;
    uint64_t acks;
    uint64_t nacks[8];     /* by NACK reason */
    uint64_t last_data_ms; /* when veh1 last sent the rogue DATA */
} rogue_t;

typedef struct authz {
    world_t w; /* first: worlds are large and this struct is calloc'ed (or given by the caller) */
    ub_catalogue_t cat;
    ub_node_t *gcs, *veh, *obs;
    int e_gcs, e_veh, e_obs;          /* each local entity's index in its own node */
    int gcs_link, obs_link;           /* their single link, toward veh1 */
    int veh_link_gcs, veh_link_obs, veh_link_rogue;
    ub_admin_t admin;                 /* on gcs1 */
    ub_policy_t policy;
    rogue_t rogue;
    uint32_t seq;                     /* next sequence number of forged frames */
    uint32_t veh_cells[AUTHZ_CELLS], gcs_cells[AUTHZ_CELLS], obs_cells[AUTHZ_CELLS];
    struct test_gps veh_gps, gcs_gps, obs_gps;
    struct test_imu veh_imu, gcs_imu, obs_imu;
    delivery_log_t gcs_log, obs_log;
} authz_t;

/* Builds the world into caller memory, zeroed first, without allocating. `seed` seeds the request ids. */
void authz_init(authz_t *a, uint64_t seed);
authz_t *authz_new(uint64_t seed); /* calloc'ed; free() it */

/* Catalogue instance index of `name` ("gpsOut", "imuOut", "cell07"). */
uint32_t authz_instance(const authz_t *a, const char *name);

/* Forges one admin frame from `src` to `dest` and hands it to `node` as received on `link`. */
void authz_forge(authz_t *a, ub_node_t *node, int link, ub_admin_code_t code, uint32_t instance, const char *src,
                 const char *dest, const uint8_t *payload, uint16_t len);
/* PUB_REQUEST / SUB_REQUEST from `src` to veh1 over the rogue's link. */
void authz_request(authz_t *a, ub_admin_code_t code, uint32_t instance, const char *src, const char *peer,
                   uint32_t period_ms, uint32_t lease_ms, uint32_t request_id);
/* PUB_STOP / SUB_STOP from `src` to veh1 over the rogue's link. */
void authz_stop(authz_t *a, ub_admin_code_t code, uint32_t instance, const char *src, const char *peer,
                uint32_t request_id);
/* ACK/NACK from `src` to `dest` (gcs1 or obs1), handed to the node of `dest` as received on its link. */
void authz_reply(authz_t *a, bool nack, uint32_t instance, const char *src, const char *dest, uint32_t request_id,
                 ub_admin_code_t answered, uint8_t detail);
/* DATA of `instance` (payload `bytes`, its packed size) from `src` to veh1 over the rogue's link. */
void authz_data(authz_t *a, uint32_t instance, const char *src, const uint8_t *bytes);

/* The same, to `dest` hosted by `node`, as received on its `link`. */
void authz_data_to(authz_t *a, ub_node_t *node, int link, const char *dest, uint32_t instance, const char *src,
                   const uint8_t *bytes);

/* Rows in veh1's table owned by `owner` (created by its remote requests). */
int authz_rows_owned(const authz_t *a, const char *owner);

#endif /* UB_TEST_AUTHZ_H */

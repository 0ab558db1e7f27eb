/*
 * The fleet features of uavbus_node (issue #12, docs/routing.md): automatic
 * routes (--route), membership at run time (stdin: entity / link / mask /
 * member / announce), a simulated vehicle's flight path (--produce,
 * --motion, --epoch-ms) and per-flow delivery reports (--flows-ms, `flows`).
 * uavbus_node.c calls these hooks; everything here goes through the runtime's
 * public API (ub_route.h, ub_member.h, ub_motion.h) and the program shell (ub_app.h).
 */
#ifndef NODE_FLEET_H
#define NODE_FLEET_H

#include <stdbool.h>
#include <stdint.h>

#include "node_motion.h"
#include "ub_app.h"
#include "ub/ub_node.h"
#include "ub/ub_ports.h"

/* Usage lines for --help. */
extern const char fleet_usage[];

/* Command-line option `opt` with its value `val` (argv[argi]): true if it is one of ours. Exits with a
 * `uavbus_node:argv[i]: ...` message on a bad value. */
bool fleet_option(ub_app_t *app, const char *opt, const char *val, int argi);

/* Who produces directory `name` here: with --produce ENTITY, ENTITY for gpsOut, imuOut and navFilterState
 * (a simulated vehicle); otherwise `dflt`. */
const char *fleet_producer(const char *name, const char *dflt);

/* CLOCK_MONOTONIC ms at which the flight path starts: --epoch-ms, else `start_ms`. */
uint64_t fleet_epoch_ms(uint64_t start_ms);

/* Once the node is configured and its directories bound: the motion path, the routing engine, the
 * membership requester with its link handler (over the app's ports). Exits on a bad option value. */
void fleet_setup(ub_app_t *app, node_motion_t *motion, uint64_t now_ms);

/* A stdin command whose first word is `verb` (`save` continues strtok_r over the line): true if it was
 * ours (answered with an event). */
bool fleet_command(const char *verb, char **save, uint64_t now_ms);

/* Every loop turn: answers of membership requests, periodic flows events. */
void fleet_poll(uint64_t now_ms);
/* When fleet_poll() next has a timer due (the flows event); UINT64_MAX: none. */
uint64_t fleet_next_due(uint64_t now_ms);

/* Writes `,"routing":{...}` (the learned-entity bounds: learned, learn_full, learn_expired) into the stats
 * event while automatic routes run; nothing otherwise. */
void fleet_stats(ub_app_t *app);

/* Every DATA delivery (the node's delivery hook). */
void fleet_on_deliver(int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms);

#endif /* NODE_FLEET_H */

/*
 * Fleet bench, in process (bench figure 8, issue 12): N vehicles and 2 ground stations, one node each, with
 * automatic routes (ub_route) over memlinks whose connectivity follows a range model, on a simulated clock
 * (1 ms steps: every node whose next due time (ub_node_next_due()) has come ticks, then the memlinks that may hold
 * a frame are pumped until quiet, and a node that received frames is due again -- as uavbus_node sleeps until its
 * next due time or input). FLEET_BENCH_END_S=S stops the run after S simulated seconds (a scale check: 1000 vehicles).
 *
 *   fleet_bench N [HELLO_MS] [SEED] [LOSS_PPM]    -> one "fleet_inproc n=N key=value ..." line on stdout
 *
 * Layout: vehicles on a grid 500 m apart, each flying a 20 m orbit; radio range 650 m, so grid neighbours are
 * in range and diagonals are not (the orbits never cross the boundary); gcs1 350 m west of the grid's middle
 * row, gcs2 350 m east of it. A link (memlink) exists for every pair within range at t = 0; the range model
 * is evaluated every 100 ms. Every vehicle publishes its state (benchGpsRawInt, 10 Hz, phases staggered) to
 * the ground station of its half of the grid. Each node is told only itself and its ground station; routes
 * and every other entity are learned. Hop limit 32 (the grid's diameter exceeds the default 8).
 *
 * Phases (simulated time): warm-up 15 s; quiet 20 s (no injected event): delivery where a path exists,
 * routing frames per link end per second, CPU; failures 60 s: every 6 s an up link that carries at least one
 * vehicle's data and whose loss leaves that vehicle a path is cut (restored 4 s later, so each failure is
 * measured alone). For every vehicle
 * whose path crossed it: route reconvergence = until its path (following the masks hop by hop) reaches its
 * ground station again, data reconvergence = until its ground station receives its data again.
 * CPU: process CPU time spent in the nodes and memlinks (ub_node_tick + pumps), per vehicle per simulated
 * second; the harness (range model, BFS, path walks) is measured apart.
 *
 * Build (bench/run.sh): every runtime source and this file with -DUB_MAX_ENTITIES=128 -DUB_DEDUP_SOURCES=128
 * -DUB_MAX_LOCAL_ENTITIES=1 (a fleet of 102 entities does not fit the default 16); 1000 vehicles: 1024.
 */
#define _GNU_SOURCE
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "benchcat.h"
#include "ub/ub_memlink.h"
#include "ub/ub_motion.h"
#include "ub/ub_node.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_route.h"

benchBlob64_t benchBlob64, benchBlob64Echo;
benchAttitude_t benchAttitude;
benchGpsRawInt_t benchGpsRawInt;
benchHighresImu_t benchHighresImu;

#define SPACING_M 500.0
#define RANGE_M 650.0
#define GCS_OFFSET_M 350.0
#define PERIOD_MS 100u
#define WARMUP_MS 15000u
#define QUIET_MS 20000u
#define FAIL_MS 60000u
#define DRAIN_MS 6000u
#define FAIL_EVERY_MS 6000u   /* one failure at a time: each is measured alone */
#define RESTORE_AFTER_MS 4000u
#define SAMPLE_GIVEUP_MS 15000u
#define MAX_SAMPLES 4096
#define MAX_LINKS 8

typedef struct station {
    ub_node_t node;
    ub_route_t rt;
    int self;
    int gcs;                 /* vehicles: 0 or 1, the ground station they publish to; -1 for a ground station */
    int dest_cache[2];       /* entity index of gcs1 / gcs2 in this node's table, -1 until learned */
    uint8_t id[UB_ENTITY_ID_LEN];
    ub_motion_t motion;
    benchGpsRawInt_t state;
    int n_links;
    int link_pair[MAX_LINKS];
    int link_id[MAX_LINKS];
    uint64_t delivered_quiet, expected_quiet, delivered_fail, expected_fail;
} station_t;

typedef struct pair {
    int a, b;          /* station indexes */
    int ia, ib;        /* link[i] at each end */
    bool in_range, failed, dark;
    uint64_t restore_at;
    ub_memlink_t ml;
} pair_t;

typedef struct sample {
    int v, pair;
    int up;            /* the station on the vehicle's side of the failed link (it must notice the loss) */
    uint64_t t0;
    int64_t detect_ms; /* until `up` stopped routing the vehicle's data into the failed link */
    int64_t route_ms, data_ms;
} sample_t;

static station_t *st;
static pair_t *pairs;
/* Pairs whose memlink may hold a frame: set when a node at either end ran (a tick, or frames it received, may
 * send), cleared once a pump leaves the link empty. Pumping only these, in pair order within each round, calls
 * exactly the pumps that can deliver (a pump of an empty memlink does nothing), without touching all of them
 * every millisecond: at 1,000 vehicles that scan was a quarter of the measured node CPU (perf). */
static uint64_t *busy;

static void mark_station(int k) {
    for (int i = 0; i < st[k].n_links; i++) {
        int p = st[k].link_pair[i];
        busy[p / 64] |= 1ull << (p % 64);
    }
}
static int n_st, n_pairs, n_veh;
static sample_t samples[MAX_SAMPLES];
static int n_samples;
static uint64_t now_ms;
static uint64_t rng = 0x9E3779B97F4A7C15ull;

static uint64_t rnd(void) {
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return rng;
}

static void die(const char *what, int rc) {
    fprintf(stderr, "fleet_bench: %s: %s\n", what, ub_strerror(rc));
    exit(2);
}
#define CHECK(x)                    \
    do {                            \
        int rc_ = (x);              \
        if (rc_ < 0) die(#x, rc_);  \
    } while (0)

static double cpu_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static double wall_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static double dist(int a, int b, double t_s) {
    ub_motion_state_t x, y;
    ub_motion_sample(&st[a].motion, t_s, &x);
    ub_motion_sample(&st[b].motion, t_s, &y);
    return ub_motion_distance(&x, &y);
}

static bool pair_up(const pair_t *p) { return p->in_range && !p->failed; }

static void apply(pair_t *p, uint32_t loss_ppm) {
    bool dark = !pair_up(p);
    ub_memlink_faults_t f = {.loss_ppm = dark ? 1000000u : loss_ppm};
    ub_memlink_set_faults(&p->ml, &f);
    p->dark = dark;
}

/* ---- the fleet ------------------------------------------------------------------------------------- */

static int gcs_entity(station_t *s, int g) {
    if (s->dest_cache[g] < 0) s->dest_cache[g] = ub_node_find_entity(&s->node, st[g].id);
    return s->dest_cache[g];
}

/* Follows the masks from vehicle v toward its ground station. Returns true when it gets there; *crosses is
 * set when the walk used pair `p`. */
static bool walk(int v, int p, bool *crosses) {
    int x = v, g = st[v].gcs;
    if (crosses) *crosses = false;
    for (int steps = 0; steps < 64; steps++) {
        if (x == g) return true;
        station_t *s = &st[x];
        int d = gcs_entity(s, g);
        uint8_t mask = 0;
        if (d < 0 || ub_node_get_mask(&s->node, s->self, d, &mask) != UB_OK || mask == 0) return false;
        int i = __builtin_ctz(mask);
        if (i >= s->n_links) return false;
        const pair_t *q = &pairs[s->link_pair[i]];
        if (crosses && s->link_pair[i] == p) *crosses = true;
        if (!pair_up(q)) return false;
        x = q->a == x ? q->b : q->a;
    }
    return false; /* a loop (never seen: the feasibility condition forbids them) */
}

/* Ground stations reachable from each station over up links: comp[x] = bit g set if gcs g is reachable. */
static void components(uint8_t *comp, int skip_pair) {
    static int queue[4096];
    memset(comp, 0, (size_t)n_st);
    for (int g = 0; g < 2; g++) {
        int head = 0, tail = 0;
        queue[tail++] = g;
        comp[g] |= (uint8_t)(1u << g);
        while (head < tail) {
            int x = queue[head++];
            for (int i = 0; i < st[x].n_links; i++) {
                int pi = st[x].link_pair[i];
                const pair_t *q = &pairs[pi];
                if (pi == skip_pair || !pair_up(q)) continue;
                int y = q->a == x ? q->b : q->a;
                if (comp[y] & (1u << g)) continue;
                comp[y] |= (uint8_t)(1u << g);
                queue[tail++] = y;
            }
        }
    }
}

static void on_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t t) {
    (void)entity, (void)instance;
    intptr_t g = (intptr_t)user;
    const char *name = (const char *)h->src_id;
    if (name[0] != 'v') return;
    int v = 2 + atoi(name + 1);
    if (v < 2 || v >= n_st || st[v].gcs != g) return;
    if (t >= WARMUP_MS && t < WARMUP_MS + QUIET_MS) st[v].delivered_quiet++;
    else if (t >= WARMUP_MS + QUIET_MS && t < WARMUP_MS + QUIET_MS + FAIL_MS) st[v].delivered_fail++;
    for (int k = 0; k < n_samples; k++)
        if (samples[k].v == v && samples[k].data_ms < 0 && t > samples[k].t0) samples[k].data_ms = (int64_t)(t - samples[k].t0);
}

static void build(int n, uint32_t hello_ms, uint32_t loss_ppm) {
    n_veh = n;
    n_st = n + 2;
    st = calloc((size_t)n_st, sizeof *st);
    if (st == NULL) die("calloc", UB_ERR_NOSPACE);
    int cols = (int)ceil(sqrt((double)n)), rows = (n + cols - 1) / cols;
    double mid = (rows - 1) * SPACING_M / 2.0;
    char text[160], err[128], name[16];
    for (int k = 0; k < n_st; k++) {
        station_t *s = &st[k];
        ub_node_options_t opt = {.hop_limit = 32, .random_seed = 1000u + (uint64_t)k};
        CHECK(ub_node_init(&s->node, &benchcat_catalogue, &opt));
        if (k < 2) {
            snprintf(name, sizeof name, "gcs%d", k + 1);
            snprintf(text, sizeof text, "static:n=%.1f,e=%.1f", mid,
                     k == 0 ? -GCS_OFFSET_M : (cols - 1) * SPACING_M + GCS_OFFSET_M);
            s->gcs = -1;
        } else {
            int v = k - 2, r = v / cols, c = v % cols;
            snprintf(name, sizeof name, "v%d", v);
            snprintf(text, sizeof text, "orbit:r=20,v=5,n=%.1f,e=%.1f,phase=%d", r * SPACING_M, c * SPACING_M,
                     (v * 37) % 360);
            s->gcs = c < (cols + 1) / 2 ? 0 : 1;
        }
        if (ub_motion_parse(text, &s->motion, err, sizeof err) != UB_OK) die(err, UB_ERR_INVAL);
        CHECK(ub_entity_id(name, s->id));
        CHECK(s->self = ub_node_add_entity(&s->node, s->id, true));
        s->dest_cache[0] = s->dest_cache[1] = -1;
    }
    /* Links: every pair within range at t = 0 (the grid's neighbours), nearest first up to 8 per station. */
    pairs = calloc((size_t)n_st * MAX_LINKS / 2 + 8, sizeof *pairs);
    if (pairs == NULL) die("calloc", UB_ERR_NOSPACE);
    for (int a = 0; a < n_st; a++) {
        for (int b = a + 1; b < n_st; b++) {
            if (dist(a, b, 0.0) > RANGE_M || st[a].n_links == MAX_LINKS || st[b].n_links == MAX_LINKS) continue;
            pair_t *p = &pairs[n_pairs];
            p->a = a;
            p->b = b;
            p->ia = st[a].n_links;
            p->ib = st[b].n_links;
            char ln[24];
            snprintf(ln, sizeof ln, "l%d", p->ia);
            int la = ub_node_add_link(&st[a].node, st[a].self, (unsigned)p->ia, ln);
            snprintf(ln, sizeof ln, "l%d", p->ib);
            int lb = ub_node_add_link(&st[b].node, st[b].self, (unsigned)p->ib, ln);
            CHECK(la);
            CHECK(lb);
            st[a].link_id[st[a].n_links] = la;
            st[b].link_id[st[b].n_links] = lb;
            st[a].link_pair[st[a].n_links++] = n_pairs;
            st[b].link_pair[st[b].n_links++] = n_pairs;
            ub_memlink_init(&p->ml, NULL, 77u + (uint64_t)n_pairs);
            CHECK(ub_memlink_connect(&p->ml, &st[a].node, la, &st[b].node, lb));
            p->in_range = true;
            apply(p, loss_ppm);
            n_pairs++;
        }
    }
    ub_route_options_t ro = {.hello_ms = hello_ms};
    for (int k = 0; k < n_st; k++) {
        station_t *s = &st[k];
        CHECK(ub_route_attach(&s->rt, &s->node, &ro, 0));
        if (k < 2) {
            ub_node_set_deliver_hook(&s->node, on_deliver, (void *)(intptr_t)k);
            CHECK(ub_node_bind(&s->node, benchcat_INST_benchGpsRawInt, &s->state));
        } else {
            CHECK(ub_node_add_entity(&s->node, st[s->gcs].id, false)); /* the operator's knowledge */
            CHECK(ub_node_bind(&s->node, benchcat_INST_benchGpsRawInt, &s->state));
            CHECK(ub_pubsub_publish(&s->node, s->self, benchcat_INST_benchGpsRawInt, st[s->gcs].id, PERIOD_MS,
                                    (uint64_t)((k * 37) % PERIOD_MS)));
        }
    }
}

static int cmp_i64(const void *a, const void *b) {
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return x < y ? -1 : x > y;
}

static int64_t pct(int64_t *v, int n, double q) {
    if (n == 0) return -1;
    qsort(v, (size_t)n, sizeof *v, cmp_i64);
    int k = (int)ceil(q * n) - 1;
    return v[k < 0 ? 0 : k >= n ? n - 1 : k];
}

/* Routing frames sent so far; `fast`: only the fast hellos (liveness on links carrying traffic, the price of
 * noticing a cut from a gap). */
static uint64_t routing_frames_of(bool fast) {
    uint64_t n = 0;
    for (int k = 0; k < n_st; k++)
        for (int i = 0; i < st[k].n_links; i++) {
            ub_route_link_info_t li;
            if (ub_route_link_info(&st[k].rt, st[k].link_id[i], &li) == UB_OK)
                n += fast ? li.stats.fast_hellos_out : li.stats.frames_out;
        }
    return n;
}
static uint64_t routing_frames(void) { return routing_frames_of(false); }

/* The station whose next hop toward v's ground station is over pair p (on v's current path). */
static int upstream(int v, int p) {
    int x = v, g = st[v].gcs;
    for (int steps = 0; steps < 64 && x != g; steps++) {
        station_t *s = &st[x];
        int d = gcs_entity(s, g);
        uint8_t mask = 0;
        if (d < 0 || ub_node_get_mask(&s->node, s->self, d, &mask) != UB_OK || mask == 0) break;
        int i = __builtin_ctz(mask);
        if (s->link_pair[i] == p) return x;
        const pair_t *q = &pairs[s->link_pair[i]];
        x = q->a == x ? q->b : q->a;
    }
    return -1;
}

/* Whether station x still sends toward gcs g over pair p. */
static bool routes_over(int x, int g, int p) {
    station_t *s = &st[x];
    int d = gcs_entity(s, g);
    uint8_t mask = 0;
    if (d < 0 || ub_node_get_mask(&s->node, s->self, d, &mask) != UB_OK) return false;
    for (int i = 0; i < s->n_links; i++)
        if ((mask & (1u << i)) && s->link_pair[i] == p) return true;
    return false;
}

static bool fail_one(uint8_t *comp) {
    /* Up links that carry some vehicle's data and whose loss leaves it a path. Tried in random order. */
    int start = (int)(rnd() % (uint64_t)n_pairs);
    for (int k = 0; k < n_pairs; k++) {
        int p = (start + k) % n_pairs;
        if (!pair_up(&pairs[p]) || pairs[p].a < 2 || pairs[p].b < 2) continue; /* ground station links: no detour */
        components(comp, p);
        int before = n_samples;
        for (int v = 2; v < n_st && n_samples < MAX_SAMPLES; v++) {
            bool crosses = false;
            if (!walk(v, p, &crosses) || !crosses || !(comp[v] & (1u << st[v].gcs))) continue;
            samples[n_samples++] = (sample_t){v, p, upstream(v, p), now_ms, -1, -1, -1};
        }
        if (n_samples > before) {
            pairs[p].failed = true;
            pairs[p].restore_at = now_ms + RESTORE_AFTER_MS;
            return true;
        }
    }
    return false;
}

int main(int argc, char **argv) {
    int n = argc > 1 ? atoi(argv[1]) : 10;
    uint32_t hello_ms = argc > 2 ? (uint32_t)atoi(argv[2]) : 1000u;
    rng ^= argc > 3 ? (uint64_t)atoll(argv[3]) * 0x2545F4914F6CDD1Dull : 0;
    uint32_t loss_ppm = argc > 4 ? (uint32_t)atoi(argv[4]) : 0;
    if (n < 2 || n > UB_MAX_ENTITIES - 8) {
        fprintf(stderr, "fleet_bench: N must be 2..%d (UB_MAX_ENTITIES %d)\n", UB_MAX_ENTITIES - 8, UB_MAX_ENTITIES);
        return 2;
    }
    double t_build = wall_s();
    build(n, hello_ms, loss_ppm);
    uint8_t *comp = calloc((size_t)n_st, 1);
    busy = calloc((size_t)n_pairs / 64 + 1, sizeof *busy);
    if (comp == NULL || busy == NULL) die("calloc", UB_ERR_NOSPACE);
    uint64_t end = WARMUP_MS + QUIET_MS + FAIL_MS + DRAIN_MS;
    const char *end_s = getenv("FLEET_BENCH_END_S");
    if (end_s != NULL && atoi(end_s) > 0 && (uint64_t)atoi(end_s) * 1000u < end) end = (uint64_t)atoi(end_s) * 1000u;
    /* A run cut short (FLEET_BENCH_END_S) ends its quiet window with it: the rates below are per second of the
     * window that ran, not of the 20 s a full run has (a 16 s scale run read 0 routing frames per second). */
    uint64_t quiet_end = WARMUP_MS + QUIET_MS < end ? WARMUP_MS + QUIET_MS : end;
    double quiet_s = quiet_end > WARMUP_MS ? (double)(quiet_end - WARMUP_MS) / 1000.0 : 0.0;
    uint64_t *due = calloc((size_t)n_st, sizeof *due);
    uint64_t ticks = 0;
    if (due == NULL) die("calloc", UB_ERR_NOSPACE);
    double node_cpu = 0, node_cpu_quiet = 0, harness_cpu = 0, wall0 = wall_s();
    uint64_t frames_q0 = 0, frames_q1 = 0, fast_q0 = 0, fast_q1 = 0, next_fail = WARMUP_MS + QUIET_MS;
    int failures = 0, range_changes = 0;
    for (now_ms = 1; now_ms <= end; now_ms++) {
        double c0 = cpu_s();
        for (int k = 0; k < n_st; k++) {
            if (now_ms < due[k]) continue;
            ub_node_tick(&st[k].node, now_ms);
            mark_station(k);
            due[k] = ub_node_next_due(&st[k].node, now_ms);
            if (due[k] <= now_ms) due[k] = now_ms + 1u; /* handled what it could at now_ms: the next step */
            ticks++;
        }
        for (int round = 0; round < 64; round++) {
            size_t moved = 0;
            /* The word is read again after each pump: a pair marked further on is pumped in this round, one marked
             * before the current position in the next, as the scan of every pair did. */
            for (int p = 0; p < n_pairs; p++) {
                uint64_t word = busy[p / 64] >> (p % 64);
                if (word == 0) {
                    p = (p / 64 + 1) * 64 - 1; /* nothing further in this word */
                    continue;
                }
                if (!(word & 1u)) {
                    p += __builtin_ctzll(word) - 1;
                    continue;
                }
                size_t m = ub_memlink_pump(&pairs[p].ml, now_ms);
                if (ub_memlink_pending(&pairs[p].ml) == 0) busy[p / 64] &= ~(1ull << (p % 64));
                if (m == 0) continue;
                mark_station(pairs[p].a);
                mark_station(pairs[p].b);
                /* Frames arrived at one end or both: each is due at once (its services look at what came). */
                for (int end_k = 0; end_k < 2; end_k++) {
                    int k = end_k == 0 ? pairs[p].a : pairs[p].b;
                    uint64_t d = ub_node_next_due(&st[k].node, now_ms);
                    if (d < due[k]) due[k] = d <= now_ms ? now_ms + 1u : d;
                }
                moved += m;
            }
            if (moved == 0) break;
        }
        double c1 = cpu_s();
        node_cpu += c1 - c0;
        if (now_ms > WARMUP_MS && now_ms <= quiet_end) node_cpu_quiet += c1 - c0;
        if (now_ms == WARMUP_MS) frames_q0 = routing_frames(), fast_q0 = routing_frames_of(true);
        if (now_ms == quiet_end) frames_q1 = routing_frames(), fast_q1 = routing_frames_of(true);
        if (now_ms % 100 == 0) {
            /* Range model, restorations, and what the data could reach this period. */
            double t_s = now_ms / 1000.0;
            for (int p = 0; p < n_pairs; p++) {
                pair_t *q = &pairs[p];
                bool in = dist(q->a, q->b, t_s) <= RANGE_M;
                if (q->failed && now_ms >= q->restore_at) q->failed = false;
                if (in != q->in_range) range_changes += now_ms > WARMUP_MS;
                q->in_range = in;
                if (q->dark != !pair_up(q)) apply(q, loss_ppm);
            }
            components(comp, -1);
            for (int v = 2; v < n_st; v++) {
                bool path = comp[v] & (1u << st[v].gcs);
                if (now_ms > WARMUP_MS && now_ms <= WARMUP_MS + QUIET_MS) st[v].expected_quiet += path;
                else if (now_ms > WARMUP_MS + QUIET_MS && now_ms <= WARMUP_MS + QUIET_MS + FAIL_MS)
                    st[v].expected_fail += path;
            }
        }
        if (now_ms == next_fail && now_ms < WARMUP_MS + QUIET_MS + FAIL_MS) {
            failures += fail_one(comp);
            for (int p = 0; p < n_pairs; p++)
                if (pairs[p].dark != !pair_up(&pairs[p])) apply(&pairs[p], loss_ppm);
            next_fail += FAIL_EVERY_MS;
        }
        for (int k = 0; k < n_samples; k++) {
            sample_t *s = &samples[k];
            if (s->route_ms < 0 && now_ms > s->t0 && walk(s->v, -1, NULL)) s->route_ms = (int64_t)(now_ms - s->t0);
            if (s->detect_ms < 0 && s->up >= 0 && now_ms > s->t0 && !routes_over(s->up, st[s->v].gcs, s->pair))
                s->detect_ms = (int64_t)(now_ms - s->t0);
        }
        harness_cpu += cpu_s() - c1;
    }
    double wall = wall_s() - wall0;
    /* Figures. */
    int64_t *route = calloc((size_t)n_samples + 1, sizeof *route), *data = calloc((size_t)n_samples + 1, sizeof *data);
    int64_t *detect = calloc((size_t)n_samples + 1, sizeof *detect), *after = calloc((size_t)n_samples + 1, sizeof *after);
    int nr = 0, nd = 0, ne = 0, na = 0, unrecovered = 0;
    const char *dump = getenv("FLEET_BENCH_SAMPLES");
    for (int k = 0; k < n_samples; k++) {
        if (dump != NULL)
            fprintf(stderr, "sample v%d pair %d-%d up %d t0 %llu detect %lld route %lld data %lld\n", samples[k].v - 2,
                    pairs[samples[k].pair].a, pairs[samples[k].pair].b, samples[k].up,
                    (unsigned long long)samples[k].t0, (long long)samples[k].detect_ms, (long long)samples[k].route_ms,
                    (long long)samples[k].data_ms);
        if (samples[k].detect_ms >= 0) detect[ne++] = samples[k].detect_ms;
        if (samples[k].detect_ms >= 0 && samples[k].route_ms >= samples[k].detect_ms)
            after[na++] = samples[k].route_ms - samples[k].detect_ms;
        if (samples[k].route_ms >= 0 && samples[k].route_ms < SAMPLE_GIVEUP_MS) route[nr++] = samples[k].route_ms;
        if (samples[k].data_ms >= 0 && samples[k].data_ms < SAMPLE_GIVEUP_MS) data[nd++] = samples[k].data_ms;
        else unrecovered++;
    }
    uint64_t dq = 0, eq = 0, df = 0, ef = 0;
    for (int v = 2; v < n_st; v++) {
        dq += st[v].delivered_quiet;
        eq += st[v].expected_quiet;
        df += st[v].delivered_fail;
        ef += st[v].expected_fail;
    }
    uint64_t drops[UB_DROP_REASON_COUNT] = {0}, learn_full = 0;
    for (int k = 0; k < n_st; k++) {
        for (int r = 0; r < UB_DROP_REASON_COUNT; r++) drops[r] += ub_node_counters(&st[k].node)->drops[r];
        learn_full += ub_route_counters(&st[k].rt)->learn_full;
    }
    int link_ends = 2 * n_pairs;
    double sim_s = end / 1000.0;
    free(due);
    int64_t r50 = pct(route, nr, 0.5), r99 = pct(route, nr, 0.99), d50 = pct(data, nd, 0.5), d99 = pct(data, nd, 0.99);
    int64_t e50 = pct(detect, ne, 0.5), e99 = pct(detect, ne, 0.99), a50 = pct(after, na, 0.5), a99 = pct(after, na, 0.99);
    printf("fleet_inproc n=%d gcs=2 hello_ms=%u loss_ppm=%u links=%d sim_s=%.0f wall_s=%.2f build_s=%.2f "
           "realtime_factor=%.1f failures=%d samples=%d unrecovered=%d range_changes=%d "
           "route_p50_ms=%lld route_p99_ms=%lld data_p50_ms=%lld data_p99_ms=%lld detect_p50_ms=%lld detect_p99_ms=%lld "
           "after_detect_p50_ms=%lld after_detect_p99_ms=%lld "
           "delivery_quiet=%.5f delivery_failures=%.5f frames_per_link_end_s=%.3f fast_hellos_per_link_end_s=%.3f "
           "cpu_ms_per_vehicle_s=%.4f cpu_ms_per_vehicle_s_quiet=%.4f harness_cpu_s=%.2f "
           "no_route=%llu hop_limit=%llu backpressure=%llu duplicate=%llu learn_full=%llu node_bytes=%zu "
           "ticks_per_node_s=%.1f\n",
           n, hello_ms, loss_ppm, n_pairs, sim_s, wall, wall0 - t_build, sim_s / wall, failures, n_samples,
           unrecovered, range_changes, (long long)r50, (long long)r99, (long long)d50, (long long)d99, (long long)e50,
           (long long)e99, (long long)a50, (long long)a99,
           eq ? (double)dq / (double)eq : 0.0, ef ? (double)df / (double)ef : 0.0,
           quiet_s > 0 ? (double)(frames_q1 - frames_q0) / (link_ends * quiet_s) : 0.0,
           quiet_s > 0 ? (double)(fast_q1 - fast_q0) / (link_ends * quiet_s) : 0.0, /* 0: the run ended in its warm-up */
           1000.0 * node_cpu / sim_s / n_st, quiet_s > 0 ? 1000.0 * node_cpu_quiet / quiet_s / n_st : 0.0, harness_cpu,
           (unsigned long long)drops[UB_DROP_NO_ROUTE], (unsigned long long)drops[UB_DROP_HOP_LIMIT],
           (unsigned long long)drops[UB_DROP_BACKPRESSURE], (unsigned long long)drops[UB_DROP_DUPLICATE],
           (unsigned long long)learn_full, sizeof(station_t), (double)ticks / n_st / sim_s);
    return 0;
}

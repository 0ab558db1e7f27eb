/*
 * Router in-process (bench figure 2): nodes in a line joined by memlinks, N0 -> N1 -> ... -> Nh,
 * one entity per node; N0 originates benchBlob64 DATA (128-byte frames) to the entity on Nh, the
 * nodes between forward (verify + dedup + hop rewrite + send). h = 1 or 3 hops.
 *
 *   router_hops HOPS   -> "hops=H msgs_per_s=... p50_ns=... p99_ns=..." for SAMPLES samples
 *
 * Throughput: originate a batch of 32 frames, pump every memlink in order; delivered frames per
 * second at the last node over ~50 ms per sample. Latency: one frame at a time, from just before
 * ub_node_send_data() to the last node's deliver hook (CLOCK_MONOTONIC), p50/p99 over 20,000.
 * Also counts allocations: malloc/calloc/realloc are interposed and must stay at 0 after init.
 *
 *   router_hops HOPS callgrind   -> under valgrind --tool=callgrind: CALLGRIND_BATCHES batches of 32 (the
 *                                   throughput loop without its clock) between CALLGRIND_ZERO_STATS and
 *                                   CALLGRIND_DUMP_STATS_AT("router/hopsH"); Ir per message = the dump's
 *                                   total / (CALLGRIND_BATCHES * 32), every one delivered (checked).
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <valgrind/callgrind.h>

#include "benchcat.h"
#include "ub/ub_memlink.h"
#include "ub/ub_node.h"

benchBlob64_t benchBlob64, benchBlob64Echo;
benchAttitude_t benchAttitude;
benchGpsRawInt_t benchGpsRawInt;
benchHighresImu_t benchHighresImu;

/* ---- allocation counter: any malloc after init is a failure of the no-malloc claim ---- */
static unsigned long allocations;
extern void *__libc_malloc(size_t);
extern void *__libc_calloc(size_t, size_t);
extern void *__libc_realloc(void *, size_t);
void *malloc(size_t n) {
    allocations++;
    return __libc_malloc(n);
}
void *calloc(size_t a, size_t b) {
    allocations++;
    return __libc_calloc(a, b);
}
void *realloc(void *p, size_t n) {
    allocations++;
    return __libc_realloc(p, n);
}

#define MAX_HOPS 3
#define SAMPLES 7
#define LAT_N 20000
#define CALLGRIND_BATCHES 2000

static ub_node_t nodes[MAX_HOPS + 1];
static ub_memlink_t links[MAX_HOPS];
static int self_ent[MAX_HOPS + 1], dst_ent[MAX_HOPS + 1];
static uint64_t delivered, last_latency_ns;
static uint64_t lat[LAT_N];

static uint64_t now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}
static void fail(const char *what, int rc) {
    fprintf(stderr, "router_hops: %s: %s\n", what, ub_strerror(rc));
    exit(2);
}
#define CHECK(x)                      \
    do {                              \
        int rc_ = (x);                \
        if (rc_ < 0) fail(#x, rc_);   \
    } while (0)

static void on_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now) {
    (void)user, (void)entity, (void)instance, (void)h, (void)now;
    delivered++;
    last_latency_ns = now_ns() - benchBlob64.t_ns;
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv) {
    int hops = argc > 1 ? atoi(argv[1]) : 1;
    if (hops < 1 || hops > MAX_HOPS) return 2;
    char name[16];
    for (int i = 0; i <= hops; i++) {
        CHECK(ub_node_init(&nodes[i], &benchcat_catalogue, NULL));
        snprintf(name, sizeof name, "n%d", i);
        CHECK(self_ent[i] = ub_node_add_entity_name(&nodes[i], name, true));
        if (i < hops) {
            snprintf(name, sizeof name, "n%d", hops);
            CHECK(dst_ent[i] = ub_node_add_entity_name(&nodes[i], name, false));
        }
        if (i > 0) CHECK(ub_node_add_link(&nodes[i], self_ent[i], 0, "back"));
        if (i < hops) {
            int l = ub_node_add_link(&nodes[i], self_ent[i], 1, "fwd");
            CHECK(l);
            CHECK(ub_node_set_mask(&nodes[i], self_ent[i], dst_ent[i], 0x02));
        }
    }
    for (int i = 0; i < hops; i++) {
        ub_memlink_init(&links[i], NULL, (uint64_t)i);
        CHECK(ub_memlink_connect(&links[i], &nodes[i], ub_node_find_link(&nodes[i], "fwd"), &nodes[i + 1],
                                 ub_node_find_link(&nodes[i + 1], "back")));
    }
    /* One storage for both ends: the last node unpacks into what the first packs from, which is fine
     * here (same process, same value) and lets the deliver hook read the send time. */
    CHECK(ub_node_bind(&nodes[0], benchcat_INST_benchBlob64, &benchBlob64));
    CHECK(ub_node_bind(&nodes[hops], benchcat_INST_benchBlob64, &benchBlob64));
    ub_node_set_deliver_hook(&nodes[hops], on_deliver, NULL);
    const uint8_t *dest = ub_node_entity_id(&nodes[0], dst_ent[0]);
    uint64_t ms = 1;
    unsigned long runtime_allocs = 0; /* counted around the runtime calls only (printf and qsort may allocate) */

    if (argc > 2 && strcmp(argv[2], "callgrind") == 0) {
        for (int warm = 0; warm < 2; warm++) { /* warm: first-call effects out of the count */
            char name[32];
            snprintf(name, sizeof name, "router/hops%d", hops);
            uint64_t d0 = delivered;
            int batches = warm == 0 ? 10 : CALLGRIND_BATCHES;
            if (warm) CALLGRIND_ZERO_STATS;
            for (int k = 0; k < batches; k++) {
                for (int b = 0; b < 32; b++) {
                    benchBlob64.seq++;
                    if (ub_node_send_data(&nodes[0], self_ent[0], benchcat_INST_benchBlob64, dest, ms) != 1)
                        fail("send refused", UB_ERR_AGAIN);
                }
                for (int i = 0; i < hops; i++) (void)ub_memlink_pump(&links[i], ms);
            }
            if (warm) CALLGRIND_DUMP_STATS_AT(name);
            if (delivered - d0 != (uint64_t)batches * 32) fail("frames not delivered", UB_ERR_NOROUTE);
        }
        printf("callgrind hops=%d messages=%d\n", hops, CALLGRIND_BATCHES * 32);
        return 0;
    }
    for (int s = 0; s < SAMPLES; s++) {
        unsigned long a0 = allocations;
        uint64_t d0 = delivered, t0 = now_ns(), t1;
        do {
            for (int b = 0; b < 32; b++) {
                benchBlob64.seq++;
                if (ub_node_send_data(&nodes[0], self_ent[0], benchcat_INST_benchBlob64, dest, ms) != 1)
                    fail("send refused", UB_ERR_AGAIN);
            }
            for (int i = 0; i < hops; i++) (void)ub_memlink_pump(&links[i], ms);
            t1 = now_ns();
        } while (t1 - t0 < 50000000u);
        runtime_allocs += allocations - a0;
        printf("throughput hops=%d msgs_per_s=%.0f\n", hops, (double)(delivered - d0) / ((t1 - t0) / 1e9));
        a0 = allocations;
        for (int k = 0; k < LAT_N; k++) {
            uint64_t before = delivered;
            benchBlob64.seq++;
            benchBlob64.t_ns = now_ns();
            if (ub_node_send_data(&nodes[0], self_ent[0], benchcat_INST_benchBlob64, dest, ms) != 1)
                fail("send refused", UB_ERR_AGAIN);
            for (int i = 0; i < hops; i++) (void)ub_memlink_pump(&links[i], ms);
            if (delivered != before + 1) fail("frame not delivered", UB_ERR_NOROUTE);
            lat[k] = last_latency_ns;
        }
        runtime_allocs += allocations - a0;
        qsort(lat, LAT_N, sizeof lat[0], cmp_u64);
        printf("latency hops=%d p50_ns=%llu p99_ns=%llu\n", hops, (unsigned long long)lat[LAT_N / 2],
               (unsigned long long)lat[LAT_N * 99 / 100]);
    }
    printf("allocations hops=%d after_init=%lu delivered=%llu\n", hops, runtime_allocs,
           (unsigned long long)delivered);
    return 0;
}

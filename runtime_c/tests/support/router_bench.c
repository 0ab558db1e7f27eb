/*
 * Router cost measurement (a program, not a test): context sizes and the cost per frame of
 * forwarding, delivering and originating a 92-byte frame (28-byte imuOut payload) through
 * ub_node_rx_frame()/ub_node_send_data() with a do-nothing transport. Built by tests/router.cmake
 * at -O2 as ub_router_bench:  cmake --build <dir> --target ub_router_bench && <dir>/runtime_c/ub_router_bench
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <cmocka.h>
#include "support/ub_test_world.h"
#include "ub/ub_admin.h"

static int sink_send(void *impl, const uint8_t *f, size_t n, uint64_t t) { (void)impl; (void)f; (void)n; (void)t; return 0; }
static const ub_link_ops_t sink_ops = {.kind = "sink", .send = sink_send, .fileno = NULL};
static double now_s(void) { struct timespec ts; clock_gettime(CLOCK_MONOTONIC, &ts); return ts.tv_sec + ts.tv_nsec * 1e-9; }

int main(void) {
    static ub_node_t n;
    printf("sizeof ub_node_t %zu, ub_memlink_t %zu, ub_admin_t %zu, ub_link_t %zu\n", sizeof(ub_node_t), sizeof(ub_memlink_t), sizeof(ub_admin_t), sizeof(ub_link_t));
    if (ub_node_init(&n, &ub_test_cat, NULL)) return 1;
    int self = ub_node_add_entity_name(&n, "fwd", true);
    int far = ub_node_add_entity_name(&n, "far", false);
    int l0 = ub_node_add_link(&n, self, 0, "l0"), l1 = ub_node_add_link(&n, self, 1, "l1");
    if (ub_node_link_attach(&n, l0, &sink_ops, NULL) || ub_node_link_attach(&n, l1, &sink_ops, NULL)) return 1;
    if (ub_node_set_mask(&n, self, far, 0x02)) return 1;
    struct test_imu imu; if (ub_node_bind(&n, TEST_IMU, &imu)) return 1;
    const ub_instance_desc_t *inst = &ub_test_cat.instances[TEST_IMU];
    uint8_t payload[28] = {0};
    enum { N = 2000000 };
    static uint8_t frames[64][UB_FRAME_MAX]; size_t len = 0;
    for (int kind = 0; kind < 3; kind++) {
        double t0 = now_s();
        for (uint32_t i = 1; i <= N; i++) {
            if (kind == 2) { if (ub_node_send_data(&n, self, TEST_IMU, ub_node_entity_id(&n, far), i) != 1) return 2; continue; }
            uint8_t *fr = frames[i % 64];
            /* Every frame needs a fresh sequence (or the duplicate window drops it), so it is rebuilt;
             * "frame building alone" below measures that part, to subtract. */
            len = make_frame(fr, UB_ADMIN_DATA, inst->id, "src", kind ? "fwd" : "far", i, 8, inst->type->fingerprint, payload, 28);
            if (ub_node_rx_frame(&n, l0, fr, len, i)) return 3;
        }
        double dt = now_s() - t0;
        printf("%-50s %4.0f ns/frame%s\n",
               kind == 0 ? "forward (verify+dedup+hop rewrite+send):" : kind == 1 ? "deliver (verify+dedup+unpack):"
                                                                               : "originate (pack+finish+send):",
               dt / N * 1e9, kind < 2 ? " (includes building the test frame)" : "");
    }
    const ub_node_counters_t *c = ub_node_counters(&n);
    printf("forwarded %llu delivered %llu originated %llu\n", (unsigned long long)c->forwarded, (unsigned long long)c->delivered, (unsigned long long)c->originated);
    /* cost of just building the frame, to subtract */
    double t0 = now_s();
    for (uint32_t i = 1; i <= N; i++) len = make_frame(frames[i % 64], UB_ADMIN_DATA, inst->id, "src", "far", i, 8, inst->type->fingerprint, payload, 28);
    printf("frame building alone: %.0f ns/frame\n", (now_s() - t0) / N * 1e9);
    return 0;
}

/* Two nodes over an in-memory link: the vehicle publishes attitudeOut to the GCS, which checks what
 * arrived. Exits 0 and prints one line when the value came through the generated codec intact.
 *
 * When the library carries frame security (ub_sec_available(): libsodium linked, UAVBUS_SECURITY), both nodes
 * share a key, the vehicle signs and the GCS requires signed frames (a signed network): the value must
 * arrive through a verified SIGNED frame, and the signed frame, with one byte of its tag changed, must be
 * refused (bad_tag). `consumer --require-security` fails when the library cannot sign at all. */
#include <stdio.h>
#include <string.h>

#include "telemetry.h"  /* the consumer's header */
#include "telem.h"        /* generated: telem_catalogue */
#include "ub/ub_memlink.h"
#include "ub/ub_node.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_sec.h"

attitude_t attitudeOut = {1000, 0.1f, -0.2f, 1.5f, 3};

static ub_node_t vehicle, gcs; /* large: static storage, no allocation */
static ub_memlink_t link;
static ub_sec_t vehicle_sec, gcs_sec;

/* The GCS's frame tap keeps the last frame it received (verified: the tap sees accepted frames only). */
static uint8_t last_rx[UB_FRAME_MAX];
static size_t last_rx_len;
static void keep_rx(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)user, (void)link_id, (void)now_ms;
    if (dir == UB_TAP_RX && len <= sizeof last_rx) {
        memcpy(last_rx, frame, len);
        last_rx_len = len;
    }
}

#define CHECK(call)                                                                                \
    do {                                                                                           \
        int rc_ = (call);                                                                          \
        if (rc_ < 0) {                                                                             \
            fprintf(stderr, "consumer: %s failed: %s\n", #call, ub_strerror(rc_));                 \
            return 1;                                                                              \
        }                                                                                          \
    } while (0)

int main(int argc, char **argv) {
    bool require_security = argc > 1 && strcmp(argv[1], "--require-security") == 0;
    bool secure = ub_sec_available();
    if (require_security && !secure) {
        fprintf(stderr, "consumer: this libub was built without frame security (UAVBUS_SECURITY=OFF)\n");
        return 1;
    }
    attitude_t received;
    memset(&received, 0, sizeof received);
    int inst = ub_catalogue_find_name(&telem_catalogue, "attitudeOut");
    CHECK(inst);
    CHECK(ub_node_init(&vehicle, &telem_catalogue, NULL));
    CHECK(ub_node_init(&gcs, &telem_catalogue, NULL));
    int uav = ub_node_add_entity_name(&vehicle, "uav1", true);
    int uav_gcs = ub_node_add_entity_name(&vehicle, "gcs1", false);
    int ground = ub_node_add_entity_name(&gcs, "gcs1", true);
    CHECK(ub_node_add_entity_name(&gcs, "uav1", false));
    CHECK(uav);
    CHECK(uav_gcs);
    CHECK(ground);
    int l_uav = ub_node_add_link(&vehicle, uav, 0, "radio");
    int l_gcs = ub_node_add_link(&gcs, ground, 0, "radio");
    CHECK(l_uav);
    CHECK(l_gcs);
    CHECK(ub_node_set_mask(&vehicle, uav, uav_gcs, 0x01));
    ub_memlink_init(&link, NULL, 1);
    CHECK(ub_memlink_connect(&link, &vehicle, l_uav, &gcs, l_gcs));
    CHECK(ub_node_bind(&vehicle, (uint32_t)inst, &attitudeOut));
    CHECK(ub_node_bind(&gcs, (uint32_t)inst, &received));
    if (secure) {
        static const uint8_t key[UB_SEC_KEY_LEN] = "consumer-test-key-32-bytes-long";
        CHECK(ub_sec_init(&vehicle_sec, NULL));
        CHECK(ub_sec_init(&gcs_sec, NULL));
        CHECK(ub_sec_add_key(&vehicle_sec, 1, key));
        CHECK(ub_sec_add_key(&gcs_sec, 1, key));
        CHECK(ub_sec_set_tx_key(&vehicle_sec, 1));
        CHECK(ub_sec_set_tx_key(&gcs_sec, 1));
        CHECK(ub_sec_start(&vehicle_sec, 1000, 0));
        CHECK(ub_sec_start(&gcs_sec, 1000, 0));
        CHECK(ub_node_set_security(&vehicle, &vehicle_sec));
        CHECK(ub_node_set_security(&gcs, &gcs_sec));
        CHECK(ub_node_set_require_signed(&gcs, true));
        ub_node_set_tap(&gcs, keep_rx, NULL);
    }
    uint8_t gcs_id[UB_ENTITY_ID_LEN];
    memcpy(gcs_id, ub_node_entity_id(&gcs, ground), sizeof gcs_id);
    /* Signed, the first frame of a new source is held back while the GCS challenges it (its freshness);
     * one publication per 100 ms of node time until one is delivered. */
    for (uint64_t t = 1; t <= 2000 && ub_node_counters(&gcs)->delivered == 0; t++) {
        if (t % 100 == 1) CHECK(ub_node_send_data(&vehicle, uav, (uint32_t)inst, gcs_id, 1));
        ub_node_tick(&vehicle, t);
        ub_node_tick(&gcs, t);
        (void)ub_memlink_pump(&link, t);
    }
    if (memcmp(&received, &attitudeOut, sizeof received) != 0 || ub_node_counters(&gcs)->delivered != 1) {
        fprintf(stderr, "consumer: attitudeOut did not arrive intact\n");
        return 1;
    }
    const char *how = "unsigned";
    if (secure) {
        ub_frame_header_t h;
        if (last_rx_len == 0 || ub_frame_parse(last_rx, last_rx_len, &h) != UB_OK
            || h.flags != UB_FRAME_FLAG_SIGNED || ub_sec_verify(&gcs_sec, &h, last_rx, last_rx_len, NULL, 0) != UB_OK
            || ub_sec_stats(&gcs_sec)->verified_in == 0) {
            fprintf(stderr, "consumer: the delivered frame was not a verified SIGNED frame\n");
            return 1;
        }
        last_rx[last_rx_len - 1] ^= 0x01; /* the last byte of the tag */
        if (ub_sec_verify(&gcs_sec, &h, last_rx, last_rx_len, NULL, 0) != UB_ERR_AUTH) {
            fprintf(stderr, "consumer: a frame with a changed tag was not refused\n");
            return 1;
        }
        how = "signed, verified";
    }
    printf("consumer: attitudeOut delivered %s (roll %.1f, pitch %.1f, yaw %.1f, mode %u)\n", how,
           (double)received.roll, (double)received.pitch, (double)received.yaw, (unsigned)received.mode);
    return 0;
}

/* Two nodes over an in-memory link: the vehicle publishes attitudeOut to the GCS, which checks what
 * arrived. Exits 0 and prints one line when the value came through the generated codec intact. */
#include <stdio.h>
#include <string.h>

#include "telemetry.h"  /* the consumer's header */
#include "telem.h"        /* generated: telem_catalogue */
#include "ub/ub_memlink.h"
#include "ub/ub_node.h"
#include "ub/ub_pubsub.h"

attitude_t attitudeOut = {1000, 0.1f, -0.2f, 1.5f, 3};

static ub_node_t vehicle, gcs; /* large: static storage, no allocation */
static ub_memlink_t link;

#define CHECK(call)                                                                                \
    do {                                                                                           \
        int rc_ = (call);                                                                          \
        if (rc_ < 0) {                                                                             \
            fprintf(stderr, "consumer: %s failed: %s\n", #call, ub_strerror(rc_));                 \
            return 1;                                                                              \
        }                                                                                          \
    } while (0)

int main(void) {
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
    uint8_t gcs_id[UB_ENTITY_ID_LEN];
    memcpy(gcs_id, ub_node_entity_id(&gcs, ground), sizeof gcs_id);
    CHECK(ub_node_send_data(&vehicle, uav, (uint32_t)inst, gcs_id, 1));
    (void)ub_memlink_pump(&link, 2);
    if (memcmp(&received, &attitudeOut, sizeof received) != 0 || ub_node_counters(&gcs)->delivered != 1) {
        fprintf(stderr, "consumer: attitudeOut did not arrive intact\n");
        return 1;
    }
    printf("consumer: attitudeOut delivered (roll %.1f, pitch %.1f, yaw %.1f, mode %u)\n", (double)received.roll,
           (double)received.pitch, (double)received.yaw, (unsigned)received.mode);
    return 0;
}

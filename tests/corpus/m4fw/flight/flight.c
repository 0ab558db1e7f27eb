#include "attitude.h"
#include "../drivers/imu/imu.h"

attitude_state_t attitude_state;
attitude_state_t attitude_setpoints[2];
imu_sample_t imu_latest;

/* The flight loop's own counter is file-local: not published. */
static uint32_t loop_count;

void flight_step(void) { loop_count++; attitude_state.loop_hz = (uint16_t)loop_count; }

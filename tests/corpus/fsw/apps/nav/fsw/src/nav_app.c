/* The navigation application: its telemetry, tables and private state. */
#include "common_types.h"
#include "msg_hdr.h"
#include "nav_msg.h"
#include "nav_tbl.h"
#include "nav_events.h"

/* Filter state private to this file: defined here, in no header. */
typedef struct {
    double P[3][3];
    float Q[3];
    uint32 Updates;
} NAV_FilterState_t;

NAV_HkTlm_t NAV_HkTlm;
NAV_Route_t NAV_Route;
NAV_Route_t NAV_AltRoutes[2];
NAV_EventLog_t NAV_EventLog;
NAV_FilterState_t NAV_Filter;
static NAV_HkTlm_t NAV_HkTlmShadow;
const NAV_Limit_t NAV_Limits[4] = {
    {"roll", -0.5f, 0.5f, 1},
    {"pitch", -0.4f, 0.4f, 1},
    {"yaw_rate", -1.0f, 1.0f, 1},
    {"climb", -3.0f, 5.0f, 0},
};
NAV_ProviderList_t NAV_Providers;
struct __nav_align __NavAlign;

void NAV_AppMain(void);
void NAV_AppMain(void) {
    NAV_HkTlmShadow = NAV_HkTlm;
    NAV_Filter.Updates++;
}

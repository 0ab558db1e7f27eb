/* Navigation configuration table file: built into its own table image. */
#include "common_types.h"
#include "nav_tbl.h"
#include "tbl_filedef.h"

NAV_Limit_t NAV_CfgLimits[3] = {
    {"gps_hdop", 0.0f, 2.5f, 1},
    {"imu_temp", -20.0f, 70.0f, 1},
    {"baro_rate", 0.0f, 50.0f, 0},
};

TBL_FileDef_t TBL_FileDef = {"NAV_CfgLimits", "NAV.CfgLimits", "limits", "nav_cfg.tbl", sizeof NAV_CfgLimits};

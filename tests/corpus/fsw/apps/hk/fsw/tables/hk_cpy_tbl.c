/* Housekeeping copy table file. */
#include "hk_msg.h"
#include "tbl_filedef.h"

HK_CopyEntry_t HK_CopyTable[8] = {
    {"nav_hk", 0x0801, 12, 4},
    {"nav_route", 0x0802, 16, 2},
};

TBL_FileDef_t TBL_FileDef = {"HK_CopyTable", "HK.CopyTable", "copy table", "hk_cpy.tbl", sizeof HK_CopyTable};

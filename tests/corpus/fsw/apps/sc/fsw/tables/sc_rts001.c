/* Relative-time sequence 001. */
#include "sc_tbl.h"
#include "tbl_filedef.h"

SC_RtsTbl_t SC_Rts001 = {{0x1801, 0x0000, 0x0005}};

TBL_FileDef_t TBL_FileDef = {"SC_Rts001", "SC.RTS_TBL001", "RTS 001", "sc_rts001.tbl", sizeof SC_Rts001};

/* Relative-time sequence 002. */
#include "sc_tbl.h"
#include "tbl_filedef.h"

SC_RtsTbl_t SC_Rts002 = {{0x1801, 0x0000, 0x0005}};

TBL_FileDef_t TBL_FileDef = {"SC_Rts002", "SC.RTS_TBL002", "RTS 002", "sc_rts002.tbl", sizeof SC_Rts002};

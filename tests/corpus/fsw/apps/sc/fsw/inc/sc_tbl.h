/* Stored-command tables: one relative-time sequence per table file. */
#ifndef SC_TBL_H
#define SC_TBL_H

#include "common_types.h"
#include "platform_cfg.h"

typedef struct {
    uint16 Words[SC_RTS_WORDS];
} SC_RtsTbl_t;

#endif

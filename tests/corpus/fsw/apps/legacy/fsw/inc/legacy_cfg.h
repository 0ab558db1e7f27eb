/* Left over from a previous mission: needs a header this tree no longer has. */
#ifndef LEGACY_CFG_H
#define LEGACY_CFG_H

#include "common_types.h"

typedef struct {
    legacy_word_t Mode;
    uint8 Flags;
} LEGACY_Cfg_t;

#endif

/* Includes the broken configuration header: its errors show here with the include chain. */
#ifndef LEGACY_APP_H
#define LEGACY_APP_H

#include "legacy_cfg.h"

extern LEGACY_Cfg_t LEGACY_Cfg;

#endif

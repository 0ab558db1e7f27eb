/* Navigation tables: text in rows, a GNU zero-length array, arrays of unknown bound, and names
 * Python cannot take as they are. */
#ifndef NAV_TBL_H
#define NAV_TBL_H

#include "common_types.h"

typedef struct {
    char Name[MISSION_MAX_NAME_LEN];
    float Min;
    float Max;
    uint8 Enabled;
} NAV_Limit_t;

/* A variable-length list the old GNU way: the providers follow the struct in memory. */
typedef struct {
    uint16 Count;
    uint16 Reserved;
    NAV_Limit_t Providers[0];
} NAV_ProviderList_t;

struct __nav_align {
    uint32 Word;
    uint8 lambda;
    uint8 __pad;
};

extern const NAV_Limit_t NAV_Limits[];    /* defined in nav_app.c, with its size */
extern NAV_Limit_t NAV_SpareLimits[];     /* never defined anywhere: size unknown */
extern NAV_ProviderList_t NAV_Providers;
extern struct __nav_align __NavAlign;

#endif

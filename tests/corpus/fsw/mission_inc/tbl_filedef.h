/* What a table image tool reads out of each table file: every table file defines one, always
 * under the same name (the older cFE convention), so the name is defined in many files. */
#ifndef TBL_FILEDEF_H
#define TBL_FILEDEF_H

#include "common_types.h"

typedef struct {
    char ObjectName[64];
    char TableName[40];
    char Description[32];
    char TgtFilename[20];
    uint32 ObjectSize;
} TBL_FileDef_t;

#endif

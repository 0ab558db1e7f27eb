/* Housekeeping: telemetry, a memory dump larger than one frame, a copy table with names, a union. */
#ifndef HK_MSG_H
#define HK_MSG_H

#include "common_types.h"
#include "msg_hdr.h"
#include "platform_cfg.h"

typedef struct {
    TLM_Hdr_t Hdr;
    uint16 CmdCount;
    uint8 ErrCount;
    uint8 MissingData;
    uint32 MemPoolHandle;
    int16 BoardTempC[4];
    bool Armed;
} HK_HkTlm_t;

typedef struct {
    TLM_Hdr_t Hdr;
    uint32 Address;
    uint16 Words[HK_DUMP_WORDS];
} HK_MemDump_t;

typedef struct {
    char Name[MISSION_MAX_NAME_LEN];
    uint16 MsgId;
    uint16 Offset;
    uint16 Bytes;
} HK_CopyEntry_t;

typedef union {
    uint32 Word;
    uint8 Bytes[4];
} HK_Raw_u;

extern HK_HkTlm_t HK_HkTlm;
extern HK_MemDump_t HK_MemDump;
extern HK_CopyEntry_t HK_CopyTable[8];
extern HK_Raw_u HK_Raw;

#endif

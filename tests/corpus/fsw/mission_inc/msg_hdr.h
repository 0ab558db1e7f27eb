/* Telemetry header. Not self-contained, like much cFS-era code: it expects common_types.h to be
 * included first (every user does), so parsing it on its own fails. */
#ifndef MSG_HDR_H
#define MSG_HDR_H

typedef struct {
    uint16 StreamId;
    uint16 Sequence;
    uint16 Length;
} CCSDS_PriHdr_t;

typedef struct {
    CCSDS_PriHdr_t Pri;
    CFE_TIME_SysTime_t Time;
} TLM_Hdr_t;

#endif

/**
 * @file ub_mavbridge_status.h
 * @brief The MAVLink bridge's own directory, `mavbridgeStatus`: who the autopilot is, whether it
 *        is heard, and what the bridge refused or lost (a subset of ub_mavbridge_counters_t, 32-bit,
 *        wrapping). Catalogued with the message directories, published on update once a second,
 *        so any entity can watch a bridge the way it watches telemetry (docs/bridges.md).
 */
#ifndef UB_MAVBRIDGE_STATUS_H
#define UB_MAVBRIDGE_STATUS_H

#include <stdint.h>

/** Instance name of the status directory. */
#define UB_MAVBRIDGE_STATUS_NAME "mavbridgeStatus"

struct ub_mavbridge_status {
    uint32_t uptime_ms;          /* since ub_mavbridge_init() */
    uint8_t autopilot_sysid;     /* 0 until the first autopilot HEARTBEAT (or the configured target) */
    uint8_t autopilot_compid;
    uint8_t connected;           /* 1 while the autopilot's HEARTBEAT arrives within link_timeout_ms */
    uint8_t signing;             /* 1 when MAVLink signing is on (outgoing signed, unsigned refused) */
    uint32_t messages_in;        /* MAVLink messages accepted from the autopilot */
    uint32_t messages_out;       /* MAVLink messages sent to it (heartbeats, intervals, commands) */
    uint32_t lost;               /* autopilot messages missing by MAVLink sequence number */
    uint32_t bad_crc;            /* MAVLink frames with a bad checksum or an unknown message id */
    uint32_t bad_signature;      /* refused by signing: unsigned, bad signature, replayed, too many streams */
    uint32_t other_source;       /* valid messages from another system or component: ignored */
    uint32_t commands_forwarded; /* directory writes sent to the autopilot */
    uint32_t commands_refused;   /* writes not forwarded (commands off, not a MAVLink message, send failed) */
    uint32_t intervals_granted;  /* SET_MESSAGE_INTERVAL requests the autopilot accepted */
    uint32_t intervals_refused;  /* ... it refused, or left unanswered after every retry */
    uint32_t link_lost;          /* times the autopilot's HEARTBEAT stopped */
};

/** Instance name of the frame directory. */
#define UB_MAVFRAME_NAME "mavFrame"
/** Largest MAVLink 2 frame: 10 header + 255 payload + 2 checksum + 13 signature. */
#define UB_MAVFRAME_MAX 280

/* One MAVLink frame, as its sender received it, between bridge nodes (the front door,
 * ub_mavroute.h): a DATA write of `mavFrame` into a peer bridge entity carries it across the bus
 * (signed, compact, fragmented and routed as any directory). Bytes, not chars: the catalogue's string
 * rule skips char arrays. */
struct ub_mavframe {
    uint16_t len;                   /* bytes used in `bytes` (a whole MAVLink 1 or 2 frame) */
    uint8_t bytes[UB_MAVFRAME_MAX]; /* the frame, checksum and signature included */
};

#endif /* UB_MAVBRIDGE_STATUS_H */

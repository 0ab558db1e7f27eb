/**
 * @file ub_admin_wire.h
 * @brief Byte layouts of the publish/subscribe admin payloads and of ACK/NACK (little-endian,
 *        documented byte by byte in docs/pubsub.md). One source for the engines, the tests and
 *        the vector generators. The frame header's dir_id names the content and its fingerprint
 *        field carries the content type's fingerprint on requests.
 *
 * Inspection (ub_inspect.h) and membership (ub_member.h) declare their own payloads in their headers.
 */
#ifndef UB_ADMIN_WIRE_H
#define UB_ADMIN_WIRE_H

/** Largest admin payload. */
#define UB_PL_MAX_LEN 32u
/** PUB_REQUEST / SUB_REQUEST: request_id u32, period_ms u32, lease_ms u32, peer ID[12]. */
#define UB_PL_REQUEST_LEN 24u
#define UB_PL_REQUEST_ID 0u
#define UB_PL_REQUEST_PERIOD 4u
#define UB_PL_REQUEST_LEASE 8u
#define UB_PL_REQUEST_PEER 12u
/** PUB_STOP / SUB_STOP: request_id u32, peer ID[12]. */
#define UB_PL_STOP_LEN 16u
#define UB_PL_STOP_ID 0u
#define UB_PL_STOP_PEER 4u
/** ACK / NACK: request_id u32, code u8 (the admin code answered), flags (ACK) or reason (NACK) u8, NACK origin
 *  flags u8 (UB_NACK_RELAYED; 0 in ACKs), reserved u8. */
#define UB_PL_REPLY_LEN 8u
#define UB_PL_REPLY_ID 0u
#define UB_PL_REPLY_CODE 4u
#define UB_PL_REPLY_DETAIL 5u
#define UB_PL_REPLY_FLAGS 6u

#endif /* UB_ADMIN_WIRE_H */

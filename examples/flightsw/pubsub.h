/**
 * @file pubsub.h
 * @brief Publish/subscribe structures (paper III.B): one per entity, plus the
 *        global administration table that the operator edits on gcs1.
 *
 * A publication row lives at the source entity, a subscription row at the
 * destination; each names the content by its 16-byte directory ID.
 */
#ifndef PUBSUB_H
#define PUBSUB_H

#include <stdint.h>
#include "fsw_types.h"

#define PUBSUB_ROWS 8
#define PUBSUB_ADMIN_ROWS 32

typedef enum pubsubRowType {
    PUBSUB_PUBLICATION = 0,
    PUBSUB_SUBSCRIPTION = 1
} pubsubRowType_t;

typedef enum pubsubRowStatus {
    PUBSUB_INACTIVE = 0,
    PUBSUB_PENDING = 1,
    PUBSUB_ACKNOWLEDGED = 2,
    PUBSUB_ACTIVE = 3,
    PUBSUB_FAILED = 4
} pubsubRowStatus_t;

/** One row of an entity's publication or subscription table. */
typedef struct pubsubRow {
    uint8_t uniqueDirID[16];
    uint8_t peerEntityID[12];        /* destination of a publication, source of a subscription */
    uint16_t periodMs;
    uint8_t active;
    uint8_t used;
    uint32_t lastSentMs;
    uint32_t leaseExpiresMs;
    uint32_t messagesSent;
} pubsubRow_t;

/** The publish/subscribe structure of one entity. */
typedef struct pubsubEntity {
    timeTag_t time;
    uint8_t entityID[12];
    uint32_t sequence;
    pubsubRow_t publication[PUBSUB_ROWS];
    pubsubRow_t subscription[PUBSUB_ROWS];
    uint32_t framesIn;
    uint32_t framesOut;
    uint32_t unknownContent;
} pubsubEntity_t;

/** One row of the global administration table (paper, Figure 5). */
typedef struct pubsubAdminRow {
    uint8_t uniqueDirID[16];
    uint8_t sourceID[12];
    uint8_t destinationID[12];
    float rateHz;
    pubsubRowType_t type;
    pubsubRowStatus_t status;
    uint8_t activate;                /* operator's switch */
    uint8_t retries;
    char contentName[80];            /* "gpsOut": typed by the operator, not sent */
} pubsubAdminRow_t;

extern pubsubEntity_t pubsubRmax1ob1;
extern pubsubEntity_t pubsubRmax1ob2;
extern pubsubEntity_t pubsubFcs20;
extern pubsubEntity_t pubsubGcs1;
extern pubsubAdminRow_t pubsubAdminTable[PUBSUB_ADMIN_ROWS];

#endif /* PUBSUB_H */

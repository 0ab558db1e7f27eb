/**
 * @file entities.h
 * @brief System entities: the entity table of a process (paper III.B, III.D).
 *
 * Each entry names an entity (12-byte ID: the name itself), the links this
 * process can reach it over, and the link mask towards every other entity
 * ("linktoentity", one hex digit per link: 0x00000011 = links 0 and 1).
 * systemEntity0 is the process's own primary entity.
 */
#ifndef ENTITIES_H
#define ENTITIES_H

#include <stdint.h>
#include "fsw_types.h"

#define ENTITY_MAX_LINKS 8
#define ENTITY_TABLE_SIZE 8

typedef enum entityKind {
    ENTITY_PRIMARY_FCS = 0,
    ENTITY_SECONDARY_FCS = 1,
    ENTITY_BACKUP_FCS = 2,
    ENTITY_GCS = 3,
    ENTITY_SIMULATED_VEHICLE = 4
} entityKind_t;

typedef struct systemEntity {
    char name[12];                           /* "rmax1ob1": the entity ID */
    entityKind_t kind;
    uint8_t local;                           /* hosted by this process */
    uint8_t numLinks;
    char linkName[ENTITY_MAX_LINKS][24];     /* "onboardPortDatalink1" */
    uint32_t linkToEntity[ENTITY_TABLE_SIZE];
    uint32_t lastHeardMs[ENTITY_TABLE_SIZE];
    uint32_t framesForwarded;
    uint32_t framesDropped;
    struct datalinkPort *link[ENTITY_MAX_LINKS];
} systemEntity_t;

extern systemEntity_t systemEntity0;
extern systemEntity_t systemEntity1;
extern systemEntity_t systemEntity2;
extern systemEntity_t systemEntity3;
extern systemEntity_t systemEntity4;
extern systemEntity_t systemEntity5;
extern systemEntity_t systemEntity6;
extern systemEntity_t systemEntity7;

#endif /* ENTITIES_H */

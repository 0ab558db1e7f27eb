/**
 * @file datalink.h
 * @brief Datalink ports and their statistics.
 *
 * rmax1ob1 has four ports (paper, Figure 8): onboardPortDatalink1 and 2 (the
 * wireless serial and wireless ethernet links to the GCS), onboardPortIPC
 * (ethernet to the secondary computer) and onboardPortRelay (serial to the
 * backup computer). rmax1ob2 talks over onboard2PortIPC; gcs1 has
 * gcsPortDatalink1 and 2.
 */
#ifndef DATALINK_H
#define DATALINK_H

#include <stddef.h>
#include <stdint.h>
#include "fsw_types.h"

typedef enum portKind {
    PORT_SERIAL = 0,
    PORT_UDP = 1,
    PORT_TCP = 2,
    PORT_SHARED_MEMORY = 3
} portKind_t;

struct datalinkPort;

/** Driver entry points; set when the port is opened. */
typedef struct portDriver {
    int (*open)(struct datalinkPort *port);
    int (*write)(struct datalinkPort *port, const uint8_t *data, size_t len);
    int (*read)(struct datalinkPort *port, uint8_t *data, size_t cap);
} portDriver_t;

/** Port statistics: the directory the GCS's link page shows. */
typedef struct datalinkPort {
    timeTag_t time;
    portKind_t kind;
    uint32_t baudRate;               /* serial only */
    uint16_t udpPort;                /* UDP/TCP only */
    _Bool open;
    _Bool enabled;                   /* software switch, e.g. no Datalink2 on fcs20 */
    uint64_t bytesIn;
    uint64_t bytesOut;
    uint32_t messagesIn;
    uint32_t messagesOut;
    uint32_t checksumErrors;
    uint32_t overruns;
    uint32_t messagesByType[16];     /* histogram over the datalink message types */
    float linkQualityPct;
    float roundTripMs;
    char deviceName[32];             /* "/dev/ttyS1", "192.168.1.20" */
    const portDriver_t *driver;
    void *driverState;
} datalinkPort_t;

/** One received datalink message as queued for the decoder. */
typedef struct datalinkMessage {
    timeTag_t received;
    uint16_t type;
    uint16_t size;
    uint8_t payload[];               /* allocated with the message; never a directory */
} datalinkMessage_t;

/**
 * Receive queue of a port: fixed header, then the ring storage reserved by
 * the linker script behind it. Only the header travels; the ring does not.
 */
typedef struct datalinkRxQueue {
    uint32_t head;
    uint32_t tail;
    uint32_t capacity;
    uint32_t dropped;
    datalinkMessage_t *current;
    uint8_t ring[];
} datalinkRxQueue_t;

extern datalinkPort_t onboardPortDatalink1;
extern datalinkPort_t onboardPortDatalink2;
extern datalinkPort_t onboardPortIPC;
extern datalinkPort_t onboardPortRelay;
extern datalinkPort_t onboard2PortIPC;
extern datalinkPort_t gcsPortDatalink1;
extern datalinkPort_t gcsPortDatalink2;
extern datalinkRxQueue_t datalinkRxQueue;

#endif /* DATALINK_H */

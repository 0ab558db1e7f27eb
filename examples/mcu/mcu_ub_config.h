/*
 * Capacities of the uavbus core on the flight-controller board (UB_CONFIG_FILE, ub_config.h): what a
 * real vehicle's flight computer needs, sized to fit a typical MCU's 64 KiB of RAM with room to spare.
 * Every value can still be changed on the command line (cmake -DUB_MAX_ENTITIES=24 ... adds a -D
 * before this file is read: each line here only sets what is not defined yet).
 */
#ifndef MCU_UB_CONFIG_H
#define MCU_UB_CONFIG_H

#ifndef UB_MAX_ENTITIES
#define UB_MAX_ENTITIES 16 /* the team: vehicles, ground stations, payload computers */
#endif
#ifndef UB_MAX_LINKS_PER_ENTITY
#define UB_MAX_LINKS_PER_ENTITY 4 /* UARTs a flight controller has for datalinks and companions */
#endif
#ifndef UB_MAX_NODE_LINKS
#define UB_MAX_NODE_LINKS 4
#endif
#ifndef UB_MAX_LOCAL_ENTITIES
#define UB_MAX_LOCAL_ENTITIES 1 /* the board is one entity */
#endif
#ifndef UB_MAX_PUBSUB_ROWS
#define UB_MAX_PUBSUB_ROWS 32 /* flows it publishes or subscribes to */
#endif
#ifndef UB_MAX_ADMIN_ROWS
#define UB_MAX_ADMIN_ROWS 32
#endif
#ifndef UB_MAX_BINDINGS
#define UB_MAX_BINDINGS 16 /* ub_node_bind() slots; the generated bind table hosts the rest */
#endif
#ifndef UB_DEDUP_SOURCES
#define UB_DEDUP_SOURCES 16 /* one duplicate window per entity it may hear from */
#endif

/* Frame security on the board (built with libsodium's sources, examples/mcu/sodium): the firmware installs
 * the board's random source itself, so libsodium's initialisation is not run (ub_config.h, UB_SODIUM_INIT);
 * origin authentication holds the authority's pairs of its few peers only. */
#ifndef UB_SODIUM_INIT
#define UB_SODIUM_INIT() 0
#endif
#ifndef UB_ORIGIN_PEERS
#define UB_ORIGIN_PEERS 8
#endif

#endif /* MCU_UB_CONFIG_H */

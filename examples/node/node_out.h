/*
 * uavbus_node's JSON-lines output, shared by its parts (uavbus_node.c, node_fleet.c):
 * build one event with out()/out_str()/out_entity(), then out_flush() writes it as one line.
 */
#ifndef NODE_OUT_H
#define NODE_OUT_H

#include <stddef.h>
#include <stdint.h>

#include "ub/ub_frame.h"

#if defined(__GNUC__)
#define NODE_PRINTF(a, b) __attribute__((format(printf, a, b)))
#define NODE_NORETURN __attribute__((noreturn))
#else
#define NODE_PRINTF(a, b)
#define NODE_NORETURN
#endif

/* Appends to the event being built (an overlong event becomes an error event at out_flush()). */
void out(const char *fmt, ...) NODE_PRINTF(1, 2);
/* A JSON string of at most `max` bytes of `s` (escaped). */
void out_str(const char *s, size_t max);
/* An entity ID as a JSON string (the name without its padding). */
void out_entity(const uint8_t id[UB_ENTITY_ID_LEN]);
/* Writes the event as one line and starts the next. */
void out_flush(void);
/* {"event":"error","message":...} */
void event_error(const char *msg);
/* Start-up failure: message on stderr and as an error event, exit status 2. */
void die(const char *fmt, ...) NODE_PRINTF(1, 2) NODE_NORETURN;

#endif /* NODE_OUT_H */

/**
 * @file ub_wire.h
 * @brief Little-endian wire primitives, written with shifts (never by casting
 *        structs or with htonl), so the encoding is the same on every host.
 *
 * Generated pack/unpack code and the frame codec both use these. All are
 * `static inline` and have no state. Callers bounds-check before calling.
 */
#ifndef UB_WIRE_H
#define UB_WIRE_H

#include <stdint.h>
#include <string.h>

#ifdef __cplusplus
extern "C" {
#endif

static inline void ub_put_u8(uint8_t *p, uint8_t v) { p[0] = v; }
static inline void ub_put_u16le(uint8_t *p, uint16_t v) {
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static inline void ub_put_u32le(uint8_t *p, uint32_t v) {
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}
static inline void ub_put_u64le(uint8_t *p, uint64_t v) {
    ub_put_u32le(p, (uint32_t)v);
    ub_put_u32le(p + 4, (uint32_t)(v >> 32));
}
static inline uint8_t ub_get_u8(const uint8_t *p) { return p[0]; }
static inline uint16_t ub_get_u16le(const uint8_t *p) {
    return (uint16_t)(p[0] | ((uint16_t)p[1] << 8));
}
static inline uint32_t ub_get_u32le(const uint8_t *p) {
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static inline uint64_t ub_get_u64le(const uint8_t *p) {
    return (uint64_t)ub_get_u32le(p) | ((uint64_t)ub_get_u32le(p + 4) << 32);
}
/* IEEE-754 floats travel as their bit patterns; memcpy is the defined way to get them. */
static inline void ub_put_f32le(uint8_t *p, float v) {
    uint32_t u;
    memcpy(&u, &v, sizeof u);
    ub_put_u32le(p, u);
}
static inline void ub_put_f64le(uint8_t *p, double v) {
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    ub_put_u64le(p, u);
}
static inline float ub_get_f32le(const uint8_t *p) {
    uint32_t u = ub_get_u32le(p);
    float v;
    memcpy(&v, &u, sizeof v);
    return v;
}
static inline double ub_get_f64le(const uint8_t *p) {
    uint64_t u = ub_get_u64le(p);
    double v;
    memcpy(&v, &u, sizeof v);
    return v;
}

#ifdef __cplusplus
}
#endif
#endif /* UB_WIRE_H */

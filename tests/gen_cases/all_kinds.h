/* Every field kind and every skip reason the generator knows (tests/unit/test_gen_*.py, golden). */
#ifndef ALL_KINDS_H
#define ALL_KINDS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef enum { MODE_IDLE = 0, MODE_AUTO = 3 } mode_e;        /* unsigned int underlying */
enum wide_e { WIDE_NEG = -1, WIDE_BIG = 0x7FFFFFFFFFLL };    /* long underlying */
typedef enum __attribute__((packed)) { TINY_A = 1 } tiny_e;  /* 1 byte */

struct vec3 {
    float x, y, z;
};

typedef struct {
    uint8_t id;
    struct vec3 pos;
} waypoint_t;

struct __attribute__((packed)) packed_hdr {
    uint8_t tag;
    uint32_t len;
    uint16_t crc;
};

struct empty_set {
    char *label;
    void (*callback)(int);
};

struct all_kinds {
    /* integers, all widths and both signs */
    char c;
    signed char sc;
    unsigned char uc;
    short s;
    unsigned short us;
    int i;
    unsigned int ui;
    long l;
    unsigned long ul;
    long long ll;
    unsigned long long ull;
    int8_t i8;
    uint16_t u16;
    int32_t i32;
    uint64_t u64;
    bool flag;
    /* floating */
    float f;
    double d;
    long double ld;
    /* enums at their real width */
    mode_e mode;
    enum wide_e wide;
    tiny_e tiny;
    /* bitfields */
    unsigned int bf_u3 : 3;
    int bf_s5 : 5;
    unsigned int bf_u12 : 12;
    uint64_t bf_u40 : 40;
    int64_t bf_s33 : 33;
    bool bf_b : 1;
    unsigned int : 0;
    /* nested, anonymous, arrays */
    struct vec3 vel;
    struct {
        int16_t roll, pitch;
    };
    struct {
        uint8_t a;
        double b;
    } unnamed_member;
    float matrix[3][3];
    waypoint_t route[4];
    struct vec3 grid[2][2];
    int8_t bytes[6];
    uint8_t raw[2][3];
    bool flags[3];
    struct packed_hdr hdr;
    /* skipped */
    char name[16];
    const char *text;
    int *ptr;
    void (*handler)(void);
    union {
        int as_int;
        float as_float;
    } either;
    union {
        uint32_t word;
        uint8_t octets[4];
    };
    struct vec3 *vp;
    uint16_t count;
    uint8_t tail[];
};

extern struct all_kinds kinds;
extern waypoint_t waypoints[3];
extern struct vec3 lattice[2][2];
extern struct packed_hdr hdr1;
extern struct empty_set nothing;
extern union { int x; } not_a_struct;
static struct vec3 not_visible __attribute__((unused));
#define DECLARE_SET(n) extern struct vec3 n##_set
DECLARE_SET(macro);

#endif

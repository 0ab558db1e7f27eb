/*
 * Build-time codegen check for the flight-software example: links the
 * catalogue that uavbus_generate() produced from the headers in examples/flightsw/ with the
 * storage in flightsw_data.c, the way flight software uses it, and checks
 *   1. the catalogue: size, ABI, sorted IDs, every ID found by
 *      ub_catalogue_find() and equal to the runtime's own 8+8 computation;
 *   2. every type's codec: bounded (NOSPACE/TRUNCATED one byte short) and
 *      stable (unpack -> pack -> unpack -> pack gives the same bytes);
 *   3. real directories: known values survive pack/unpack through the
 *      catalogue's codec pointers, and skipped fields (strings, pointers,
 *      flexible arrays) are never written by unpack.
 * Prints one line per failure and exits non-zero if any check failed.
 */
#include <stdalign.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "ub/ub_catalogue.h"
#include "ub/ub_config.h"

#include "flightsw.h"

#include "datalink.h"
#include "gps.h"
#include "health.h"
#include "imu.h"
#include "onboard.h"
#include "sensors.h"
#include "waypoints.h"

#define MIN_INSTANCES 700u     /* the paper's system had about 700 */
#define SCRATCH_BYTES 4096u    /* larger than any flightsw directory (checked) */
#define RANDOM_SEED 0x2005630Au

typedef struct check_state {
    unsigned failures;
    unsigned checks;
} check_state_t;

static void expect(check_state_t *st, int ok, const char *what, const char *detail) {
    st->checks++;
    if (!ok) {
        st->failures++;
        printf("FAIL: %s (%s)\n", what, detail);
    }
}

static uint32_t xorshift32(uint32_t *s) {
    uint32_t x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *s = x;
    return x;
}

static const ub_type_desc_t *type_of(check_state_t *st, const char *instance_name) {
    int idx = ub_catalogue_find_name(&flightsw_catalogue, instance_name);
    expect(st, idx >= 0, "instance is catalogued", instance_name);
    return idx >= 0 ? flightsw_catalogue.instances[idx].type : NULL;
}

static void check_catalogue(check_state_t *st) {
    const ub_catalogue_t *cat = &flightsw_catalogue;
    char detail[160];
    snprintf(detail, sizeof detail, "%zu instances", cat->n_instances);
    expect(st, cat->n_instances >= MIN_INSTANCES, "at least 700 instances", detail);
    expect(st, cat->abi_version == UB_CATALOGUE_ABI_VERSION, "catalogue ABI version", "regenerate");
    expect(st, cat->id_scheme == UB_ID_SCHEME_PAPER, "paper ID scheme", "uavbus_generate default");
    expect(st, cat->json != NULL && cat->json_len == strlen(cat->json) && cat->json_len > 1000 &&
                   strncmp(cat->json, "{\"catalogue\":\"flightsw\"", 23) == 0,
           "embedded self-description", "the compact catalogue JSON, for log headers");
    for (size_t i = 0; i < cat->n_instances; i++) {
        const ub_instance_desc_t *in = &cat->instances[i];
        if (i > 0) {
            expect(st, memcmp(cat->instances[i - 1].id, in->id, UB_DIR_ID_LEN) < 0, "IDs strictly ascending", in->name);
        }
        expect(st, ub_catalogue_find(cat, in->id) == (int)i, "ub_catalogue_find returns the instance", in->name);
        uint8_t expected_id[UB_DIR_ID_LEN];
        ub_dir_id_paper(in->name, expected_id);
        expect(st, memcmp(expected_id, in->id, UB_DIR_ID_LEN) == 0, "ID follows the 8+8 rule", in->name);
        expect(st, in->type != NULL && in->type >= cat->types && in->type < cat->types + cat->n_types,
               "instance type is in the type table", in->name);
    }
    uint8_t unknown[UB_DIR_ID_LEN];
    ub_dir_id_paper("noSuchDirectory_anywhere", unknown);
    expect(st, ub_catalogue_find(cat, unknown) == UB_ERR_NOTFOUND, "unknown ID is not found", "NOTFOUND");
}

/* Aligned for any directory type, so unpack may write through a typed pointer. */
typedef struct scratch {
    alignas(max_align_t) uint8_t obj[SCRATCH_BYTES];
} scratch_t;

static void check_type_codec(check_state_t *st, const ub_type_desc_t *t, uint32_t *rng) {
    uint8_t wire[UB_MAX_PAYLOAD], first[UB_MAX_PAYLOAD], second[UB_MAX_PAYLOAD];
    scratch_t a, b;
    expect(st, t->c_size <= SCRATCH_BYTES, "type fits the scratch object", t->name);
    expect(st, t->packed_size <= UB_MAX_PAYLOAD, "type fits one frame payload", t->name);
    expect(st, t->packed_size <= flightsw_catalogue.max_packed_size, "max_packed_size is the maximum", t->name);
    if (t->c_size > SCRATCH_BYTES || t->packed_size > UB_MAX_PAYLOAD) {
        return;
    }
    const int size = (int)t->packed_size;
    for (uint32_t i = 0; i < t->packed_size; i++) {
        wire[i] = (uint8_t)xorshift32(rng);
    }
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    /* Unpack refuses what no pack writes (a bool byte other than 0/1, a bitfield value wider than
     * its field) with UB_ERR_RANGE and writes nothing; what it accepts packs back to the very same
     * bytes (canonical codecs, docs/catalogue.md). A refused image is replaced by a valid one. */
    int got = t->unpack(a.obj, wire, t->packed_size);
    expect(st, got == size || got == UB_ERR_RANGE, "unpack consumes packed_size or refuses", t->name);
    if (got == UB_ERR_RANGE) {
        static const scratch_t zero;
        expect(st, memcmp(&a, &zero, sizeof a) == 0, "a refused unpack writes nothing", t->name);
        expect(st, t->pack(a.obj, wire, sizeof wire) == size, "pack of a zeroed object", t->name);
        got = t->unpack(a.obj, wire, t->packed_size);
        expect(st, got == size, "unpack accepts what pack wrote", t->name);
    }
    expect(st, t->pack(a.obj, first, sizeof first) == size, "pack writes packed_size", t->name);
    expect(st, memcmp(first, wire, t->packed_size) == 0, "pack(unpack(bytes)) == bytes", t->name);
    expect(st, t->unpack(b.obj, first, t->packed_size) == size, "unpack of own pack", t->name);
    expect(st, t->pack(b.obj, second, sizeof second) == size, "second pack", t->name);
    expect(st, memcmp(first, second, t->packed_size) == 0, "pack/unpack round trip is stable", t->name);
    if (t->packed_size > 0) {
        expect(st, t->pack(a.obj, first, t->packed_size - 1) == UB_ERR_NOSPACE, "pack one byte short", t->name);
        expect(st, t->unpack(b.obj, first, t->packed_size - 1) == UB_ERR_TRUNCATED, "unpack one byte short", t->name);
    }
}

static void check_all_codecs(check_state_t *st) {
    uint32_t rng = RANDOM_SEED;
    expect(st, flightsw_catalogue.max_packed_size <= UB_MAX_PAYLOAD, "max_packed_size fits a frame", "UB_MAX_PAYLOAD");
    for (size_t i = 0; i < flightsw_catalogue.n_types; i++) {
        check_type_codec(st, &flightsw_catalogue.types[i], &rng);
    }
}

/* Packs `src` with the catalogue's codec for `name` and unpacks into `dst`. */
static int ship(check_state_t *st, const char *name, const void *src, void *dst) {
    uint8_t wire[UB_MAX_PAYLOAD];
    const ub_type_desc_t *t = type_of(st, name);
    if (t == NULL) {
        return 0;
    }
    int packed = t->pack(src, wire, sizeof wire);
    expect(st, packed == (int)t->packed_size, "pack of a real directory", name);
    if (packed < 0) {
        return 0;
    }
    int unpacked = t->unpack(dst, wire, (size_t)packed);
    expect(st, unpacked == packed, "unpack of a real directory", name);
    return unpacked == packed;
}

static void check_onboard_set(check_state_t *st) {
    onboardSet.time = (timeTag_t){ 1200u, 250000u };
    onboardSet.mode = MODE_AUTONOMOUS;
    onboardSet.switches.logLevel = 5;
    onboardSet.switches.enableVision = 1;
    onboardSet.controllerGains[3][2] = 0.125f;
    onboardSet.armed = 1;
    onboardSet_t copy;
    memset(&copy, 0, sizeof copy);
    strcpy(copy.vehicleName, "receiver");
    copy.peerSet = &copy;
    if (!ship(st, "onboardSet", &onboardSet, &copy)) {
        return;
    }
    expect(st, copy.time.microseconds == 250000u && copy.mode == MODE_AUTONOMOUS, "onboardSet scalars", "time, mode");
    expect(st, copy.switches.logLevel == 5 && copy.switches.enableVision == 1 && copy.switches.enableDatalink2 == 1,
           "onboardSet bitfields", "switches");
    expect(st, copy.datum.latitudeDeg == onboardSet.datum.latitudeDeg, "onboardSet nested struct", "datum");
    expect(st, copy.controllerGains[3][2] == 0.125f, "onboardSet 2-D array", "controllerGains");
    expect(st, copy.armed == 1 && copy.onGround == 1, "onboardSet _Bool", "armed, onGround");
    expect(st, strcmp(copy.vehicleName, "receiver") == 0, "string field untouched by unpack", "vehicleName");
    expect(st, copy.peerSet == &copy && copy.buildDescription == NULL, "pointers untouched by unpack", "peerSet");
}

static void check_gps(check_state_t *st) {
    gpsOut.latitudeDeg = 32.3738123;
    gpsOut.velocityNed.z = -1.5f;
    gpsOut.fix = GPS_FIX_RTK_FIXED;
    gpsOut.status.jammingLevel = 9;
    gpsOut.status.differential = 1;
    gpsOut_t copy;
    memset(&copy, 0, sizeof copy);
    if (ship(st, "gpsOut", &gpsOut, &copy)) {
        expect(st, copy.latitudeDeg == 32.3738123 && copy.velocityNed.z == -1.5f, "gpsOut values", "lat, vel");
        expect(st, copy.fix == GPS_FIX_RTK_FIXED, "gpsOut enum", "fix");
        expect(st, copy.status.jammingLevel == 9 && copy.status.differential == 1, "gpsOut anonymous-type bitfields",
               "status");
    }
    gpsRaw.header.weekMilliseconds = 0x01020304u;
    gpsRaw.header.leapSeconds = -18;
    gpsRaw.rawMessage[71] = 0xAB;
    gpsRaw_t raw;
    memset(&raw, 0, sizeof raw);
    strcpy(raw.receiverModel, "kept");
    if (ship(st, "gpsRaw", &gpsRaw, &raw)) {
        expect(st, raw.header.weekMilliseconds == 0x01020304u && raw.header.leapSeconds == -18, "packed struct",
               "gpsLogHeader");
        expect(st, raw.rawMessage[71] == 0xAB, "uint8_t array is data, not a string", "rawMessage");
        expect(st, strcmp(raw.receiverModel, "kept") == 0, "string field untouched", "receiverModel");
    }
}

static void check_imu_and_health(check_state_t *st) {
    imuOut.q = -0.25;
    imuOut.health = HEALTH_DEGRADED;
    imuOut_t imu;
    memset(&imu, 0, sizeof imu);
    if (ship(st, "imuOut", &imuOut, &imu)) {
        expect(st, imu.q == -0.25 && imu.health == HEALTH_DEGRADED, "anonymous struct member and packed enum", "imuOut");
    }
    healthMonitor.subsystem[11] = HEALTH_FAILED;
    healthMonitor.gpsHealthTrend = -1;
    healthMonitor.lastResetMs = -123456789012LL;
    healthMonitor.uptimeMs = 0x0123456789ABCDEFull;
    healthMonitor_t hm;
    memset(&hm, 0, sizeof hm);
    if (ship(st, "healthMonitor", &healthMonitor, &hm)) {
        expect(st, hm.subsystem[11] == HEALTH_FAILED && hm.gpsHealthTrend == -1, "enum array, signed char",
               "healthMonitor");
        expect(st, hm.lastResetMs == -123456789012LL && hm.uptimeMs == 0x0123456789ABCDEFull, "64-bit integers",
               "healthMonitor");
    }
}

static void check_ports(check_state_t *st) {
    onboardPortDatalink2.bytesIn = 0xFEDCBA9876543210ull;
    onboardPortDatalink2.messagesByType[15] = 77u;
    datalinkPort_t port;
    memset(&port, 0, sizeof port);
    strcpy(port.deviceName, "local");
    port.driverState = &port;
    if (ship(st, "onboardPortDatalink2", &onboardPortDatalink2, &port)) {
        expect(st, port.bytesIn == 0xFEDCBA9876543210ull && port.messagesByType[15] == 77u, "port counters",
               "onboardPortDatalink2");
        expect(st, strcmp(port.deviceName, "local") == 0 && port.driverState == &port && port.driver == NULL,
               "port strings and pointers untouched", "deviceName, driver");
    }
    datalinkRxQueue.dropped = 3u;
    datalinkRxQueue_t queue;
    memset(&queue, 0, sizeof queue);
    queue.current = (datalinkMessage_t *)NULL;
    if (ship(st, "datalinkRxQueue", &datalinkRxQueue, &queue)) {
        expect(st, queue.dropped == 3u, "header of a flexible-array struct travels", "datalinkRxQueue");
    }
}

static void check_array_elements(check_state_t *st) {
    waypointPlan[127].altitudeMsl = 310.5f;
    waypointPlan[127].action = WPT_LAND;
    waypoint_t wp;
    memset(&wp, 0, sizeof wp);
    if (ship(st, "waypointPlan[127]", &waypointPlan[127], &wp)) {
        expect(st, wp.altitudeMsl == 310.5f && wp.action == WPT_LAND, "last waypoint element", "waypointPlan[127]");
    }
    batteryCell[1][11].millivolts = 4150;
    batteryCell_t cell;
    memset(&cell, 0, sizeof cell);
    if (ship(st, "batteryCell[1][11]", &batteryCell[1][11], &cell)) {
        expect(st, cell.millivolts == 4150, "2-D array element", "batteryCell[1][11]");
    }
    expect(st, ub_catalogue_find_name(&flightsw_catalogue, "cameraTrack[1][15]") >= 0, "2-D element named",
           "cameraTrack[1][15]");
    expect(st, ub_catalogue_find_name(&flightsw_catalogue, "cameraTrack[2][0]") == UB_ERR_NOTFOUND,
           "no element past the end", "cameraTrack[2][0]");
}

int main(void) {
    check_state_t st = { 0, 0 };
    check_catalogue(&st);
    check_all_codecs(&st);
    check_onboard_set(&st);
    check_gps(&st);
    check_imu_and_health(&st);
    check_ports(&st);
    check_array_elements(&st);
    printf("flightsw_roundtrip: %zu instances, %zu types, %u checks, %u failures\n", flightsw_catalogue.n_instances,
           flightsw_catalogue.n_types, st.checks, st.failures);
    return st.failures == 0 ? 0 : 1;
}

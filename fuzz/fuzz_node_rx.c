/*
 * Fuzz harness: hostile bytes into a configured node (issue #17 item 6).
 *
 * The node is one of Table 2 (examples/configs/table2.json, or table2_policy.json with its security policy:
 * administrators, read/write rules, limits): "primary" (rmax1ob1, the flight computer) or "gcs" (gcs1,
 * with the global administration table attached), over the generated flight-software catalogue, with
 * directories bound to storage and a capturing transport behind every link. The input is a program of
 * operations:
 *
 *   byte 0: which node (bit 0: primary or gcs) of which file (bit 1: table2 or table2_policy); bit 2: the
 *           first link carries the compact encoding (ub_compact.h: COBS packets, LINK_HELLO dictionaries);
 *           bit 3: the first link has the smallest MTU, so directories leave on it in fragments; bit 4: the
 *           node holds no fragment state (else ub_node_set_frag(): FRAGMENT frames are reassembled).
 *   then, repeated: op u8 | arg u8 | len u16le | len bytes
 *     op % 8 = 0  stream bytes into ub_node_rx() on link arg
 *              1  the bytes resealed into a frame (see below), into ub_node_rx()
 *              2  the bytes resealed, as a datagram into ub_node_rx_frame()
 *              3  the bytes, raw, as a datagram
 *              4  time passes (1 + 8 * arg ms) and the node ticks
 *              5  a local API call (subscribe, publish, stop, send, admin rows) with parameters from the bytes
 *              6  the transports answer OK, AGAIN (backpressure) or IO errors from now on
 *              7  a link is re-attached, detached, or given the same transport again
 *
 * Resealing is what lets hostile headers and payloads reach the router, the tables and the admin code:
 * random bytes almost never pass the header check and the CRC, so the harness writes the sync word, the
 * sizes and both checks itself (ub_frame_set_hop_limit() recomputes them) and, as `arg` asks, puts known
 * entity IDs in the source/destination, a known content ID with its fingerprint (and its packed size),
 * the wire version and message type, and an admin code in range.
 *
 * Properties checked after every operation (a failure aborts): every frame the node hands a transport is
 * a valid frame (on the compact link: one COBS packet that the link's own dictionary expands to a valid
 * frame); on every link the decoder's bytes_in == bytes_ok + garbage_bytes + pending and equals the
 * stream bytes fed; the link's bytes_in is every byte fed to it. Memory errors and undefined behaviour
 * are ASan's and UBSan's.
 */
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "flightsw.h"
#include "fuzz_util.h"
#include "ub/ub_admin.h"
#include "ub/ub_compact.h"
#include "ub/ub_frag.h"
#include "ub/ub_frame.h"
#include "ub/ub_inspect.h"
#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_wire.h"
#include "ub/ub_admin_wire.h"

#ifndef UB_FUZZ_CONFIG_DIR
#define UB_FUZZ_CONFIG_DIR "examples/configs"
#endif

#define STORAGE_MAX 4096
#define N_NODES 4

static const char *const k_node_names[N_NODES] = {"primary", "gcs", "primary", "gcs"};
static const char *const k_files[N_NODES] = {"table2.json", "table2.json", "table2_policy.json", "table2_policy.json"};
/* Bound first (what uavbus_node binds), then other instances up to UB_MAX_BINDINGS. */
static const char *const k_first_bound[] = {"gpsOut",       "navFilterState",       "imuOutPrimary",
                                            "onboardSet",   "imuOut",               "gpsOutBackup",
                                            "navFilterStateBackup", "fcsSet",       "onboard2Set",
                                            "gcsMissionRmax1[0]"};

static ub_nodecfg_t g_cfg[N_NODES];
static char g_cfg_text[1 << 16];
static ub_node_t g_node;
static ub_admin_t g_admin;
static _Alignas(16) uint8_t g_storage[UB_MAX_BINDINGS][STORAGE_MAX];
static uint32_t g_bound[UB_MAX_BINDINGS];
static size_t g_n_bound;
static uint8_t g_ids[UB_MAX_ENTITIES + 1][UB_ENTITY_ID_LEN]; /* the config's entities and one stranger */
static size_t g_n_ids;
static int g_send_rc;
static uint64_t g_fed_stream[UB_MAX_NODE_LINKS], g_fed_total[UB_MAX_NODE_LINKS];

static ub_compact_t g_compact; /* the first link's, when byte 0 asks for it */
static ub_frag_t g_frag;
static int g_compact_link = -1;
static int g_link_tag[UB_MAX_NODE_LINKS]; /* each link's transport impl: its id */

static void check_compact_packet(const uint8_t *wire, size_t len) {
    FUZZ_CHECK(len >= 2 && wire[len - 1] == 0 && memchr(wire, 0, len - 1) == NULL,
               "the compact link sent %zu bytes that are not one delimited COBS packet", len);
    static uint8_t pkt[UB_COMPACT_WIRE_MAX], frame[UB_FRAME_MAX];
    int n = ub_cobs_decode(wire, len - 1, pkt, sizeof pkt);
    FUZZ_CHECK(n > 0, "the compact link sent an unstuffable packet (%d)", n);
    ub_compact_codec_t c;
    ub_compact_tx_codec(&g_compact, &c);
    ub_frame_header_t h;
    ub_rx_reason_t why = UB_RX_REASON_COUNT; /* none yet */
    /* The sender's references hold each source's last sequence sent: this packet's. */
    int flen = ub_compact_decode(&c, pkt, (size_t)n, &g_compact.tx, frame, sizeof frame, &h, &why);
    FUZZ_CHECK(flen > 0, "the compact link's own dictionary does not expand its packet (reason %d)", (int)why);
    FUZZ_CHECK(ub_frame_parse(frame, (size_t)flen, NULL) == UB_OK, "a compact packet expands to an invalid frame");
}

static int capture_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)now_ms;
    int link = impl != NULL ? *(const int *)impl : -1;
    if (link >= 0 && link == g_compact_link) check_compact_packet(frame, len);
    else FUZZ_CHECK(ub_frame_parse(frame, len, NULL) == UB_OK, "the node sent an invalid frame (%zu bytes)", len);
    return g_send_rc;
}

static const ub_link_ops_t k_capture_ops = {.kind = "capture", .send = capture_send};

int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    char err[UB_NODECFG_ERR_LEN];
    for (int k = 0; k < N_NODES; k++) {
        char path[512];
        snprintf(path, sizeof path, "%s/%s", UB_FUZZ_CONFIG_DIR, k_files[k]);
        if (ub_nodecfg_load_file(&g_cfg[k], path, g_cfg_text, sizeof g_cfg_text, err, sizeof err) != UB_OK
            || ub_nodecfg_select_node(&g_cfg[k], k_node_names[k], err, sizeof err) != UB_OK) {
            fprintf(stderr, "fuzz_node_rx: %s\n", err);
            exit(1);
        }
    }
    for (size_t i = 0; i < g_cfg[0].entity_count; i++) {
        if (ub_entity_id(g_cfg[0].entities[i].name, g_ids[g_n_ids]) == UB_OK) g_n_ids++;
    }
    memcpy(g_ids[g_n_ids++], "stranger\0\0\0\0", UB_ENTITY_ID_LEN);
    const ub_catalogue_t *cat = &flightsw_catalogue;
    for (size_t i = 0; i < sizeof k_first_bound / sizeof k_first_bound[0]; i++) {
        int idx = ub_catalogue_find_name(cat, k_first_bound[i]);
        if (idx >= 0 && cat->instances[idx].type->c_size <= STORAGE_MAX) g_bound[g_n_bound++] = (uint32_t)idx;
    }
    for (size_t i = 0; i < cat->n_instances && g_n_bound < UB_MAX_BINDINGS; i += 7) {
        bool dup = false;
        for (size_t b = 0; b < g_n_bound; b++) dup = dup || g_bound[b] == i;
        if (!dup && cat->instances[i].type->c_size <= STORAGE_MAX) g_bound[g_n_bound++] = (uint32_t)i;
    }
    return 0;
}

static int local_entity(void) { return g_node.locals[0].entity; }

static void setup(uint8_t mode) {
    int which = mode % N_NODES;
    char err[UB_NODECFG_ERR_LEN];
    FUZZ_CHECK(ub_node_init(&g_node, &flightsw_catalogue, NULL) == UB_OK, "node init");
    FUZZ_CHECK(ub_nodecfg_apply(&g_cfg[which], &g_node, err, sizeof err) == UB_OK, "%s", err);
    memset(g_storage, 0, sizeof g_storage);
    for (size_t b = 0; b < g_n_bound; b++) {
        FUZZ_CHECK(ub_node_bind(&g_node, g_bound[b], g_storage[b]) == UB_OK, "bind %zu", b);
    }
    g_compact_link = -1;
    int first = -1;
    for (int l = 0; l < UB_MAX_NODE_LINKS; l++) {
        g_link_tag[l] = l;
        if (ub_node_link(&g_node, l) == NULL) continue;
        if (first < 0) first = l;
        fuzz_ignore(ub_node_link_attach(&g_node, l, &k_capture_ops, &g_link_tag[l]));
    }
    ub_frag_init(&g_frag, NULL, 1);
    if (!(mode & 16)) FUZZ_CHECK(ub_node_set_frag(&g_node, &g_frag) == UB_OK, "frag");
    if (first >= 0 && (mode & 4)) {
        ub_compact_init(&g_compact, &flightsw_catalogue, 7, NULL);
        FUZZ_CHECK(ub_node_link_set_compact(&g_node, first, &g_compact, NULL) == UB_OK, "compact");
        g_compact_link = first;
    }
    if (first >= 0 && (mode & 8)) FUZZ_CHECK(ub_node_link_set_mtu(&g_node, first, UB_LINK_MTU_MIN) == UB_OK, "mtu");
    if (which % 2 == 1) FUZZ_CHECK(ub_admin_init(&g_admin, &g_node, local_entity(), NULL) == UB_OK, "admin init");
    g_send_rc = UB_OK;
    memset(g_fed_stream, 0, sizeof g_fed_stream);
    memset(g_fed_total, 0, sizeof g_fed_total);
}

static int pick_link(uint8_t arg) {
    int ids[UB_MAX_NODE_LINKS], n = 0;
    for (int l = 0; l < UB_MAX_NODE_LINKS; l++) {
        if (ub_node_link(&g_node, l) != NULL) ids[n++] = l;
    }
    return n == 0 ? 0 : ids[arg % n];
}

/* Makes a frame the checks accept out of `b` (see the file comment); returns its length. */
static size_t reseal(const uint8_t *b, size_t n, uint8_t arg, uint8_t *f) {
    size_t payload = n > UB_FRAME_HEADER_LEN ? n - UB_FRAME_HEADER_LEN : 0;
    if (payload > UB_MAX_PAYLOAD) payload = UB_MAX_PAYLOAD;
    memset(f, 0, UB_FRAME_HEADER_LEN + payload);
    memcpy(f, b, n < UB_FRAME_HEADER_LEN + payload ? n : UB_FRAME_HEADER_LEN + payload);
    f[0] = UB_SYNC0;
    f[1] = UB_SYNC1;
    if (!(arg & 0x01)) f[UB_FRAME_OFF_VERSION] = UB_WIRE_VERSION;
    if (!(arg & 0x02)) ub_put_u16le(f + UB_FRAME_OFF_MSG_TYPE, UB_MSG_TYPE_PUBSUB);
    if (arg & 0x04) {
        memcpy(f + UB_FRAME_OFF_DEST_ID, g_ids[f[UB_FRAME_OFF_DEST_ID] % g_n_ids], UB_ENTITY_ID_LEN);
        memcpy(f + UB_FRAME_OFF_SRC_ID, g_ids[f[UB_FRAME_OFF_SRC_ID] % g_n_ids], UB_ENTITY_ID_LEN);
    }
    if (arg & 0x08) {
        const ub_catalogue_t *cat = &flightsw_catalogue;
        size_t idx = (size_t)ub_get_u16le(f + UB_FRAME_OFF_DIR_ID) % cat->n_instances;
        if (arg & 0x40) idx = g_bound[idx % g_n_bound];
        const ub_instance_desc_t *inst = &cat->instances[idx];
        memcpy(f + UB_FRAME_OFF_DIR_ID, inst->id, UB_DIR_ID_LEN);
        ub_put_u32le(f + UB_FRAME_OFF_FINGERPRINT, inst->type->fingerprint);
        if ((arg & 0x10) && inst->type->packed_size <= UB_MAX_PAYLOAD) {
            size_t want = inst->type->packed_size;
            if (want > payload) memset(f + UB_FRAME_HEADER_LEN + payload, 0, want - payload);
            payload = want;
        }
    }
    if (arg & 0x20) f[UB_FRAME_OFF_ADMIN] = (uint8_t)(f[UB_FRAME_OFF_ADMIN] % (UB_ADMIN_NACK + 1));
    if (f[UB_FRAME_OFF_HOP_LIMIT] == 0) f[UB_FRAME_OFF_HOP_LIMIT] = 1;
    ub_put_u16le(f + UB_FRAME_OFF_PAYLOAD_SIZE, (uint16_t)payload);
    ub_put_u16le(f + UB_FRAME_OFF_MSG_SIZE, (uint16_t)(UB_FRAME_HEADER_LEN + payload));
    size_t len = UB_FRAME_HEADER_LEN + payload;
    FUZZ_CHECK(ub_frame_set_hop_limit(f, len, f[UB_FRAME_OFF_HOP_LIMIT]) == UB_OK, "reseal");
    return len;
}

static void local_call(uint8_t arg, const uint8_t *b, size_t n, uint64_t now) {
    fuzz_in_t in = {b, n};
    const ub_catalogue_t *cat = &flightsw_catalogue;
    uint32_t inst = fuzz_u16(&in) % (uint32_t)cat->n_instances;
    if (fuzz_u8(&in) & 1) inst = g_bound[inst % g_n_bound];
    const uint8_t *peer = g_ids[fuzz_u8(&in) % g_n_ids];
    uint32_t period = fuzz_u16(&in);
    int e = local_entity();
    int row = fuzz_u8(&in);
    switch (arg % 8) {
    case 0: fuzz_ignore(ub_pubsub_subscribe(&g_node, e, inst, peer, period, now)); break;
    case 1: fuzz_ignore(ub_pubsub_publish(&g_node, e, inst, peer, period, now)); break;
    case 2: fuzz_ignore(ub_pubsub_stop(&g_node, e, row % (UB_MAX_PUBSUB_ROWS + 2), now)); break;
    case 3: fuzz_ignore(ub_node_send_data(&g_node, e, inst, peer, now)); break;
    default:
        if (g_admin.node == NULL) break;
        if (arg % 8 == 4) {
            ub_admin_row_spec_t spec = {.instance = inst, .period_ms = period, .type = (ub_admin_row_type_t)(row % 3)};
            memcpy(spec.source, peer, UB_ENTITY_ID_LEN);
            memcpy(spec.destination, g_ids[fuzz_u8(&in) % g_n_ids], UB_ENTITY_ID_LEN);
            fuzz_ignore(ub_admin_add_row(&g_admin, &spec));
        } else if (arg % 8 == 5) {
            fuzz_ignore(ub_admin_set_active(&g_admin, row % (UB_MAX_ADMIN_ROWS + 2), fuzz_u8(&in) & 1, now));
        } else if (arg % 8 == 6) {
            fuzz_ignore(ub_admin_remove_row(&g_admin, row % (UB_MAX_ADMIN_ROWS + 2)));
        } else {
            ub_admin_row_info_t info;
            fuzz_ignore(ub_admin_row_status(&g_admin, row % (UB_MAX_ADMIN_ROWS + 2), &info));
        }
        break;
    }
}

static void check_accounting(void) {
    for (int l = 0; l < UB_MAX_NODE_LINKS; l++) {
        const ub_link_t *link = ub_node_link(&g_node, l);
        if (link == NULL) continue;
        const ub_decoder_stats_t *d = &link->decoder.stats;
        uint64_t pending = ub_decoder_pending(&link->decoder);
        FUZZ_CHECK(d->bytes_in == d->bytes_ok + d->garbage_bytes + pending,
                   "link %d: decoder bytes_in %llu != ok %llu + garbage %llu + pending %llu", l,
                   (unsigned long long)d->bytes_in, (unsigned long long)d->bytes_ok,
                   (unsigned long long)d->garbage_bytes, (unsigned long long)pending);
        FUZZ_CHECK(d->bytes_in == g_fed_stream[l], "link %d: decoder counted %llu stream bytes, %llu fed", l,
                   (unsigned long long)d->bytes_in, (unsigned long long)g_fed_stream[l]);
        FUZZ_CHECK(link->counters.bytes_in == g_fed_total[l], "link %d: bytes_in %llu, %llu fed", l,
                   (unsigned long long)link->counters.bytes_in, (unsigned long long)g_fed_total[l]);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    fuzz_in_t in = {data, size};
    setup(fuzz_u8(&in));
    uint64_t now = 1000;
    static uint8_t frame[UB_FRAME_MAX];
    while (in.left > 0) {
        uint8_t op = fuzz_u8(&in), arg = fuzz_u8(&in);
        size_t n;
        const uint8_t *b = fuzz_bytes(&in, fuzz_u16(&in) % (2 * UB_FRAME_MAX), &n);
        int link = pick_link(arg);
        switch (op % 8) {
        case 0:
            g_fed_stream[link] += n;
            g_fed_total[link] += n;
            fuzz_ignore(ub_node_rx(&g_node, link, b, n, now));
            break;
        case 1:
        case 2: {
            size_t len = reseal(b, n, (uint8_t)(arg ^ op), frame);
            g_fed_total[link] += len;
            if (op % 8 == 1) {
                g_fed_stream[link] += len;
                fuzz_ignore(ub_node_rx(&g_node, link, frame, len, now));
            } else {
                fuzz_ignore(ub_node_rx_frame(&g_node, link, frame, len, now));
            }
            break;
        }
        case 3:
            if (n == 0) break;
            g_fed_total[link] += n;
            fuzz_ignore(ub_node_rx_frame(&g_node, link, b, n, now));
            break;
        case 4:
            now += 1 + 8u * arg;
            ub_node_tick(&g_node, now);
            break;
        case 5: local_call(arg, b, n, now); break;
        case 6: g_send_rc = arg % 3 == 0 ? UB_OK : arg % 3 == 1 ? UB_ERR_AGAIN : UB_ERR_IO; break;
        default:
            if (arg & 0x80) fuzz_ignore(ub_node_link_detach(&g_node, link));
            else if (arg & 0x40) fuzz_ignore(ub_node_link_set_transport(&g_node, link, &k_capture_ops, &g_link_tag[link]));
            else fuzz_ignore(ub_node_link_attach(&g_node, link, &k_capture_ops, &g_link_tag[link]));
            break;
        }
        check_accounting();
    }
    ub_node_tick(&g_node, now + 10000);
    check_accounting();
    if (g_admin.node != NULL) ub_admin_detach(&g_admin);
    memset(&g_admin, 0, sizeof g_admin);
    return 0;
}

/* ---- seeds: frames our own encoder makes, in realistic programs ------------------------------------- */

typedef struct seed {
    uint8_t buf[8192];
    size_t len;
} seed_t;

static void seed_op(seed_t *s, uint8_t op, uint8_t arg, const uint8_t *b, size_t n) {
    if (s->len + 4 + n > sizeof s->buf) return;
    s->buf[s->len++] = op;
    s->buf[s->len++] = arg;
    ub_put_u16le(s->buf + s->len, (uint16_t)n);
    s->len += 2;
    memcpy(s->buf + s->len, b, n);
    s->len += n;
}

/* A frame from `src` to `dest` about instance `name` with admin code `admin` and `payload`. */
static size_t seed_frame(uint8_t *f, const char *name, const char *src, const char *dest, uint8_t admin,
                         const uint8_t *payload, uint16_t n, uint32_t seq) {
    const ub_catalogue_t *cat = &flightsw_catalogue;
    int idx = ub_catalogue_find_name(cat, name);
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, cat->instances[idx].id, UB_DIR_ID_LEN);
    fuzz_ignore(ub_entity_id(dest, h.dest_id));
    fuzz_ignore(ub_entity_id(src, h.src_id));
    h.admin = admin;
    h.hop_limit = UB_DEFAULT_HOP_LIMIT;
    h.payload_size = n;
    h.seq = seq;
    h.fingerprint = cat->instances[idx].type->fingerprint;
    memcpy(f + UB_FRAME_HEADER_LEN, payload, n);
    int len = ub_frame_finish(f, UB_FRAME_MAX, &h);
    return len < 0 ? 0 : (size_t)len;
}

static size_t seed_request(uint8_t *f, const char *name, const char *src, const char *dest, uint8_t admin,
                           const char *peer, uint32_t seq) {
    uint8_t pl[UB_PL_REQUEST_LEN] = {0};
    ub_put_u32le(pl + UB_PL_REQUEST_ID, seq);
    ub_put_u32le(pl + UB_PL_REQUEST_PERIOD, 100);
    ub_put_u32le(pl + UB_PL_REQUEST_LEASE, 3000);
    fuzz_ignore(ub_entity_id(peer, pl + UB_PL_REQUEST_PEER));
    return seed_frame(f, name, src, dest, admin, pl, sizeof pl, seq);
}

static size_t seed_data(uint8_t *f, const char *name, const char *src, const char *dest, uint32_t seq) {
    const ub_catalogue_t *cat = &flightsw_catalogue;
    int idx = ub_catalogue_find_name(cat, name);
    const ub_type_desc_t *t = cat->instances[idx].type;
    static _Alignas(16) uint8_t obj[STORAGE_MAX];
    uint8_t pl[UB_MAX_PAYLOAD];
    memset(obj, 0, sizeof obj);
    int n = t->pack != NULL ? t->pack(obj, pl, sizeof pl) : (int)t->packed_size;
    if (t->pack == NULL) memset(pl, 0, t->packed_size);
    return seed_frame(f, name, src, dest, UB_ADMIN_DATA, pl, (uint16_t)(n < 0 ? 0 : n), seq);
}

/* Each seed twice: on the plain Table 2 and on table2_policy.json. */
static void seed_write(const char *dir, const char *name, seed_t *s) {
    char policy_name[96];
    fuzz_write_seed(dir, name, s->buf, s->len);
    s->buf[0] |= 2;
    snprintf(policy_name, sizeof policy_name, "%s_policy", name);
    fuzz_write_seed(dir, policy_name, s->buf, s->len);
}

/* An INSPECT request (docs/inspect.md) from gcs1 to rmax1ob1 about `name`. */
static size_t seed_inspect_req(uint8_t *f, const char *name, uint8_t op, uint8_t arg, uint16_t offset, uint32_t value,
                               const uint8_t *data, uint16_t n, uint32_t seq) {
    uint8_t pl[UB_MAX_PAYLOAD] = {0};
    ub_put_u32le(pl + UB_INSPECT_REQ_ID, seq);
    pl[UB_INSPECT_REQ_OP] = op;
    pl[UB_INSPECT_REQ_ARG] = arg;
    ub_put_u16le(pl + UB_INSPECT_REQ_OFFSET, offset);
    ub_put_u32le(pl + UB_INSPECT_REQ_VALUE, value);
    if (n > 0) memcpy(pl + UB_INSPECT_REQ_DATA, data, n);
    return seed_frame(f, name, "gcs1", "rmax1ob1", UB_ADMIN_INSPECT, pl, (uint16_t)(UB_INSPECT_REQ_DATA + n), seq);
}

/* Inspection requests of every operation, good and refused, as stream and datagram. */
static void seed_inspect(const char *dir, uint8_t *f) {
    static seed_t s;
    uint8_t tick[1] = {0};
    uint8_t gcs[UB_ENTITY_ID_LEN], stranger[UB_ENTITY_ID_LEN] = "stranger";
    fuzz_ignore(ub_entity_id("gcs1", gcs));
    uint8_t four[4] = {1, 2, 3, 4};
    memset(&s, 0, sizeof s);
    s.buf[s.len++] = 0;
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_READ, 0, 0, 0, NULL, 0, 30));
    seed_op(&s, 3, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_READ, 0, 4000, 0, NULL, 0, 31)); /* past the end */
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_WRITE, 0, 0, 0, four, 4, 32));
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_WRITE, 0, 0, 0, NULL, 0, 33)); /* nothing to write */
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gcsMissionRmax1[1]", UB_INSPECT_READ, 0, 0, 0, NULL, 0, 34)); /* unbound */
    for (uint8_t t = UB_INSPECT_ENTITIES; t <= UB_INSPECT_ADMIN + 1; t++)
        seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_LIST, t, 0, 0, NULL, 0, 40u + t));
    seed_op(&s, 5, 1, (const uint8_t[]){0, 0, 0, 0, 100, 0, 0}, 7); /* a local publication: a row to change */
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_SET_PERIOD, 0, 0, 50, NULL, 0, 50));
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_SET_PERIOD, 0, 0, 0, NULL, 0, 51));
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_SET_MASK, 0, 0, 1, gcs, UB_ENTITY_ID_LEN, 52));
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_SET_MASK, 0, 0, 1, stranger, UB_ENTITY_ID_LEN, 53));
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_SET_MASK, 0, 0, 0x100, gcs, UB_ENTITY_ID_LEN, 54));
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", UB_INSPECT_ADMIN_ROW, UB_INSPECT_ADMIN_PERIOD, 0, 10, NULL, 0, 55));
    seed_op(&s, 0, 0, f, seed_inspect_req(f, "gpsOut", 0x7F, 0, 0, 0, NULL, 0, 56)); /* no such operation */
    uint8_t short_pl[4] = {0};
    seed_op(&s, 0, 0, f, seed_frame(f, "gpsOut", "gcs1", "rmax1ob1", UB_ADMIN_INSPECT, short_pl, sizeof short_pl, 57));
    seed_op(&s, 4, 50, tick, 0);
    seed_write(dir, "inspect_requests", &s);
    /* gcs (administration table): ADMIN_ROW on a row that exists. */
    memset(&s, 0, sizeof s);
    s.buf[s.len++] = 1;
    uint8_t call[8] = {0};
    ub_put_u16le(call, (uint16_t)ub_catalogue_find_name(&flightsw_catalogue, "gpsOut"));
    ub_put_u16le(call + 4, 100);
    call[7] = 3; /* destination: gcs1 (as gcs_admin_rows) */
    seed_op(&s, 5, 4, call, sizeof call);
    for (uint32_t v = 0; v <= 2; v++) {
        uint32_t sq = 60 + v;
        uint8_t pl[UB_INSPECT_REQ_DATA] = {0};
        ub_put_u32le(pl, sq);
        pl[UB_INSPECT_REQ_OP] = UB_INSPECT_ADMIN_ROW;
        pl[UB_INSPECT_REQ_ARG] = v == 0 ? UB_INSPECT_ADMIN_PERIOD : UB_INSPECT_ADMIN_ACTIVE;
        ub_put_u32le(pl + UB_INSPECT_REQ_VALUE, v == 0 ? 250 : v - 1);
        seed_op(&s, 0, 0, f, seed_frame(f, "gpsOut", "rmax1ob1", "gcs1", UB_ADMIN_INSPECT, pl, sizeof pl, sq));
    }
    seed_op(&s, 4, 20, tick, 0);
    seed_write(dir, "inspect_admin_rows", &s);
}

/* FRAGMENT frames (ub_frag.h) of gpsOut from gcs1 to rmax1ob1: a whole transfer out of order with a
 * duplicate, one that never completes and times out, a malformed fragment header. */
static void seed_fragments(const char *dir, uint8_t *f) {
    static seed_t s;
    uint8_t tick[1] = {0};
    const ub_catalogue_t *cat = &flightsw_catalogue;
    const ub_type_desc_t *t = cat->instances[ub_catalogue_find_name(cat, "gpsOut")].type;
    uint8_t image[UB_MAX_PAYLOAD] = {0}, pl[UB_MAX_PAYLOAD];
    size_t total = t->packed_size;
    memset(&s, 0, sizeof s);
    s.buf[s.len++] = 0;
    for (int k = 2; k >= 0; k--) { /* 3 fragments, last first, the middle one twice */
        int n = ub_frag_write(pl, sizeof pl, 7, (uint16_t)k, 3, image, total);
        if (n > 0) seed_op(&s, 0, 0, f, seed_frame(f, "gpsOut", "gcs1", "rmax1ob1", UB_ADMIN_FRAGMENT, pl, (uint16_t)n, 70u + (uint32_t)k));
        if (k == 1 && n > 0) seed_op(&s, 3, 0, f, seed_frame(f, "gpsOut", "gcs1", "rmax1ob1", UB_ADMIN_FRAGMENT, pl, (uint16_t)n, 80));
    }
    int n = ub_frag_write(pl, sizeof pl, 8, 0, 2, image, total); /* its second half never comes */
    if (n > 0) seed_op(&s, 0, 0, f, seed_frame(f, "gpsOut", "fcs20", "rmax1ob1", UB_ADMIN_FRAGMENT, pl, (uint16_t)n, 81));
    pl[UB_FRAG_OFF_COUNT] = 0; /* malformed: no fragments */
    seed_op(&s, 0, 0, f, seed_frame(f, "gpsOut", "gcs1", "rmax1ob1", UB_ADMIN_FRAGMENT, pl, (uint16_t)n, 82));
    seed_op(&s, 4, 255, tick, 0); /* past the reassembly timeout */
    seed_op(&s, 4, 255, tick, 0);
    seed_write(dir, "fragments", &s);

    /* What DATA would be refused for, refused per fragment: an unknown content, another layout, a size
     * that is not the type's, an unbound directory; then more transfers than slots (refused, counted). */
    memset(&s, 0, sizeof s);
    s.buf[s.len++] = 0;
    n = ub_frag_write(pl, sizeof pl, 9, 0, 2, image, total);
    size_t len = seed_frame(f, "gpsOut", "gcs1", "rmax1ob1", UB_ADMIN_FRAGMENT, pl, (uint16_t)n, 100);
    f[UB_FRAME_OFF_DIR_ID] ^= 0x5A; /* no such content */
    fuzz_ignore(ub_frame_set_hop_limit(f, len, f[UB_FRAME_OFF_HOP_LIMIT]));
    seed_op(&s, 0, 0, f, len);
    len = seed_frame(f, "gpsOut", "gcs1", "rmax1ob1", UB_ADMIN_FRAGMENT, pl, (uint16_t)n, 101);
    f[UB_FRAME_OFF_FINGERPRINT] ^= 1; /* another layout */
    fuzz_ignore(ub_frame_set_hop_limit(f, len, f[UB_FRAME_OFF_HOP_LIMIT]));
    seed_op(&s, 0, 0, f, len);
    n = ub_frag_write(pl, sizeof pl, 9, 0, 2, image, total - 1); /* not the type's size */
    seed_op(&s, 0, 0, f, seed_frame(f, "gpsOut", "gcs1", "rmax1ob1", UB_ADMIN_FRAGMENT, pl, (uint16_t)n, 102));
    const ub_type_desc_t *t2 = cat->instances[ub_catalogue_find_name(cat, "gcsMissionRmax1[1]")].type;
    n = ub_frag_write(pl, sizeof pl, 9, 0, 2, image, t2->packed_size);
    seed_op(&s, 0, 0, f, seed_frame(f, "gcsMissionRmax1[1]", "gcs1", "rmax1ob1", UB_ADMIN_FRAGMENT, pl, (uint16_t)n, 103));
    static const char *const srcs[3] = {"gcs1", "fcs20", "rmax1ob2"};
    for (uint16_t k = 0; k < 6; k++) { /* 3 sources x 2 transfers: more than UB_FRAG_SLOTS */
        n = ub_frag_write(pl, sizeof pl, (uint16_t)(200 + k), 0, 2, image, total);
        seed_op(&s, 0, 0, f, seed_frame(f, "gpsOut", srcs[k % 3], "rmax1ob1", UB_ADMIN_FRAGMENT, pl, (uint16_t)n, 110u + k));
    }
    seed_op(&s, 4, 255, tick, 0);
    seed_write(dir, "fragments_refused", &s);
    /* A node without fragment state: FRAGMENT frames dropped too_big. */
    s.buf[0] = 16;
    seed_write(dir, "fragments_no_state", &s);
}

/* The first link compact (byte 0 bit 2), then also with the smallest MTU (bit 3): packets a peer's compact
 * state makes of full frames, a cut packet, noise between delimiters, and a local publication the node
 * sends on the compact link (checked by capture_send), in fragments under the MTU. */
static void seed_compact(const char *dir, uint8_t *f) {
    static seed_t s;
    static ub_compact_t peer;
    uint8_t tick[1] = {0};
    uint8_t wire[UB_COMPACT_WIRE_MAX];
    uint8_t ids[3][UB_ENTITY_ID_LEN];
    fuzz_ignore(ub_entity_id("fcs20", ids[0]));
    fuzz_ignore(ub_entity_id("gcs1", ids[1]));
    fuzz_ignore(ub_entity_id("rmax1ob1", ids[2]));
    for (uint8_t mode = 4; mode <= 12; mode += 8) {
        ub_compact_init(&peer, &flightsw_catalogue, 9, NULL);
        ub_compact_set_local(&peer, (const uint8_t(*)[UB_ENTITY_ID_LEN])ids, 3, 1, 0);
        memset(&s, 0, sizeof s);
        s.buf[s.len++] = mode;
        seed_op(&s, 4, 10, tick, 0); /* the node's first LINK_HELLO round */
        for (uint32_t k = 0; k < 4; k++) {
            size_t n = k % 2 == 0 ? seed_data(f, "gpsOut", "gcs1", "rmax1ob1", 90 + k)
                                  : seed_request(f, "gpsOut", "gcs1", "rmax1ob1", UB_ADMIN_PUB_REQUEST, "gcs1", 90 + k);
            int w = ub_compact_link_encode(&peer, f, n, wire, sizeof wire);
            if (w > 0) seed_op(&s, 0, 0, wire, (size_t)w);
            if (w > 4 && k == 2) seed_op(&s, 0, 0, wire, (size_t)w / 2); /* cut: the rest is lost */
        }
        seed_op(&s, 0, 0, (const uint8_t[]){0x05, 0x11, 0x22, 0x00, 0x00, 0x03, 0x01}, 7); /* noise */
        seed_op(&s, 5, 1, (const uint8_t[]){0, 0, 0, 0, 100, 0, 0}, 7);
        seed_op(&s, 4, 200, tick, 0);
        seed_op(&s, 6, 1, tick, 0); /* push back, then errors */
        seed_op(&s, 4, 200, tick, 0);
        seed_op(&s, 6, 2, tick, 0);
        seed_op(&s, 4, 200, tick, 0);
        seed_write(dir, mode == 4 ? "compact_link" : "compact_link_mtu", &s);
    }
}

void ub_fuzz_write_seeds(const char *dir) {
    static seed_t s;
    uint8_t f[UB_FRAME_MAX];
    uint8_t tick[1] = {0};
    /* primary (rmax1ob1): the GCS asks for gpsOut, then data and admin traffic on several links. */
    memset(&s, 0, sizeof s);
    s.buf[s.len++] = 0;
    seed_op(&s, 0, 0, f, seed_request(f, "gpsOut", "gcs1", "rmax1ob1", UB_ADMIN_PUB_REQUEST, "gcs1", 1));
    seed_op(&s, 4, 20, tick, 0);
    seed_op(&s, 3, 1, f, seed_request(f, "imuOut", "gcs1", "rmax1ob1", UB_ADMIN_SUB_REQUEST, "fcs20", 2));
    seed_op(&s, 0, 2, f, seed_data(f, "imuOut", "fcs20", "rmax1ob1", 3));
    seed_op(&s, 4, 200, tick, 0);
    seed_op(&s, 0, 0, f, seed_data(f, "gpsOut", "gcs1", "fcs20", 4)); /* to be forwarded */
    seed_op(&s, 0, 0, f, seed_request(f, "gpsOut", "gcs1", "rmax1ob1", UB_ADMIN_PUB_STOP, "gcs1", 5));
    seed_op(&s, 4, 255, tick, 0);
    seed_write(dir, "primary_requests_and_data", &s);
    /* gcs: the operator's rows, their replies and data. */
    memset(&s, 0, sizeof s);
    s.buf[s.len++] = 1;
    uint8_t call[8] = {0};
    call[7] = 3; /* destination: gcs1 */
    int gps = ub_catalogue_find_name(&flightsw_catalogue, "gpsOut");
    ub_put_u16le(call, (uint16_t)gps);
    call[2] = 0;
    call[3] = 0; /* peer: rmax1ob1 */
    ub_put_u16le(call + 4, 100);
    seed_op(&s, 5, 4, call, sizeof call); /* admin: add row */
    seed_op(&s, 5, 5, (const uint8_t[]){0, 0, 0, 0, 0, 0, 0, 1}, 8);
    seed_op(&s, 4, 1, tick, 0);
    uint8_t reply[UB_PL_REPLY_LEN] = {0};
    reply[UB_PL_REPLY_DETAIL] = UB_ACK_FLOWING;
    seed_op(&s, 0, 0, f, seed_frame(f, "gpsOut", "rmax1ob1", "gcs1", UB_ADMIN_ACK, reply, sizeof reply, 9));
    seed_op(&s, 0, 0, f, seed_data(f, "gpsOut", "rmax1ob1", "gcs1", 10));
    seed_op(&s, 3, 1, f, seed_data(f, "gpsOut", "rmax1ob1", "gcs1", 11));
    seed_op(&s, 0, 0, f, seed_frame(f, "gpsOut", "rmax1ob1", "gcs1", UB_ADMIN_NACK, reply, sizeof reply, 12));
    seed_op(&s, 4, 255, tick, 0);
    seed_write(dir, "gcs_admin_rows", &s);
    /* Resealed operations with every arg bit, and a re-attach in the middle of a frame. */
    memset(&s, 0, sizeof s);
    s.buf[s.len++] = 0;
    size_t n = seed_data(f, "gpsOut", "gcs1", "rmax1ob1", 20);
    seed_op(&s, 1, 0x7c, f, n);
    seed_op(&s, 2, 0x3c, f, n);
    seed_op(&s, 0, 1, f, n / 2);
    seed_op(&s, 7, 1, tick, 0);
    seed_op(&s, 0, 1, f + n / 2, n - n / 2);
    seed_op(&s, 6, 1, tick, 0);
    seed_op(&s, 5, 0, call, sizeof call);
    seed_op(&s, 4, 30, tick, 0);
    seed_write(dir, "resealed_and_reattached", &s);
    seed_inspect(dir, f);
    seed_fragments(dir, f);
    seed_compact(dir, f);
}

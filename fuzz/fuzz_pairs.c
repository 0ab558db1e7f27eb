/*
 * Fuzz harness: a microcontroller's provisioning table (issue 23 item 8, ub_origin_load_pairs(); the format in
 * ub_origin.h and docs/security.md "Microcontrollers"), as the firmware reads it from its flash sector.
 *
 *   byte 0: flags; bit 0 set: the harness rewrites the last 4 bytes with the CRC-32C of the rest (so the
 *           fuzzer reaches past the CRC); bytes 1..: the table
 *
 * Properties checked (a failure aborts): a refused table installs no pair; an accepted one has the length its
 * count says and a right CRC, names no pair with itself, and every pair it installed seals a frame to its peer
 * with the tag the table's key board->peer makes (later entries of a peer listed twice win), while a peer
 * outside the table is refused (`no_identity`: no store, no key agreement).
 */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "flightsw.h"
#include "fuzz_util.h"
#include "ub/ub_frame.h"
#include "ub/ub_node.h"
#include "ub/ub_node_svc.h"
#include "ub/ub_origin.h"

static ub_node_t g_node;
static ub_origin_t g_org;
static uint8_t g_buf[UB_ORIGIN_PAIRS_LEN(255) + 64];

int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    return 0;
}

static void put_crc(uint8_t *t, size_t len) {
    uint32_t crc = ub_crc32c(t, len - 4u);
    for (unsigned i = 0; i < 4; i++) t[len - 4u + i] = (uint8_t)(crc >> (8u * i));
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 1 || size - 1 > sizeof g_buf) return 0;
    size_t len = size - 1;
    memcpy(g_buf, data + 1, len);
    if ((data[0] & 1u) && len >= 4) put_crc(g_buf, len);
    ub_origin_options_t none;
    memset(&none, 0, sizeof none);
    FUZZ_CHECK(ub_origin_init(&g_org, &none) == UB_OK, "init");
    ub_origin_provision_t prov;
    int n = ub_origin_load_pairs(&g_org, g_buf, len, &prov);
    if (n < 0) {
        FUZZ_CHECK(ub_origin_cached(&g_org) == 0, "refused table (%d) left %zu pairs", n, ub_origin_cached(&g_org));
        return 0;
    }
    FUZZ_CHECK(len == UB_ORIGIN_PAIRS_LEN((size_t)n) && memcmp(g_buf, UB_ORIGIN_PAIRS_MAGIC, 4) == 0,
               "accepted a table of %zu bytes for %d pairs", len, n);
    FUZZ_CHECK(ub_crc32c(g_buf, len - 4u) == ((uint32_t)g_buf[len - 4u] | (uint32_t)g_buf[len - 3u] << 8 |
                                             (uint32_t)g_buf[len - 2u] << 16 | (uint32_t)g_buf[len - 1u] << 24),
               "accepted a bad CRC");
    FUZZ_CHECK(prov.pairs == (uint8_t)n && ub_origin_cached(&g_org) <= (size_t)n, "pairs %u of %d", prov.pairs, n);
    FUZZ_CHECK(memcmp(prov.entity_id, g_buf + 8, UB_ENTITY_ID_LEN) == 0, "entity");
    /* a node hosting the table's entity; each pair seals with the table's key board->peer */
    if (ub_entity_id_is_zero(prov.entity_id) || ub_entity_id_is_link_local(prov.entity_id)) return 0;
    FUZZ_CHECK(ub_node_init(&g_node, &flightsw_catalogue, NULL) == UB_OK, "node");
    int self = ub_node_add_entity(&g_node, prov.entity_id, true);
    if (self < 0) return 0;
    int slot = ub_node_entity_slot(&g_node, self);
    uint8_t payload[4] = {1, 2, 3, 4};
    for (int i = 0; i < n; i++) {
        const uint8_t *e = g_buf + UB_ORIGIN_PAIRS_HEADER_LEN + (size_t)i * UB_ORIGIN_PAIRS_ENTRY_LEN;
        FUZZ_CHECK(!ub_entity_id_eq(e, prov.entity_id), "a pair with itself");
        if (ub_entity_id_is_link_local(e)) continue; /* link-local frames carry no origin block */
        const uint8_t *k_tx = e + UB_ENTITY_ID_LEN;
        for (int j = i + 1; j < n; j++) { /* a later entry of the same peer wins */
            const uint8_t *f = g_buf + UB_ORIGIN_PAIRS_HEADER_LEN + (size_t)j * UB_ORIGIN_PAIRS_ENTRY_LEN;
            if (ub_entity_id_eq(f, e)) k_tx = f + UB_ENTITY_ID_LEN;
        }
        ub_frame_header_t h;
        memset(&h, 0, sizeof h);
        memcpy(h.dest_id, e, UB_ENTITY_ID_LEN);
        memcpy(h.src_id, prov.entity_id, UB_ENTITY_ID_LEN);
        h.hop_limit = 8;
        h.payload_size = sizeof payload;
        ub_drop_reason_t drop = UB_DROP_NO_ROUTE;
        FUZZ_CHECK(g_org.svc.seal(&g_org.svc, &g_node, slot, &h, payload, 1, &drop) == 1, "pair %d not sealed", i);
        uint8_t want[UB_FRAME_ORIGIN_TAG_LEN];
        FUZZ_CHECK(ub_origin_tag(k_tx, &h, payload, want) == UB_OK, "tag");
        FUZZ_CHECK(memcmp(want, h.origin_tag, sizeof want) == 0, "pair %d sealed with another key", i);
    }
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dest_id, "zz-stranger", 11);
    memcpy(h.src_id, prov.entity_id, UB_ENTITY_ID_LEN);
    h.hop_limit = 8;
    bool listed = false;
    for (int i = 0; i < n; i++)
        listed |= ub_entity_id_eq(g_buf + UB_ORIGIN_PAIRS_HEADER_LEN + (size_t)i * UB_ORIGIN_PAIRS_ENTRY_LEN, h.dest_id);
    ub_drop_reason_t drop = UB_DROP_NO_ROUTE;
    if (!listed) FUZZ_CHECK(g_org.svc.seal(&g_org.svc, &g_node, slot, &h, payload, 1, &drop) < 0 &&
                                drop == UB_DROP_NO_IDENTITY, "a stranger sealed");
    return 0;
}

void ub_fuzz_write_seeds(const char *dir) {
    static const char *const peers[3] = {"gcs1", "rmax1ob1", "rmax1ob2"};
    uint8_t t[UB_ORIGIN_PAIRS_LEN(3) + 1];
    memset(t, 0, sizeof t);
    t[0] = 1; /* the harness fixes the CRC */
    uint8_t *p = t + 1;
    memcpy(p, UB_ORIGIN_PAIRS_MAGIC, 4);
    p[4] = 1;
    p[5] = 3;
    memcpy(p + 8, "fcs20", 5);
    p[20] = 1;
    p[21] = 1;
    for (unsigned i = 0; i < 32; i++) p[24 + i] = (uint8_t)(0x40u + i);
    for (unsigned k = 0; k < 3; k++) {
        uint8_t *e = p + UB_ORIGIN_PAIRS_HEADER_LEN + k * UB_ORIGIN_PAIRS_ENTRY_LEN;
        memcpy(e, peers[k], strlen(peers[k]));
        for (unsigned i = 0; i < 32; i++) e[UB_ENTITY_ID_LEN + i] = (uint8_t)(k * 32u + i);
    }
    put_crc(p, UB_ORIGIN_PAIRS_LEN(3));
    fuzz_write_seed(dir, "three_pairs", t, sizeof t);
    t[0] = 0; /* the CRC as written: the same table, taken as it is */
    fuzz_write_seed(dir, "three_pairs_crc", t, sizeof t);
    p[5] = 0; /* an empty table (no pairs), its CRC fixed by the harness */
    t[0] = 1;
    fuzz_write_seed(dir, "empty", t, 1 + UB_ORIGIN_PAIRS_LEN(0));
    p[5] = 3;
    memcpy(p + UB_ORIGIN_PAIRS_HEADER_LEN + 2 * UB_ORIGIN_PAIRS_ENTRY_LEN, peers[0], strlen(peers[0])); /* twice */
    fuzz_write_seed(dir, "peer_twice", t, sizeof t);
}

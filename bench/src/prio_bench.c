/* Commands beside a telemetry flood on a 57,600-baud radio, with and without priorities (bench figure 11,
 * issue 28).
 *
 *     prio_bench SECONDS PRIO LABEL CMD_FILE BULK_FILE|- TEL_FILE:HZ...
 *        -> one line "prio<TAB>LABEL<TAB>PRIO<TAB>bulk<TAB>commands<TAB>p50_ms<TAB>p99_ms<TAB>max_ms<TAB>
 *                     tel_offered/s<TAB>tel_delivered/s<TAB>tel_age_p50_ms<TAB>tel_age_p99_ms<TAB>shed/s<TAB>
 *                     refused/s<TAB>bulk_B/s"
 *
 * The medium is ub_impair (ub_impair.h) at 5,760 bytes/s on the injected clock, stepped 1 ms at a time, the
 * code the ports put in front of a radio; PRIO=1 sets its `prio` (ub_prio.h: per-class queues, the medium
 * takes the highest class waiting whenever it is free), PRIO=0 keeps send order (a 32-frame FIFO, as a
 * MAVLink radio or router has). The frames are real ones (bench/prio_bench.py writes them: uavbus compact
 * packets made by the C codec, MAVLink 2 frames by pymavlink; u16 LE length + bytes per frame); the medium
 * only counts their bytes, so the bench writes a frame number into each copy's first 4 bytes to see, at the
 * far side, which frame arrived when.
 *
 * The sender does what a node does: each telemetry stream offers its next frame at its rate (a frame the
 * link refuses is dropped, counted `refused`: the node's backpressure); a command is offered every 250 ms
 * (plus 0-49 ms, seeded) and, while the link refuses it, again every millisecond (the application's retry)
 * -- its latency runs from its first offer to its last byte at the far side; fragments of a large directory
 * (BULK_FILE), when given, are offered as fast as the link takes them (a transfer paused by push-back goes on
 * at the next tick). Classes come from ub_prio_class_of(): the command is an admin frame, telemetry DATA,
 * fragments FRAGMENT. The first simulated second is warm-up (the queues fill); the figures count the rest.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ub/ub_impair.h"
#include "ub/ub_prio.h"

#define MAX_FRAMES 256
#define MAX_STREAMS 4
#define MAX_CMDS 4096
#define MAX_TEL 200000
#define KIND(id) ((id) >> 28)
#define NUM(id) ((id) & 0x0FFFFFFFu)
enum { K_CMD = 1, K_TEL = 2, K_BULK = 3 };

typedef struct stream {
    uint8_t frames[MAX_FRAMES][UB_FRAME_MAX];
    uint16_t lens[MAX_FRAMES];
    int n, next;
    uint64_t period_us, due_us;
} stream_t;

static stream_t tel[MAX_STREAMS], cmd, bulk;
static ub_impair_t imp; /* large: not on the stack */
static uint64_t cmd_sent[MAX_CMDS], cmd_lat[MAX_CMDS], tel_sent[MAX_TEL], tel_age[MAX_TEL];
static size_t n_cmd_lat, n_tel_age;
static uint64_t warm_ms = 1000, bulk_bytes, tel_delivered;

static int load(stream_t *s, const char *path) {
    FILE *f = fopen(path, "rb");
    if (f == NULL) return -1;
    uint8_t hdr[2];
    while (s->n < MAX_FRAMES && fread(hdr, 1, 2, f) == 2) {
        uint16_t len = (uint16_t)(hdr[0] | hdr[1] << 8);
        if (len < 4 || len > UB_FRAME_MAX || fread(s->frames[s->n], 1, len, f) != len) {
            fclose(f);
            return -1;
        }
        s->lens[s->n++] = len;
    }
    fclose(f);
    return s->n;
}

static int sink_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)impl;
    uint32_t id;
    memcpy(&id, frame, 4);
    if (now_ms < warm_ms) return UB_OK;
    if (KIND(id) == K_CMD && NUM(id) < MAX_CMDS && cmd_sent[NUM(id)] >= warm_ms)
        cmd_lat[n_cmd_lat++] = now_ms - cmd_sent[NUM(id)];
    if (KIND(id) == K_TEL && NUM(id) < MAX_TEL) {
        tel_delivered++;
        if (tel_sent[NUM(id)] >= warm_ms) tel_age[n_tel_age++] = now_ms - tel_sent[NUM(id)];
    }
    if (KIND(id) == K_BULK) bulk_bytes += len;
    return UB_OK;
}
static const ub_link_ops_t sink_ops = {.kind = "sink", .send = sink_send, .fileno = NULL};

/* Offers stream `s`'s next frame numbered `id` in class `cls`. @return what the link answered. */
static int offer(stream_t *s, uint32_t id, ub_prio_class_t cls, uint64_t now_ms) {
    uint8_t copy[UB_FRAME_MAX];
    uint16_t len = s->lens[s->next];
    memcpy(copy, s->frames[s->next], len);
    memcpy(copy, &id, 4);
    int rc = ub_impair_ops.send_class(&imp, copy, len, (uint8_t)cls, now_ms);
    if (rc >= 0) s->next = (s->next + 1) % s->n;
    return rc;
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}
static double pct(uint64_t *v, size_t n, double p) {
    if (n == 0) return -1.0;
    qsort(v, n, sizeof *v, cmp_u64);
    size_t i = (size_t)(p * (double)(n - 1) + 0.5);
    return (double)v[i];
}

int main(int argc, char **argv) {
    if (argc < 7) {
        fprintf(stderr, "usage: prio_bench SECONDS PRIO LABEL CMD_FILE BULK_FILE|- TEL_FILE:HZ...\n");
        return 2;
    }
    uint64_t seconds = strtoull(argv[1], NULL, 10);
    uint32_t prio = (uint32_t)strtoul(argv[2], NULL, 10);
    const char *label = argv[3];
    if (load(&cmd, argv[4]) <= 0) {
        fprintf(stderr, "prio_bench: %s: no frames (u16 LE length + bytes, each >= 4 bytes)\n", argv[4]);
        return 1;
    }
    bool with_bulk = strcmp(argv[5], "-") != 0;
    if (with_bulk && load(&bulk, argv[5]) <= 0) {
        fprintf(stderr, "prio_bench: %s: no frames\n", argv[5]);
        return 1;
    }
    int n_tel = 0;
    double tel_hz = 0;
    for (int a = 6; a < argc && n_tel < MAX_STREAMS; a++, n_tel++) {
        char path[4096];
        const char *colon = strrchr(argv[a], ':');
        double hz = colon != NULL ? strtod(colon + 1, NULL) : 0;
        size_t pl = colon != NULL ? (size_t)(colon - argv[a]) : 0;
        if (hz <= 0 || pl == 0 || pl >= sizeof path) {
            fprintf(stderr, "prio_bench: '%s': expected FILE:HZ (e.g. compact-ATTITUDE.frames:50)\n", argv[a]);
            return 2;
        }
        memcpy(path, argv[a], pl);
        path[pl] = '\0';
        if (load(&tel[n_tel], path) <= 0) {
            fprintf(stderr, "prio_bench: %s: no frames\n", path);
            return 1;
        }
        tel[n_tel].period_us = (uint64_t)(1e6 / hz + 0.5);
        tel[n_tel].due_us = (uint64_t)n_tel * 1000u; /* streams out of phase by a millisecond */
        tel_hz += hz;
    }
    ub_impair_params_t p = {.rate_Bps = 5760, .prio = prio};
    ub_impair_init(&imp, &p, 1);
    if (ub_impair_wrap(&imp, &sink_ops, NULL) != UB_OK) return 1;

    const ub_prio_class_t c_cmd = ub_prio_class_of(UB_ADMIN_PUB_STOP, UB_PRIO_TELEMETRY);
    const ub_prio_class_t c_tel = ub_prio_class_of(UB_ADMIN_DATA, UB_PRIO_TELEMETRY);
    const ub_prio_class_t c_bulk = ub_prio_class_of(UB_ADMIN_FRAGMENT, UB_PRIO_TELEMETRY);
    uint64_t rng = 0x2545F4914F6CDD1DULL, next_cmd_at = 500;
    uint32_t n_cmds = 0, n_tel_ids = 0, n_bulk = 0;
    bool cmd_pending = false;
    uint64_t tel_offered = 0, refused = 0, shed = 0;
    const uint64_t end_ms = (seconds + 1) * 1000u;
    for (uint64_t now = 0; now < end_ms; now++) {
        (void)ub_impair_service(&imp, now);
        if (!cmd_pending && now >= next_cmd_at && n_cmds + 1 < MAX_CMDS) {
            cmd_pending = true;
            cmd_sent[++n_cmds] = now;
            rng ^= rng >> 12, rng ^= rng << 25, rng ^= rng >> 27;
            next_cmd_at = now + 250 + (rng * 0x2545F4914F6CDD1DULL >> 33) % 50;
        }
        if (cmd_pending) {
            int rc = offer(&cmd, (uint32_t)K_CMD << 28 | n_cmds, c_cmd, now);
            if (rc >= 0) cmd_pending = false, shed += (uint64_t)rc;
        }
        for (int s = 0; s < n_tel; s++) {
            while (tel[s].due_us <= now * 1000u) {
                tel[s].due_us += tel[s].period_us;
                if (n_tel_ids + 1 >= MAX_TEL) continue;
                uint32_t id = ++n_tel_ids;
                tel_sent[id] = now;
                if (now >= warm_ms) tel_offered++;
                int rc = offer(&tel[s], (uint32_t)K_TEL << 28 | id, c_tel, now);
                if (rc < 0 && now >= warm_ms) refused++;
                if (rc > 0 && now >= warm_ms) shed += (uint64_t)rc;
            }
        }
        while (with_bulk && offer(&bulk, (uint32_t)K_BULK << 28 | (++n_bulk & 0x0FFFFFFFu), c_bulk, now) == UB_OK) {
        }
    }
    if (!ub_impair_check_balance(&imp)) {
        fprintf(stderr, "prio_bench: %s: impairment counters do not balance\n", label);
        return 1;
    }
    double secs = (double)seconds;
    size_t n_lat = n_cmd_lat;
    double p50 = pct(cmd_lat, n_lat, 0.50), p99 = pct(cmd_lat, n_lat, 0.99), mx = pct(cmd_lat, n_lat, 1.0);
    double a50 = pct(tel_age, n_tel_age, 0.50), a99 = pct(tel_age, n_tel_age, 0.99);
    (void)tel_hz;
    printf("prio\t%s\t%u\t%d\t%zu\t%.0f\t%.0f\t%.0f\t%.1f\t%.1f\t%.0f\t%.0f\t%.1f\t%.1f\t%.0f\n", label, prio,
           with_bulk ? 1 : 0, n_lat, p50, p99, mx, (double)tel_offered / secs, (double)tel_delivered / secs, a50, a99,
           (double)shed / secs, (double)refused / secs, (double)bulk_bytes / secs);
    return 0;
}

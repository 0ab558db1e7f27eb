/* Messages per second through a simulated radio (bench figure 9b, issue #15).
 *
 *     radio_bench RATE_BPS MTU SECONDS FILE...   -> lines "radio<TAB>FILE<TAB>msgs/s<TAB>bytes/s<TAB>too_big"
 *
 * Each FILE is a stream of frames (u16 LE length + bytes; bench/wire_bench.py writes them: uavbus compact
 * packets made by the C codec, MAVLink 2 frames made by pymavlink). Every stream goes through its own
 * ub_impair (runtime_c/include/ub/ub_impair.h) holding the link to RATE_BPS bytes per second and a packet
 * MTU, on an injected clock: the sender offers the stream's frames in a loop as fast as the radio takes them
 * (it pushes back with UB_ERR_AGAIN once its 32-frame buffer is full, as a modem with flow control does), for
 * SECONDS simulated seconds; the figure is what reaches the far side. Same model, same clock, for every
 * stream: the ratio is the bytes per message, measured through the code the ports use.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ub/ub_impair.h"

#define MAX_FRAMES 1024

typedef struct {
    uint64_t frames, bytes;
} sink_t;

static int sink_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)frame, (void)now_ms;
    sink_t *s = impl;
    s->frames++;
    s->bytes += len;
    return UB_OK;
}

static const ub_link_ops_t sink_ops = {.kind = "sink", .send = sink_send, .fileno = NULL};

static uint8_t frames[MAX_FRAMES][UB_FRAME_MAX];
static uint16_t lens[MAX_FRAMES];
static ub_impair_t imp; /* large: not on the stack */

static int load(const char *path) {
    FILE *f = fopen(path, "rb");
    if (f == NULL) return -1;
    int n = 0;
    uint8_t hdr[2];
    while (n < MAX_FRAMES && fread(hdr, 1, 2, f) == 2) {
        lens[n] = (uint16_t)(hdr[0] | hdr[1] << 8);
        if (lens[n] > UB_FRAME_MAX || fread(frames[n], 1, lens[n], f) != lens[n]) {
            fclose(f);
            return -1;
        }
        n++;
    }
    fclose(f);
    return n;
}

int main(int argc, char **argv) {
    if (argc < 5) {
        fprintf(stderr, "usage: radio_bench RATE_BPS MTU SECONDS FILE...\n");
        return 2;
    }
    uint32_t rate = (uint32_t)strtoul(argv[1], NULL, 10), mtu = (uint32_t)strtoul(argv[2], NULL, 10);
    uint64_t seconds = strtoull(argv[3], NULL, 10);
    for (int a = 4; a < argc; a++) {
        int n = load(argv[a]);
        if (n <= 0) {
            fprintf(stderr, "radio_bench: %s: no frames (u16 LE length + bytes expected)\n", argv[a]);
            return 1;
        }
        ub_impair_params_t p = {0};
        p.rate_Bps = rate;
        p.mtu = mtu;
        ub_impair_init(&imp, &p, 1);
        sink_t sink = {0};
        if (ub_impair_wrap(&imp, &sink_ops, &sink) != UB_OK) return 1;
        uint64_t offered = 0;
        int k = 0;
        /* A warm-up second fills the radio's buffer; the figure counts what arrives after it. */
        uint64_t warm_frames = 0, warm_bytes = 0;
        for (uint64_t now = 0; now < (seconds + 1) * 1000u; now++) {
            if (now == 1000u) warm_frames = sink.frames, warm_bytes = sink.bytes;
            (void)ub_impair_service(&imp, now);
            for (;;) {
                int rc = ub_impair_ops.send(&imp, frames[k], lens[k], now);
                if (rc == UB_ERR_AGAIN) break;
                offered++;
                k = (k + 1) % n;
                if (rc != UB_OK) break; /* too big for the MTU: counted; the next one next millisecond */
            }
        }
        const ub_impair_stats_t *st = ub_impair_stats(&imp);
        printf("radio\t%s\t%.1f\t%.1f\t%llu\n", argv[a], (double)(sink.frames - warm_frames) / (double)seconds,
               (double)(sink.bytes - warm_bytes) / (double)seconds, (unsigned long long)st->too_big);
        if (!ub_impair_check_balance(&imp)) {
            fprintf(stderr, "radio_bench: %s: impairment counters do not balance\n", argv[a]);
            return 1;
        }
    }
    return 0;
}

/* ub_ports_drain() (ub_ports.h): the input side of a forwarding loop, waiting for company in C. ppoll() waits
 * in microseconds (poll() only in milliseconds: an idle gap of a few tens of µs is the point). */
#define _GNU_SOURCE
#include <string.h>
#include <time.h>

#include "ub/ub_node.h"
#include "ub/ub_ports.h"

static uint64_t mono_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* The ports' descriptors into how->fds, bumping fds_gen when they differ from the last drain's. */
static int refresh_fds(const ub_ports_t *ports, ub_ports_drain_t *how) {
    struct pollfd now[UB_DRAIN_FDS];
    int n = ub_ports_pollfds(ports, now, UB_DRAIN_FDS - 1);
    if (n < 0) return n;
    bool same = n == how->nfds;
    for (int i = 0; same && i < n; i++) same = now[i].fd == how->fds[i].fd && now[i].events == how->fds[i].events;
    if (!same) {
        memcpy(how->fds, now, sizeof now[0] * (size_t)n);
        how->nfds = n;
        how->fds_gen++;
    }
    return n;
}

int ub_ports_drain(ub_ports_t *ports, ub_ports_drain_t *how, uint64_t now_ms) {
    if (ports == NULL || how == NULL || ports->node == NULL) return UB_ERR_INVAL;
    how->drains++;
    uint64_t start = 0;
    ub_drain_end_t end = UB_DRAIN_EMPTY;
    /* Each round services every port (reading all they hold); the gap between rounds is slept through
     * whole, watching only wake_fd: a site sending a datagram every few µs costs one round per gap, not a
     * wake-up per datagram. The input is idle when a round after a gap read nothing. The first gap is
     * idle_us; each busy round doubles the next (perf on gwA under a blast: 15 % of its samples were the
     * scheduler switching around 20 µs gaps). */
    uint64_t gap = how->idle_us;
    for (bool first = true;; first = false) {
        int got = ub_ports_service(ports, now_ms); /* driver errors are counted per port */
        how->rounds++;
        size_t pending = how->pending != NULL ? *how->pending : 0;
        if (pending == 0) break;
        if (pending >= how->flush_at) {
            end = UB_DRAIN_FULL;
            break;
        }
        if (!first && got <= 0) {
            end = UB_DRAIN_IDLE;
            break;
        }
        uint64_t t = mono_us();
        if (start == 0) start = t;
        if (t - start >= how->max_us) {
            end = UB_DRAIN_AGED;
            break;
        }
        /* The gap doubles each round that read something: a busy input costs a few rounds per drain (a
         * sleep and a wake-up each), not one per datagram or two; a lone frame waits one idle_us. */
        if (!first && gap < how->max_us) gap *= 2; /* here the round read something: not first, got > 0 */
        uint64_t wait = gap, left = how->max_us - (t - start);
        if (wait > left) wait = left;
        struct timespec ts = {.tv_sec = (time_t)(wait / 1000000u), .tv_nsec = (long)(wait % 1000000u) * 1000L};
        if (how->wake_fd >= 0) {
            struct pollfd w = {.fd = how->wake_fd, .events = POLLIN};
            int r = ppoll(&w, 1, &ts, NULL);
            if (r > 0) {
                end = UB_DRAIN_WOKEN;
                break;
            }
        } else if (wait > 0) {
            (void)nanosleep(&ts, NULL); /* EINTR: a shorter gap, the next round decides */
        }
    }
    ub_node_tick(ports->node, now_ms);
    /* What the rounds' last service and the tick queued on batching ports leaves now: the caller sleeps in
     * poll() next, and a queue it does not know of would wait for its timeout. */
    (void)ub_ports_flush(ports);
    int n = refresh_fds(ports, how);
    how->ends[end]++;
    return n < 0 ? n : (int)end;
}

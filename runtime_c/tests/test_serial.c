/*
 * The serial driver over a pseudo-terminal pair: a subscription runs over the
 * "wire"; frames survive arbitrary read chunking and garbage injected between
 * them (seeded, so every run writes the same bytes); termios settings and
 * argument errors.
 */
#define _XOPEN_SOURCE 700 /* posix_openpt, grantpt, unlockpt, ptsname, symlink */

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

#include "support/ub_test_link_events.h"
#include "support/ub_test_pair.h"
#include "support/ub_test_pty.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_serial.h"

typedef struct serial_pair {
    pair_t *p;
    int master;
    ub_serial_t slave_end;  /* sub side: the "device" */
    ub_serial_t master_end; /* pub side */
} serial_pair_t;

static serial_pair_t *serial_pair_new(void) {
    serial_pair_t *s = calloc(1, sizeof *s);
    assert_non_null(s);
    s->p = pair_new(NULL);
    char slave_path[128];
    s->master = open_pty_master(slave_path, sizeof slave_path, 0);
    /* Raw mode on the slave first: with the default line discipline the pty would echo and translate bytes. */
    assert_int_equal(ub_serial_open(&s->slave_end, slave_path, 115200), UB_OK);
    assert_int_equal(ub_serial_adopt(&s->master_end, s->master, 0), UB_OK);
    assert_int_equal(ub_serial_attach(&s->slave_end, s->p->sub_node, s->p->sub_link), UB_OK);
    assert_int_equal(ub_serial_attach(&s->master_end, s->p->pub_node, s->p->pub_link), UB_OK);
    return s;
}

static void serial_pair_free(serial_pair_t *s) {
    ub_serial_close(&s->slave_end);
    ub_serial_close(&s->master_end); /* adopted: not closed by the driver */
    close(s->master);
    pair_free(s->p);
    free(s);
}

/* The pty hands written bytes to the other side asynchronously: wait briefly (real time) for input. */
static void wait_input(serial_pair_t *s, int wait_ms) {
    struct pollfd fds[2] = {{.fd = ub_serial_fileno(&s->slave_end), .events = POLLIN},
                            {.fd = s->master, .events = POLLIN}};
    (void)poll(fds, 2, wait_ms);
}

/* Serves both ends until every byte one end wrote has been read by the other (a pty loses nothing in raw
 * mode, but hands bytes over on the kernel's time, not the test's simulated clock): the simulated clock
 * moves on only once the wire is empty, so the counts below do not depend on how busy the machine is.
 * Waits at most ~2 s of real time, then lets the assertions speak. */
static void exchange(ub_serial_t *a, ub_node_t *na, ub_serial_t *b, ub_node_t *nb, uint64_t now_ms) {
    for (int k = 0; k < 200; k++) {
        assert_true(ub_serial_service(a, na, now_ms) >= 0);
        assert_true(ub_serial_service(b, nb, now_ms) >= 0);
        const ub_serial_stats_t *sa = ub_serial_stats(a), *sb = ub_serial_stats(b);
        if (sb->bytes_in >= sa->bytes_out && sa->bytes_in >= sb->bytes_out) return;
        struct pollfd fds[2] = {{.fd = ub_serial_fileno(a), .events = POLLIN}, {.fd = ub_serial_fileno(b), .events = POLLIN}};
        (void)poll(fds, 2, 10);
    }
}

static void step(serial_pair_t *s, uint64_t now_ms) {
    ub_node_tick(s->p->pub_node, now_ms);
    ub_node_tick(s->p->sub_node, now_ms);
    exchange(&s->master_end, s->p->pub_node, &s->slave_end, s->p->sub_node, now_ms);
}

static void test_two_nodes_exchange_over_a_pty(void **state) {
    (void)state;
    serial_pair_t *s = serial_pair_new();
    pair_t *p = s->p;
    struct termios tio;
    assert_int_equal(tcgetattr(ub_serial_fileno(&s->slave_end), &tio), 0);
    assert_int_equal(cfgetospeed(&tio), B115200);
    assert_int_equal(tio.c_cflag & CSIZE, CS8);
    assert_int_equal(tio.c_cflag & (PARENB | CSTOPB), 0);
    assert_int_equal(tio.c_lflag & (ICANON | ECHO), 0);

    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, 0) >= 0);
    for (uint64_t now = 0; now < 1000; now++) step(s, now);
    size_t got = delivery_count(&p->log, p->sub, TEST_GPS, 0, 1000);
    assert_in_range(got, 15, 21);
    assert_memory_equal(&p->gps_dst, &p->gps_src, sizeof p->gps_src);
    assert_int_equal(s->master_end.stats.bytes_out, ub_node_link(p->pub_node, p->pub_link)->counters.bytes_out);
    assert_true(ub_node_link(p->pub_node, p->pub_link)->counters.frames_in >= 1); /* the subscription request */
    serial_pair_free(s);
}

/* xorshift64: the test's own seeded byte source. */
static uint64_t next_random(uint64_t *state) {
    uint64_t x = *state;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    *state = x;
    return x;
}

#define N_FRAMES 30
#define STREAM_MAX (N_FRAMES * (UB_FRAME_MAX + 64))

static void test_frames_survive_chunking_and_garbage(void **state) {
    (void)state;
    serial_pair_t *s = serial_pair_new();
    pair_t *p = s->p;
    /* Capture real DATA frames from the pub node instead of sending them on the pty. */
    capture_t *cap = calloc(1, sizeof *cap);
    assert_non_null(cap);
    assert_int_equal(ub_node_link_attach(p->pub_node, p->pub_link, &capture_ops, cap), UB_OK);
    for (int i = 0; i < N_FRAMES; i++)
        assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0), 1);
    assert_int_equal(cap->n, N_FRAMES);

    /* Stream: garbage (random bytes; every 3rd time a stray sync word, every 5th a frame's first half), then a
     * frame; repeat. */
    uint8_t *stream = calloc(1, STREAM_MAX);
    assert_non_null(stream);
    size_t len = 0;
    uint64_t rng = 0x5eed5eed12345678ULL;
    size_t garbage = 0;
    for (size_t f = 0; f < N_FRAMES; f++) {
        size_t junk = next_random(&rng) % 40;
        for (size_t j = 0; j < junk; j++) stream[len++] = (uint8_t)next_random(&rng);
        if (f % 3 == 1) {
            stream[len++] = UB_SYNC0;
            stream[len++] = UB_SYNC1;
            junk += 2;
        }
        if (f % 5 == 2) {
            memcpy(stream + len, cap->frame[f], cap->len[f] / 2); /* a cut-off frame */
            len += cap->len[f] / 2;
            junk += cap->len[f] / 2;
        }
        garbage += junk;
        memcpy(stream + len, cap->frame[f], cap->len[f]);
        len += cap->len[f];
    }

    /* Write in random chunks of 1..64 bytes, serving the slave between writes. */
    size_t off = 0;
    for (int i = 0; i < 100000 && off < len; i++) {
        size_t chunk = 1 + next_random(&rng) % 64;
        if (chunk > len - off) chunk = len - off;
        ssize_t n = write(s->master, stream + off, chunk);
        if (n > 0) off += (size_t)n;
        else assert_true(n < 0 && errno == EAGAIN);
        assert_true(ub_serial_service(&s->slave_end, p->sub_node, 0) >= 0);
    }
    assert_int_equal(off, len);
    for (int i = 0; i < 200 && p->log.n < N_FRAMES; i++) {
        wait_input(s, 5);
        assert_true(ub_serial_service(&s->slave_end, p->sub_node, 0) >= 0);
    }
    assert_int_equal(p->log.n, N_FRAMES);
    for (size_t i = 0; i < N_FRAMES; i++) assert_int_equal(p->log.d[i].seq, i + 1);
    const ub_link_t *link = ub_node_link(p->sub_node, p->sub_link);
    assert_int_equal(link->counters.frames_in, N_FRAMES);
    assert_int_equal(s->slave_end.stats.bytes_in, len);
    /* Everything that was not a delivered frame is accounted for as garbage or rejected candidates. */
    assert_int_equal(link->decoder.stats.bytes_ok + garbage, len);
    assert_true(link->decoder.stats.garbage_bytes > 0);
    uint64_t rejected = 0;
    for (int r = 0; r < UB_RX_REASON_COUNT; r++)
        rejected += ub_node_link_bad_frames(p->sub_node, p->sub_link, (ub_rx_reason_t)r);
    assert_true(rejected >= N_FRAMES / 3); /* the stray sync words and cut-off frames were candidates, then refused */
    free(stream);
    free(cap);
    serial_pair_free(s);
}

/* A hang-up: the far end of the pty closes (as a USB adapter is pulled): the driver notices at once,
 * counts it, closes the descriptor (a hung-up tty polls readable forever: before, the node spun on it at
 * 56-80 % of a core and no counter moved), refuses sends as closed, and reopens the device by path with
 * backoff when it comes back; the subscription then flows again. The device path is a symlink, as udev
 * gives a re-plugged adapter, pointed at a new pty. */
static void test_hangup_detected_counted_and_reopened(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    char slave_path[128], link_path[96];
    int master = open_pty_master(slave_path, sizeof slave_path, 0);
    pty_symlink(link_path, sizeof link_path, "tty", slave_path);
    ub_serial_t dev, far;
    assert_int_equal(ub_serial_open(&dev, link_path, 115200), UB_OK);
    assert_int_equal(ub_serial_adopt(&far, master, 0), UB_OK);
    assert_int_equal(ub_serial_attach(&dev, p->sub_node, p->sub_link), UB_OK);
    assert_int_equal(ub_serial_attach(&far, p->pub_node, p->pub_link), UB_OK);
    assert_int_equal(ub_serial_state(&dev), UB_SERIAL_UP);
    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 20, 0) >= 0);
    uint64_t now = 0;
    for (; now < 400; now += 10) {
        ub_node_tick(p->pub_node, now);
        ub_node_tick(p->sub_node, now);
        (void)poll(&(struct pollfd){.fd = master, .events = POLLIN}, 1, 2);
        assert_true(ub_serial_service(&far, p->pub_node, now) >= 0);
        assert_true(ub_serial_service(&dev, p->sub_node, now) >= 0);
    }
    uint64_t before = p->log.n;
    assert_true(before > 5);
    link_events_t ev;
    assert_int_equal(link_events_attach(&ev, p->sub_node), UB_OK);

    /* The far end goes away. */
    ub_serial_close(&far);
    close(master);
    assert_int_equal(ub_serial_service(&dev, p->sub_node, now), 0);
    /* Transport evidence: the hang-up reaches the node's services as a link event in that very call. */
    assert_int_equal(ev.downs, 1);
    assert_int_equal(ev.last_link, p->sub_link);
    assert_int_equal(ev.last_ms, now);
    const ub_serial_stats_t *st = ub_serial_stats(&dev);
    assert_int_equal(st->hangups, 1);
    assert_int_equal(ub_serial_state(&dev), UB_SERIAL_DOWN);
    assert_int_equal(ub_serial_fileno(&dev), -1); /* nothing left to poll: no busy loop */
    assert_int_equal(ub_link_fileno(ub_node_link(p->sub_node, p->sub_link)), -1);
    uint64_t due = 0;
    assert_true(ub_serial_next_retry(&dev, &due));
    assert_int_equal(due, now + UB_SERIAL_RETRY_MIN_MS);
    /* Sends while down are refused as closed, and counted. */
    const ub_link_t *l = ub_node_link(p->sub_node, p->sub_link);
    uint64_t tx_err = l->counters.drops[UB_DROP_TX_ERROR];
    now += UB_PS_DEFAULT_RENEW_MS + 10;
    ub_node_tick(p->sub_node, now); /* the subscription's renewal is due: it cannot leave */
    assert_true(l->counters.drops[UB_DROP_TX_ERROR] > tx_err);
    assert_true(st->send_closed > 0);

    /* The device is absent (the pty slave vanished): attempts fail and back off, doubling. */
    assert_int_equal(ub_serial_service(&dev, p->sub_node, now), 0); /* the first retry failed at once */
    assert_int_equal(st->reopen_failures, 1);
    assert_true(ub_serial_next_retry(&dev, &due));
    uint64_t t = now;
    uint32_t expected_wait = 2 * UB_SERIAL_RETRY_MIN_MS;
    assert_int_equal(due, t + expected_wait);
    for (int k = 1; k < 4; k++) {
        t += expected_wait;
        assert_int_equal(ub_serial_service(&dev, p->sub_node, t - 1), 0); /* not yet due */
        assert_int_equal(st->reopen_failures, (uint64_t)k);
        assert_int_equal(ub_serial_service(&dev, p->sub_node, t), 0);
        assert_int_equal(st->reopen_failures, (uint64_t)k + 1);
        expected_wait = expected_wait * 2 > UB_SERIAL_RETRY_MAX_MS ? UB_SERIAL_RETRY_MAX_MS : expected_wait * 2;
        assert_true(ub_serial_next_retry(&dev, &due));
        assert_int_equal(due, t + expected_wait);
    }
    /* Re-plugged: the symlink now names a new pty. The driver reopens it and the data flows again. */
    master = open_pty_master(slave_path, sizeof slave_path, 0);
    unlink(link_path);
    assert_int_equal(symlink(slave_path, link_path), 0);
    assert_int_equal(ub_serial_adopt(&far, master, 0), UB_OK);
    assert_int_equal(ub_serial_attach(&far, p->pub_node, p->pub_link), UB_OK);
    t = due;
    assert_int_equal(ub_serial_service(&dev, p->sub_node, t), 0);
    assert_int_equal(ub_serial_state(&dev), UB_SERIAL_UP);
    assert_int_equal(st->reopens, 1);
    assert_int_equal(ev.ups, 1); /* and the reopen as UP */
    assert_true(ub_serial_fileno(&dev) >= 0);
    assert_false(ub_serial_next_retry(&dev, &due));
    for (uint64_t end = t + 2000; t < end; t += 10) {
        ub_node_tick(p->pub_node, t);
        ub_node_tick(p->sub_node, t);
        (void)poll(&(struct pollfd){.fd = master, .events = POLLIN}, 1, 2);
        assert_true(ub_serial_service(&far, p->pub_node, t) >= 0);
        assert_true(ub_serial_service(&dev, p->sub_node, t) >= 0);
    }
    assert_true(p->log.n > before + 5);

    /* The other direction: the device end closes; the adopted master sees the hang-up and stays down. Bytes the
     * device wrote just before closing are read first (they are data, not the hang-up), so the master may need
     * a few services, each after the kernel says the descriptor is ready, before it reads the hang-up itself. */
    ub_serial_close(&dev);
    for (int k = 0; k < 100 && ub_serial_state(&far) == UB_SERIAL_UP; k++) {
        (void)poll(&(struct pollfd){.fd = master, .events = POLLIN}, 1, 10);
        assert_true(ub_serial_service(&far, p->pub_node, t) >= 0);
    }
    assert_int_equal(ub_serial_stats(&far)->hangups, 1);
    assert_int_equal(ub_serial_state(&far), UB_SERIAL_DOWN);
    assert_false(ub_serial_next_retry(&far, &due)); /* adopted: nothing to reopen */
    assert_int_equal(ub_serial_service(&far, p->pub_node, t + 60000), 0);
    assert_int_equal(ub_serial_stats(&far)->reopens, 0);
    ub_serial_close(&far);
    close(master);
    unlink(link_path);
    pair_free(p);
}

static void test_open_errors(void **state) {
    (void)state;
    ub_serial_t s;
    assert_int_equal(ub_serial_open(&s, "/nonexistent/tty", 115200), UB_ERR_IO);
    assert_int_equal(ub_serial_open(&s, "/dev/null", 12345), UB_ERR_RANGE);
    assert_int_equal(ub_serial_open(&s, "/dev/null", 9600), UB_ERR_IO); /* not a tty */
    assert_int_equal(errno, ENOTTY);
    assert_int_equal(ub_serial_fileno(&s), -1);
    assert_int_equal(ub_serial_adopt(&s, -1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_serial_service(&s, NULL, 0), UB_ERR_INVAL);
    ub_serial_close(&s);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_two_nodes_exchange_over_a_pty),
        cmocka_unit_test(test_frames_survive_chunking_and_garbage),
        cmocka_unit_test(test_hangup_detected_counted_and_reopened),
        cmocka_unit_test(test_open_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

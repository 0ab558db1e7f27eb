/*
 * The serial driver where test_serial.c does not go (issue #29 item 6), on real pseudo-terminals and pipes:
 *  - a far end that stops reading: whole writes until the transmit buffer is full, then backpressure,
 *    counted; POLLOUT asked while bytes wait; the service flushes them, and the far end reads every accepted
 *    message once, in order; a hang-up with bytes queued counts them discarded;
 *  - an adopted pipe (a descriptor that is no tty): configured only when asked (and refused then), a reader
 *    that went away is a hang-up (EPIPE), not an I/O error, and an adopted descriptor is never reopened;
 *  - the reopen backoff doubling up to its ceiling and staying there;
 *  - the foreign-traffic handler set twice, removed, a caller's decoder left alone, and describe's figures;
 *  - refusals: NULLs, a link the node does not have, a closed link's service, a device path too long.
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
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "support/ub_test_foreign.h"
#include "support/ub_test_pair.h"
#include "support/ub_test_pty.h"
#include "ub/ub_ports.h"
#include "ub/ub_serial.h"

#define MSG_LEN 200

/* Message k: its index (4 bytes, little-endian), then a filler that depends on k. */
static void message(uint32_t k, uint8_t *out) {
    out[0] = (uint8_t)k, out[1] = (uint8_t)(k >> 8), out[2] = (uint8_t)(k >> 16), out[3] = (uint8_t)(k >> 24);
    for (size_t i = 4; i < MSG_LEN; i++) out[i] = (uint8_t)(k * 7u + i);
}

/* Writes messages 0, 1, ... until one is refused; @return how many were taken. */
static uint32_t fill(ub_serial_t *s, uint32_t first, uint64_t now) {
    uint8_t m[MSG_LEN];
    for (uint32_t k = first; k < first + 100000; k++) {
        message(k, m);
        int rc = ub_serial_write_foreign(s, m, sizeof m, now);
        if (rc == UB_ERR_AGAIN) return k - first;
        assert_int_equal(rc, UB_OK);
    }
    fail_msg("the far end never filled up");
    return 0;
}

static void test_backpressure_then_flush_at_service(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    char slave[128];
    int master = open_pty_master(slave, sizeof slave, O_NONBLOCK);
    static ub_serial_t dev;
    assert_int_equal(ub_serial_open(&dev, slave, 115200), UB_OK);
    assert_int_equal(ub_serial_attach(&dev, p->sub_node, p->sub_link), UB_OK);
    const ub_serial_stats_t *st = ub_serial_stats(&dev);

    uint32_t taken = fill(&dev, 0, 0);
    assert_true(taken > 0);
    assert_int_equal(st->backpressure, 1);
    assert_int_equal(st->foreign_out, taken);
    assert_true(ub_serial_tx_pending(&dev) > 0);
    struct pollfd fds[1];
    assert_int_equal(ub_serial_driver.pollfds(&dev, fds, 1), 1);
    assert_true(fds[0].events & POLLOUT);

    /* The far end reads again; the service flushes what waited. Every accepted message arrives once, whole,
     * in order, and nothing of the refused one. */
    size_t total = (size_t)taken * MSG_LEN, got = 0;
    uint8_t *wire = malloc(total + MSG_LEN);
    assert_non_null(wire);
    for (int i = 0; i < 20000 && got < total + 1; i++) {
        assert_true(ub_serial_service(&dev, p->sub_node, 0) >= 0);
        (void)poll(&(struct pollfd){.fd = master, .events = POLLIN}, 1, got < total ? 5 : 50);
        ssize_t n = read(master, wire + got, total + MSG_LEN - got);
        if (n > 0) got += (size_t)n;
        else if (got == total && ub_serial_tx_pending(&dev) == 0) break;
    }
    assert_int_equal(got, total);
    uint8_t want[MSG_LEN];
    for (uint32_t k = 0; k < taken; k++) {
        message(k, want);
        assert_memory_equal(wire + (size_t)k * MSG_LEN, want, MSG_LEN);
    }
    assert_int_equal(st->bytes_out, total);
    assert_int_equal(ub_serial_tx_pending(&dev), 0);
    assert_int_equal(ub_serial_driver.pollfds(&dev, fds, 1), 1);
    assert_int_equal(fds[0].events, POLLIN);

    /* Full again, and the far end goes away: the service's flush finds the hang-up; what waited is counted
     * discarded, not written anywhere. */
    (void)fill(&dev, taken, 0);
    size_t pending = ub_serial_tx_pending(&dev);
    assert_true(pending > 0);
    close(master);
    assert_int_equal(ub_serial_service(&dev, p->sub_node, 10), 0);
    assert_int_equal(st->hangups, 1);
    assert_int_equal(st->tx_discarded, pending);
    assert_int_equal(st->io_errors, 0);
    assert_int_equal(ub_serial_tx_pending(&dev), 0);
    uint64_t due = 0;
    assert_true(ub_serial_next_retry(&dev, NULL)); /* a device opened by path is retried */
    assert_true(ub_serial_next_retry(&dev, &due));
    assert_int_equal(due, 10 + UB_SERIAL_RETRY_MIN_MS);
    ub_serial_close(&dev);
    assert_false(ub_serial_next_retry(&dev, &due)); /* closed on purpose: no more retries */
    assert_int_equal(ub_serial_service(&dev, p->sub_node, due), UB_ERR_INVAL);
    free(wire);
    pair_free(p);
}

static void test_an_adopted_pipe(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    struct sigaction ign = {.sa_handler = SIG_IGN}, old;
    assert_int_equal(sigaction(SIGPIPE, &ign, &old), 0); /* as uavbus_node does: EPIPE, not a signal */
    int pf[2];
    assert_int_equal(pipe(pf), 0);
    static ub_serial_t s;
    assert_int_equal(ub_serial_adopt(&s, pf[1], 12345), UB_ERR_RANGE);
    assert_int_equal(ub_serial_adopt(&s, pf[1], 9600), UB_ERR_IO); /* a pipe has no line settings */
    assert_int_equal(ub_serial_adopt(&s, pf[1], 0), UB_OK);          /* left alone: fine */
    assert_int_equal(ub_serial_attach(&s, p->pub_node, p->pub_link), UB_OK);
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0), 1);
    uint8_t frame[UB_FRAME_MAX];
    ssize_t n = read(pf[0], frame, sizeof frame);
    assert_true(n > 0);
    assert_int_equal((uint64_t)n, ub_serial_stats(&s)->bytes_out);
    /* the reader goes away: the next write is a hang-up, refused as closed; the node counts its drop */
    close(pf[0]);
    const ub_link_counters_t *lc = &ub_node_link(p->pub_node, p->pub_link)->counters;
    uint64_t tx_err = lc->drops[UB_DROP_TX_ERROR];
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 1), 0);
    assert_int_equal(lc->drops[UB_DROP_TX_ERROR], tx_err + 1);
    const ub_serial_stats_t *st = ub_serial_stats(&s);
    assert_int_equal(st->hangups, 1);
    assert_int_equal(st->io_errors, 0);
    assert_int_equal(st->frames_out, 1);
    assert_int_equal(ub_serial_state(&s), UB_SERIAL_DOWN);
    assert_false(ub_serial_next_retry(&s, NULL)); /* adopted: nothing to reopen */
    uint8_t b = 0;
    assert_int_equal(ub_serial_write_foreign(&s, &b, 1, 2), UB_ERR_CLOSED);
    assert_int_equal(st->send_closed, 1);
    ub_serial_close(&s);
    close(pf[1]); /* adopted: the driver did not close it */
    assert_int_equal(sigaction(SIGPIPE, &old, NULL), 0);
    pair_free(p);
}

/* A device that stays away: retries at 100, then 200, 400, ... ms after each failure, up to the ceiling,
 * and at the ceiling from then on (never more often, never given up). */
static void test_reopen_backoff_reaches_its_ceiling(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    char slave[128], link_path[96];
    int master = open_pty_master(slave, sizeof slave, O_NONBLOCK);
    pty_symlink(link_path, sizeof link_path, "tty_edges", slave);
    static ub_serial_t dev;
    assert_int_equal(ub_serial_open(&dev, link_path, 9600), UB_OK);
    assert_int_equal(ub_serial_attach(&dev, p->sub_node, p->sub_link), UB_OK);
    close(master);
    unlink(link_path); /* unplugged for good */
    uint64_t now = 0;
    for (int i = 0; i < 100 && ub_serial_state(&dev) == UB_SERIAL_UP; i++) {
        (void)poll(&(struct pollfd){.fd = ub_serial_fileno(&dev), .events = POLLIN}, 1, 10);
        assert_int_equal(ub_serial_service(&dev, p->sub_node, now), 0);
    }
    assert_int_equal(ub_serial_state(&dev), UB_SERIAL_DOWN);
    uint64_t due = 0;
    assert_true(ub_serial_next_retry(&dev, &due));
    assert_int_equal(due, UB_SERIAL_RETRY_MIN_MS);
    uint32_t wait = UB_SERIAL_RETRY_MIN_MS;
    for (int k = 1; k <= 9; k++) {
        now = due;
        assert_int_equal(ub_serial_service(&dev, p->sub_node, now), 0);
        assert_int_equal(ub_serial_stats(&dev)->reopen_failures, (uint64_t)k);
        wait = wait * 2 > UB_SERIAL_RETRY_MAX_MS ? UB_SERIAL_RETRY_MAX_MS : wait * 2;
        assert_true(ub_serial_next_retry(&dev, &due));
        assert_int_equal(due - now, wait);
    }
    assert_int_equal(wait, UB_SERIAL_RETRY_MAX_MS); /* reached, and held for the last retries */
    ub_serial_close(&dev);
    pair_free(p);
}

static void test_foreign_handler_and_refusals(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    char slave[128];
    int master = open_pty_master(slave, sizeof slave, O_NONBLOCK);
    static ub_serial_t dev;
    assert_int_equal(ub_serial_open(&dev, slave, 115200), UB_OK);
    /* refusals before it is attached */
    assert_int_equal(ub_serial_attach(NULL, p->sub_node, p->sub_link), UB_ERR_INVAL);
    assert_int_equal(ub_serial_attach_as(&dev, p->sub_node, p->sub_link, NULL, &dev), UB_ERR_INVAL);
    assert_true(ub_serial_attach(&dev, p->sub_node, 99) < 0); /* no such link */
    assert_null(dev.node);
    assert_int_equal(ub_serial_service(&dev, p->sub_node, 0), UB_ERR_INVAL);
    assert_int_equal(ub_serial_attach(&dev, p->sub_node, p->sub_link), UB_OK);
    assert_int_equal(ub_serial_service(&dev, p->pub_node, 0), UB_ERR_INVAL); /* another node */
    uint8_t big[UB_SERIAL_TX_BUFFER + 1] = {0};
    assert_int_equal(ub_serial_write_foreign(NULL, big, 1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_serial_write_foreign(&dev, NULL, 1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_serial_write_foreign(&dev, big, sizeof big, 0), UB_ERR_INVAL);
    assert_int_equal(ub_serial_stats(&dev)->bytes_out, 0);
    assert_int_equal(ub_serial_set_rx_hook(NULL, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_serial_set_rx_hook(&dev, NULL, &dev), UB_OK); /* none: no user kept */
    assert_null(dev.rx_user);

    /* The handler: bytes that are not frames reach it; set again, what its decoder holds is kept. */
    handler_t h = {.len = 0};
    assert_int_equal(ub_serial_set_foreign(&dev, on_foreign, &h), UB_OK);
    static const char text[] = "$GPGGA,1*00\r\n";
    assert_int_equal(write(master, text, strlen(text)), (ssize_t)strlen(text));
    assert_int_equal(write(master, (const uint8_t[]){UB_SYNC0, UB_SYNC1}, 2), 2); /* a frame's start, held */
    for (int i = 0; i < 200 && dev.stats.bytes_in < strlen(text) + 2; i++) {
        (void)poll(&(struct pollfd){.fd = ub_serial_fileno(&dev), .events = POLLIN}, 1, 10);
        assert_true(ub_serial_service(&dev, p->sub_node, 0) >= 0);
    }
    assert_int_equal(h.len, strlen(text));
    assert_memory_equal(h.got, text, strlen(text));
    assert_int_equal(ub_decoder_pending(&dev.own_dec), 2);
    assert_int_equal(ub_serial_set_foreign(&dev, on_foreign, &h), UB_OK);
    assert_int_equal(ub_decoder_pending(&dev.own_dec), 2);
    char d[1024], want[64];
    assert_true(ub_serial_driver.describe(&dev, d, sizeof d) > 0);
    snprintf(want, sizeof want, "\"foreign_bytes\":%zu,\"foreign_refused\":0", strlen(text));
    assert_non_null(strstr(d, want));
    /* removed: the held start is counted garbage, and the slot's decoder reads again */
    assert_int_equal(ub_serial_set_foreign(&dev, NULL, NULL), UB_OK);
    assert_null(dev.dec);
    assert_int_equal(ub_decoder_pending(&dev.own_dec), 0);
    assert_int_equal(dev.own_dec.stats.garbage_bytes, 2);
    assert_true(ub_serial_driver.describe(&dev, d, sizeof d) > 0);
    assert_non_null(strstr(d, "\"foreign_bytes\":0,"));
    /* a caller's decoder is not the driver's to restart or drop when a handler is removed */
    static ub_decoder_t mine;
    ub_decoder_init(&mine);
    assert_int_equal(ub_serial_set_decoder(&dev, &mine), UB_OK);
    assert_int_equal(ub_serial_set_foreign(&dev, NULL, NULL), UB_OK);
    assert_ptr_equal(dev.dec, &mine);
    assert_int_equal(ub_serial_set_decoder(&dev, NULL), UB_OK);

    /* the driver table's counters and the spec's device length */
    assert_int_equal(ub_serial_driver.counters(&dev, NULL, 5), ub_serial_driver.counters(&dev, NULL, 0));
    char spec[UB_PORT_DEVICE_LEN + 40], err[UB_PORTS_ERR_LEN];
    int k = snprintf(spec, sizeof spec, "serial:device=/dev/");
    memset(spec + k, 'x', UB_PORT_DEVICE_LEN);
    spec[k + UB_PORT_DEVICE_LEN] = '\0';
    ub_port_spec_t s;
    assert_int_equal(ub_port_spec_parse(spec, &s, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "give a device path of 1 to"));
    ub_serial_close(&dev);
    close(master);
    pair_free(p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_backpressure_then_flush_at_service),
        cmocka_unit_test(test_an_adopted_pipe),
        cmocka_unit_test(test_reopen_backoff_reaches_its_ceiling),
        cmocka_unit_test(test_foreign_handler_and_refusals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

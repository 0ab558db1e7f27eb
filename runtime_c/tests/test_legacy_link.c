/*
 * The legacy datalink link driver (ub_legacy_link.h) in C, on a real pseudo-terminal (issue #29 item 6: the
 * Python test tests/python/test_legacy_link.py drives it through cffi, which the coverage build does not
 * count). The test is the old ground station on the pty's far end: it writes envelopes (ub_legacy.h, whose
 * bytes tests/vectors/legacy_envelope.json checks) and reads what the node's port writes.
 *  - received: a uavbus frame in the uavbus type is delivered; a uavbus-type message whose payload is not a
 *    frame is counted `frames_rejected`; other types go whole to the handler (what it refuses counted
 *    `foreign_refused`), or are counted `unhandled` without one;
 *  - sent: the node's frames leave one per message of the port's type; the application's legacy messages go
 *    out byte-exact; a frame the envelope cannot hold is refused before the wire;
 *  - a hang-up: sends refused as closed, the device reopened by path, the half message of the old stream
 *    counted as noise, and the new stream parsed from a clean start;
 *  - the spec's `type` key and its refusals, and the serial keys it passes on.
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
#include <unistd.h>

#include "support/ub_test_pair.h"
#include "support/ub_test_pty.h"
#include "ub/ub_frame.h"
#include "ub/ub_legacy_link.h"
#include "ub/ub_ports.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_wire.h"

#define UAVBUS_TYPE 200u

static void write_all(int fd, const uint8_t *data, size_t len) {
    size_t off = 0;
    for (int i = 0; i < 1000 && off < len; i++) {
        ssize_t n = write(fd, data + off, len - off);
        if (n > 0) off += (size_t)n;
        else (void)poll(&(struct pollfd){.fd = fd, .events = POLLOUT}, 1, 5);
    }
    assert_int_equal(off, len);
}

static size_t legacy(uint16_t type, const void *payload, size_t len, uint8_t *out) {
    int n = ub_legacy_build(type, payload, len, out, UB_LEGACY_MESSAGE_MAX);
    assert_true(n > 0);
    return (size_t)n;
}

/* The application's handler of legacy traffic: keeps what it is given; takes only `take_max` bytes of each. */
typedef struct handler {
    uint8_t got[1024];
    size_t len, calls, take_max;
} handler_t;

static size_t on_foreign(void *user, const uint8_t *msg, size_t len) {
    handler_t *h = user;
    assert_true(h->len + len <= sizeof h->got);
    memcpy(h->got + h->len, msg, len);
    h->len += len;
    h->calls++;
    return len < h->take_max ? len : h->take_max;
}

static uint64_t counter(const ub_ports_t *ports, const char *name) {
    ub_driver_counter_t c[32];
    int n = ub_ports_counters(ports, "subPort", c, 32);
    assert_true(n > 0 && n <= 32);
    for (int i = 0; i < n; i++)
        if (strcmp(c[i].name, name) == 0) return c[i].value;
    fail_msg("no counter %s", name);
    return 0;
}

/* Services the ports until `cond` holds (the pty hands bytes over on the kernel's time): at most ~2 s. */
#define SERVE_UNTIL(ports, now, cond)                                                                   \
    do {                                                                                                        \
        for (int k_ = 0; k_ < 400 && !(cond); k_++) {                                                           \
            (void)poll(&(struct pollfd){.fd = ub_serial_fileno(&lk(ports)->serial), .events = POLLIN}, 1, 5);   \
            (void)ub_ports_service(ports, now);                                                                 \
        }                                                                                                       \
        assert_true(cond);                                                                                      \
    } while (0)

static const ub_legacy_link_t *lk(const ub_ports_t *ports) {
    const ub_legacy_link_t *l = ub_ports_state(ports, "subPort", &ub_legacy_driver);
    assert_non_null(l);
    return l;
}

/* Reads from the far end until `want` bytes came (or ~2 s passed), serving the ports meanwhile. */
static size_t read_far(ub_ports_t *ports, int master, uint8_t *out, size_t want, uint64_t now) {
    size_t got = 0;
    for (int k = 0; k < 400 && got < want; k++) {
        (void)ub_ports_service(ports, now);
        (void)poll(&(struct pollfd){.fd = master, .events = POLLIN}, 1, 5);
        ssize_t n = read(master, out + got, want - got);
        if (n > 0) got += (size_t)n;
    }
    return got;
}

/* Real DATA frames of gpsOut from the pub node to the sub node (a capture transport instead of the memlink). */
static size_t data_frame(pair_t *p, uint8_t *out) {
    static capture_t cap;
    memset(&cap, 0, sizeof cap);
    assert_int_equal(ub_node_link_attach(p->pub_node, p->pub_link, &capture_ops, &cap), UB_OK);
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0), 1);
    assert_int_equal(cap.n, 1);
    memcpy(out, cap.frame[0], cap.len[0]);
    return cap.len[0];
}

static void test_frames_and_legacy_messages_share_the_wire(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_ports_t *ports = calloc(1, sizeof *ports);
    assert_non_null(ports);
    assert_int_equal(ub_ports_init(ports, p->sub_node), UB_OK);
    char slave[128], spec[200], err[UB_PORTS_ERR_LEN];
    int master = open_pty_master(slave, sizeof slave, O_NONBLOCK);
    snprintf(spec, sizeof spec, "legacy:device=%s,baud=57600,type=%u", slave, UAVBUS_TYPE);
    assert_int_equal(ub_ports_open_text(ports, "subPort", spec, 0, err, sizeof err), UB_OK);
    handler_t h = {.take_max = SIZE_MAX};
    assert_int_equal(ub_ports_set_foreign(ports, "subPort", on_foreign, &h), UB_OK);

    /* From the old side: a heartbeat (type 1), noise, a uavbus frame, a uavbus-type message that holds no
     * frame, and a newer type (7) the handler takes only 10 bytes of. */
    static uint8_t frame[UB_FRAME_MAX], stream[4 * UB_LEGACY_MESSAGE_MAX];
    size_t flen = data_frame(p, frame), n = 0;
    uint8_t hb[64], bogus[64], newer[64];
    size_t hb_len = legacy(1, "GS alive", 8, hb);
    size_t bogus_len = legacy(UAVBUS_TYPE, "not a frame at all", 18, bogus);
    static const uint8_t seven[30] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    size_t newer_len = legacy(7, seven, sizeof seven, newer);
    memcpy(stream + n, hb, hb_len), n += hb_len;
    memcpy(stream + n, "\x00noise", 6), n += 6;
    n += legacy(UAVBUS_TYPE, frame, flen, stream + n);
    memcpy(stream + n, bogus, bogus_len), n += bogus_len;
    memcpy(stream + n, newer, newer_len), n += newer_len;
    write_all(master, stream, n);
    SERVE_UNTIL(ports, 10, lk(ports)->parser.stats.bytes_in >= n);

    assert_int_equal(p->log.n, 1); /* the frame, delivered */
    assert_memory_equal(&p->gps_dst, &p->gps_src, sizeof p->gps_src);
    assert_int_equal(counter(ports, "frames_in"), 1);
    assert_int_equal(counter(ports, "frames_rejected"), 1);
    assert_int_equal(counter(ports, "foreign_messages"), 2);
    assert_int_equal(counter(ports, "foreign_refused"), 0);
    assert_int_equal(counter(ports, "noise_bytes"), 6);
    assert_int_equal(counter(ports, "messages"), 4);
    assert_int_equal(counter(ports, "type"), UAVBUS_TYPE);
    /* the legacy messages reached the handler whole, byte-exact, in order; the uavbus ones never did */
    assert_int_equal(h.calls, 2);
    assert_int_equal(h.len, hb_len + newer_len);
    assert_memory_equal(h.got, hb, hb_len);
    assert_memory_equal(h.got + hb_len, newer, newer_len);

    /* A handler that takes part of a message: the rest is counted refused. */
    h.take_max = 10;
    write_all(master, newer, newer_len);
    SERVE_UNTIL(ports, 20, counter(ports, "foreign_messages") == 3);
    assert_int_equal(counter(ports, "foreign_refused"), newer_len - 10);
    /* No handler: another type is counted unhandled, never handed anywhere. */
    assert_int_equal(ub_ports_set_foreign(ports, "subPort", NULL, NULL), UB_OK);
    assert_null(lk(ports)->foreign_user);
    write_all(master, hb, hb_len);
    SERVE_UNTIL(ports, 30, counter(ports, "unhandled") == 1);
    assert_int_equal(h.calls, 3);

    /* Sent: the node's subscription request leaves as one message of the uavbus type holding a valid frame,
     * and the application's legacy message goes out byte-exact after it. */
    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, 40) >= 0);
    ub_node_tick(p->sub_node, 40); /* the request leaves at the tick */
    assert_int_equal(counter(ports, "frames_out"), 1);
    uint8_t mine[64];
    size_t mine_len = legacy(1, "vehicle alive", 13, mine);
    assert_int_equal(ub_ports_write_foreign(ports, "subPort", mine, mine_len, 40), UB_OK);
    static uint8_t wire[2 * UB_LEGACY_MESSAGE_MAX];
    size_t got = read_far(ports, master, wire, UB_LEGACY_HEADER_LEN, 40);
    assert_int_equal(got, UB_LEGACY_HEADER_LEN);
    assert_int_equal(wire[0], UB_LEGACY_SYNC0);
    assert_int_equal(ub_get_u16le(wire + 4), UAVBUS_TYPE);
    size_t inner = ub_get_u16le(wire + 6);
    size_t total = UB_LEGACY_HEADER_LEN + inner + mine_len;
    assert_int_equal(read_far(ports, master, wire + got, total - got, 40), total - got);
    ub_frame_header_t fh;
    assert_int_equal(ub_frame_parse(wire + UB_LEGACY_HEADER_LEN, inner, &fh), UB_OK); /* CRC checked */
    assert_memory_equal(fh.src_id, p->sub_id, UB_ENTITY_ID_LEN);
    assert_memory_equal(wire + UB_LEGACY_HEADER_LEN + inner, mine, mine_len);
    assert_int_equal(counter(ports, "bytes_out"), total);

    /* A frame longer than the envelope's payload cannot be sent: refused before the wire, not counted. */
    static uint8_t huge[UB_LEGACY_PAYLOAD_MAX + 1];
    assert_int_equal(ub_legacy_link_ops.send((void *)lk(ports), huge, sizeof huge, 50), UB_ERR_RANGE);
    assert_int_equal(counter(ports, "frames_out"), 1);
    assert_int_equal(counter(ports, "bytes_out"), total);

    /* The driver table's counters: counted without room, cut at the room given. */
    ub_driver_counter_t two[2];
    int all = ub_ports_counters(ports, "subPort", NULL, 0);
    assert_true(all > 2);
    assert_int_equal(ub_ports_counters(ports, "subPort", two, 2), all);
    assert_string_equal(two[1].name, "frames_in");
    assert_int_equal(ub_legacy_driver.counters(lk(ports), NULL, 5), (size_t)all); /* room, nowhere to put it */
    ub_ports_close_all(ports);
    close(master);
    free(ports);
    pair_free(p);
}

/* The far end goes away with half a message in the parser: the port refuses sends as closed, waits for its
 * retry time (no descriptor to poll), reopens the device by path (a symlink, as udev gives a re-plugged
 * adapter), counts the half message as noise, and parses the new stream from its first byte. */
static void test_hangup_reopens_and_starts_the_parser_afresh(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_ports_t *ports = calloc(1, sizeof *ports);
    assert_non_null(ports);
    assert_int_equal(ub_ports_init(ports, p->sub_node), UB_OK);
    char slave[128], link_path[96], spec[200], err[UB_PORTS_ERR_LEN];
    int master = open_pty_master(slave, sizeof slave, O_NONBLOCK);
    pty_symlink(link_path, sizeof link_path, "legacy_tty", slave);
    snprintf(spec, sizeof spec, "legacy:device=%s", link_path); /* default baud and type */
    assert_int_equal(ub_ports_open_text(ports, "subPort", spec, 0, err, sizeof err), UB_OK);
    assert_int_equal(lk(ports)->type, UB_LEGACY_DEFAULT_TYPE);
    struct pollfd fds[4];
    assert_int_equal(ub_ports_pollfds(ports, fds, 4), 1);

    static uint8_t frame[UB_FRAME_MAX], msg[UB_LEGACY_MESSAGE_MAX];
    size_t flen = data_frame(p, frame);
    size_t mlen = legacy(UB_LEGACY_DEFAULT_TYPE, frame, flen, msg);
    write_all(master, msg, 20); /* cut off: the far end goes away before the rest */
    SERVE_UNTIL(ports, 10, ub_legacy_pending(&lk(ports)->parser) == 20);
    close(master);
    uint64_t now = 100;
    SERVE_UNTIL(ports, now, counter(ports, "hangups") == 1);
    assert_int_equal(ub_serial_state(&lk(ports)->serial), UB_SERIAL_DOWN);
    assert_int_equal(ub_ports_pollfds(ports, fds, 4), 0); /* nothing to poll while down */
    uint8_t hb[32];
    size_t hb_len = legacy(1, "hb", 2, hb);
    assert_int_equal(ub_ports_write_foreign(ports, "subPort", hb, hb_len, now), UB_ERR_CLOSED);
    assert_int_equal(ub_legacy_link_ops.send((void *)lk(ports), frame, flen, now), UB_ERR_CLOSED);
    assert_int_equal(counter(ports, "frames_out"), 0);
    int timeout = ub_ports_poll_timeout(ports, now, 60000); /* the retry time wakes the loop */
    assert_true(timeout >= 0 && timeout <= (int)UB_SERIAL_RETRY_MIN_MS);

    /* Re-plugged: a new pty behind the same path. At the retry time the port reopens it. */
    master = open_pty_master(slave, sizeof slave, O_NONBLOCK);
    unlink(link_path);
    assert_int_equal(symlink(slave, link_path), 0);
    uint64_t noise = counter(ports, "noise_bytes");
    now += UB_SERIAL_RETRY_MIN_MS;
    (void)ub_ports_service(ports, now);
    assert_int_equal(ub_serial_state(&lk(ports)->serial), UB_SERIAL_UP);
    assert_int_equal(lk(ports)->serial.stats.reopens, 1);
    assert_int_equal(counter(ports, "noise_bytes"), noise + 20); /* the old stream's half message */
    assert_int_equal(ub_legacy_pending(&lk(ports)->parser), 0);
    /* The new stream's first message: delivered, and nothing counted against a stream that had no error (had
     * the 20 old bytes stayed, the message would first have been read as their continuation: a bad checksum). */
    write_all(master, msg, mlen);
    SERVE_UNTIL(ports, now, counter(ports, "frames_in") == 1);
    assert_int_equal(p->log.n, 1);
    assert_int_equal(counter(ports, "bad_checksum") + counter(ports, "bad_header"), 0);
    ub_ports_close_all(ports);
    close(master);
    unlink(link_path);
    free(ports);
    pair_free(p);
}

/* The spec: type=N once, 1..65535; device required; the serial keys passed on with their own messages; the
 * text written back in full; a device that cannot be opened refused at open. */
static void test_spec_type_and_refusals(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_ports_t *ports = calloc(1, sizeof *ports);
    assert_non_null(ports);
    assert_int_equal(ub_ports_init(ports, p->sub_node), UB_OK);
    ub_port_spec_t s;
    char err[UB_PORTS_ERR_LEN], text[128];
    assert_int_equal(ub_ports_spec_parse(ports, "legacy:device=/dev/ttyS1,type=7", &s, err, sizeof err), UB_OK);
    ub_port_spec_format(&s, text, sizeof text);
    assert_string_equal(text, "legacy:device=/dev/ttyS1,baud=115200,type=7");
    assert_int_equal(ub_ports_spec_parse(ports, "legacy:type=9,baud=57600,device=/dev/ttyS1", &s, err, sizeof err),
                     UB_OK);
    ub_port_spec_format(&s, text, sizeof text);
    assert_string_equal(text, "legacy:device=/dev/ttyS1,baud=57600,type=9");
    static const char *const bad_type[] = {"legacy:device=/dev/ttyS1,type=0", "legacy:device=/dev/ttyS1,type=65536",
                                           "legacy:device=/dev/ttyS1,type=x",
                                           "legacy:device=/dev/ttyS1,type=5,type=5"};
    for (size_t i = 0; i < sizeof bad_type / sizeof bad_type[0]; i++) {
        err[0] = '\0';
        assert_int_equal(ub_ports_spec_parse(ports, bad_type[i], &s, err, sizeof err), UB_ERR_INVAL);
        assert_non_null(strstr(err, "give once the legacy message type"));
    }
    assert_int_equal(ub_ports_spec_parse(ports, "legacy:type=5", &s, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "legacy needs device=PATH"));
    assert_int_equal(ub_ports_spec_parse(ports, "legacy:device=/dev/ttyS1,baud=1234", &s, err, sizeof err),
                     UB_ERR_INVAL);
    assert_non_null(strstr(err, "'baud=1234'"));
    assert_int_equal(ub_ports_open_text(ports, "subPort", "legacy:device=/nonexistent/tty", 0, err, sizeof err),
                     UB_ERR_IO);
    assert_null(ub_ports_find(ports, "subPort"));
    free(ports);
    pair_free(p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frames_and_legacy_messages_share_the_wire),
        cmocka_unit_test(test_hangup_reopens_and_starts_the_parser_afresh),
        cmocka_unit_test(test_spec_type_and_refusals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

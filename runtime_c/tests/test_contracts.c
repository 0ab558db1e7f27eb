/*
 * The argument contracts of the public API (the @return lines of the headers), called the wrong way on
 * purpose: NULL pointers, bad ids, closed objects, buffers too small. Every call must return the
 * documented code and touch nothing. Plus the few driver paths the scenario tests do not reach: an
 * oversize UDP datagram, UDP batching with full slots, serial ports under ub_ports, poll sets that do not
 * fit. (make coverage names what stays uncovered.)
 */
#define _XOPEN_SOURCE 700 /* posix_openpt, grantpt, unlockpt, ptsname */

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "support/ub_test_pair.h"
#include "test_frame_util.h"
#include "ub/ub_impair.h"
#include "ub/ub_log.h"
#include "ub/ub_ports.h"
#include "ub/ub_serial.h"
#include "ub/ub_tcp.h"
#include "ub/ub_udp.h"

static void test_node_contracts(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_node_t *n = p->pub_node;
    uint8_t id[UB_ENTITY_ID_LEN] = {0}, mask = 0;
    static const ub_link_ops_t no_send = {.kind = "x"};
    assert_int_equal(ub_node_init(NULL, &ub_test_cat, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_init(n, NULL, NULL), UB_ERR_INVAL);
    ub_catalogue_t bad = ub_test_cat;
    bad.abi_version = 0;
    static ub_node_t other;
    assert_int_equal(ub_node_init(&other, &bad, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_entity(NULL, id, true), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_entity(n, NULL, true), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_entity(n, id, true), UB_ERR_INVAL); /* the all-zero ID */
    assert_int_equal(ub_node_add_entity(n, p->pub_id, false), UB_ERR_EXISTS);
    assert_int_equal(ub_node_add_entity_name(n, NULL, true), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_entity_name(n, "a-name-much-too-long", true), UB_ERR_RANGE);
    assert_int_equal(ub_node_find_entity(NULL, id), UB_ERR_INVAL);
    assert_int_equal(ub_node_find_entity(n, NULL), UB_ERR_INVAL);
    assert_null(ub_node_entity_id(NULL, 0));
    assert_null(ub_node_entity_id(n, -1));
    assert_null(ub_node_entity_id(n, UB_MAX_ENTITIES));
    assert_int_equal(ub_node_add_link(NULL, p->pub, 1, "x"), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_link(n, p->pub, 1, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_link(n, p->pub_peer, 1, "x"), UB_ERR_INVAL); /* not local */
    assert_int_equal(ub_node_add_link(n, p->pub, UB_MAX_LINKS_PER_ENTITY, "x"), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_link(n, p->pub, 1, ""), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_link(n, p->pub, 1, "a-link-name-longer-than-thirty-one-chars"), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_link(n, p->pub, 0, "y"), UB_ERR_EXISTS);       /* index taken */
    assert_int_equal(ub_node_add_link(n, p->pub, 1, "pubPort"), UB_ERR_EXISTS); /* name used */
    assert_int_equal(ub_node_find_link(NULL, "pubPort"), UB_ERR_INVAL);
    assert_int_equal(ub_node_find_link(n, NULL), UB_ERR_INVAL);
    assert_null(ub_node_link(NULL, 0));
    assert_null(ub_node_link(n, -1));
    assert_null(ub_node_link(n, UB_MAX_NODE_LINKS));
    assert_int_equal(ub_node_set_mask(NULL, p->pub, p->pub_peer, 1), UB_ERR_INVAL);
    assert_int_equal(ub_node_set_mask(n, p->pub_peer, p->pub, 1), UB_ERR_INVAL);
    assert_int_equal(ub_node_set_mask(n, p->pub, UB_MAX_ENTITIES, 1), UB_ERR_INVAL);
    assert_int_equal(ub_node_set_mask(n, p->pub, p->pub, 1), UB_ERR_INVAL);
    assert_int_equal(ub_node_set_mask(n, p->pub, p->pub_peer, 0x80), UB_ERR_NOTFOUND);
    assert_int_equal(ub_node_get_mask(NULL, p->pub, p->pub_peer, &mask), UB_ERR_INVAL);
    assert_int_equal(ub_node_get_mask(n, p->pub, p->pub_peer, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_get_mask(n, p->pub_peer, p->pub, &mask), UB_ERR_INVAL);
    assert_int_equal(ub_node_get_mask(n, p->pub, -1, &mask), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_attach(NULL, 0, &no_send, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_attach(n, 9, &no_send, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_attach(n, p->pub_link, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_attach(n, p->pub_link, &no_send, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_set_transport(NULL, 0, &no_send, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_set_transport(n, 9, &no_send, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_set_transport(n, p->pub_link, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_set_transport(n, p->pub_link, &no_send, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_detach(NULL, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_detach(n, 9), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_bad_frames(NULL, 0, UB_RX_BAD_CRC), 0);
    assert_int_equal(ub_node_link_bad_frames(n, 9, UB_RX_BAD_CRC), 0);
    assert_int_equal(ub_node_link_bad_frames(n, p->pub_link, UB_RX_REASON_COUNT), 0);
    int storage;
    assert_int_equal(ub_node_bind(NULL, TEST_GPS, &storage), UB_ERR_INVAL);
    assert_int_equal(ub_node_bind(n, TEST_GPS, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_bind(n, 99, &storage), UB_ERR_INVAL);
    assert_null(ub_node_binding(NULL, TEST_GPS));
    uint8_t byte = 0;
    assert_int_equal(ub_node_rx(NULL, 0, &byte, 1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_rx(n, 9, &byte, 1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_rx(n, p->pub_link, NULL, 1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_rx(n, p->pub_link, NULL, 0, 0), 0);
    assert_int_equal(ub_node_rx_frame(NULL, 0, &byte, 1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_rx_frame(n, 9, &byte, 1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_rx_frame(n, p->pub_link, NULL, 1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_send_data(NULL, p->pub, TEST_GPS, p->sub_id, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_send_data(n, p->pub, TEST_GPS, NULL, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_send_data(n, p->pub_peer, TEST_GPS, p->sub_id, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_send_data(n, p->pub, 99, p->sub_id, 0), UB_ERR_INVAL);
    assert_int_equal(ub_node_send_data(n, p->pub, TEST_IMU, p->sub_id, 0), UB_ERR_NOTFOUND); /* unbound */
    pair_free(p);
}

static void test_log_contracts(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    static ub_log_t log;
    static ub_node_t bare;
    assert_int_equal(ub_log_open(NULL, 1, p->pub_node, "n", true, 0, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_open(&log, -1, p->pub_node, "n", true, 0, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_open(&log, 1, NULL, "n", true, 0, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_open(&log, 1, p->pub_node, NULL, true, 0, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_open(&log, 1, &bare, "n", true, 0, 0), UB_ERR_INVAL); /* no catalogue */
    char name[UB_LOG_NAME_MAX + 1];
    memset(name, 'n', sizeof name - 1);
    name[sizeof name - 1] = '\0';
    assert_int_equal(ub_log_open(&log, 1, p->pub_node, name, true, 0, 0), UB_ERR_NOSPACE);
    char path[UB_LOG_PATH_MAX + 8];
    memset(path, 'p', sizeof path - 1);
    path[sizeof path - 1] = '\0';
    assert_int_equal(ub_log_open_path(&log, NULL, NULL, p->pub_node, "n", true, 0, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_open_path(&log, path, NULL, p->pub_node, "n", true, 0, 0), UB_ERR_NOSPACE);
    assert_int_equal(ub_log_open_path(&log, "/nonexistent-dir/x.ublog", NULL, p->pub_node, "n", true, 0, 0),
                     UB_ERR_IO);
    assert_int_equal(ub_log_open_path(&log, "/tmp/x.ublog", NULL, NULL, "n", true, 0, 0), UB_ERR_INVAL);
    char out[8];
    assert_int_equal(ub_log_file_name("a.ublog", 0, NULL, 8), UB_ERR_INVAL);
    assert_int_equal(ub_log_file_name("a.ublog", 0, out, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_file_name("a-long-name.ublog", 0, out, sizeof out), UB_ERR_NOSPACE);
    uint8_t frame[UB_FRAME_MAX] = {0};
    assert_int_equal(ub_log_write(NULL, 0, UB_TAP_RX, frame, 64, 0), UB_ERR_INVAL);
    memset(&log, 0, sizeof log);
    assert_int_equal(ub_log_write(&log, 0, UB_TAP_RX, frame, 64, 0), UB_ERR_INVAL); /* not open */
    int fd = open("/dev/null", O_WRONLY);
    assert_true(fd >= 0);
    assert_int_equal(ub_log_open(&log, fd, p->pub_node, "n", false, 0, 0), UB_OK);
    assert_int_equal(ub_log_write(&log, 0, UB_TAP_RX, NULL, 64, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_write(&log, 0, UB_TAP_RX, frame, 0, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_write(&log, 0, UB_TAP_RX, frame, UB_FRAME_MAX + 1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_write(&log, -1, UB_TAP_RX, frame, 64, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_write(&log, 256, UB_TAP_RX, frame, 64, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_write(&log, 0, (ub_tap_dir_t)2, frame, 64, 0), UB_ERR_INVAL);
    ub_log_tap(NULL, 0, UB_TAP_RX, frame, 64, 0);
    ub_log_tap(&log, 0, UB_TAP_TX, frame, 64, 0); /* record_tx off: skipped, counted */
    ub_log_tap(&log, 0, UB_TAP_RX, frame, 0, 0);  /* refused by ub_log_write: counted as an error */
    assert_int_equal(ub_log_stats(&log)->skipped_tx, 1);
    assert_int_equal(ub_log_stats(&log)->write_errors, 1);
    assert_null(ub_log_stats(NULL));
    assert_int_equal(ub_log_file_index(NULL), 0);
    ub_log_set_write_fn(NULL, NULL, NULL);
    ub_log_close(&log);
    ub_log_close(&log);
    ub_log_close(NULL);
    close(fd);
    /* Reader contracts. */
    ub_log_reader_t rd;
    ub_log_record_t rec;
    assert_int_equal(ub_log_reader_init(NULL, frame, 10, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_log_header_parse(NULL, 10, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_log_header_parse(frame, 0, NULL), UB_ERR_TRUNCATED); /* nothing yet: read more */
    assert_int_equal(ub_log_reader_next(NULL, &rec), 0);
    ub_log_reader_begin(&rd, 2);
    assert_int_equal(ub_log_reader_next(&rd, NULL), 0);
    assert_int_equal(ub_log_reader_next(&rd, &rec), 0); /* no window yet */
    ub_log_reader_data(&rd, NULL, 5, true);
    assert_int_equal(ub_log_reader_next(&rd, &rec), 0);
    ub_log_reader_begin(NULL, 2);
    ub_log_reader_data(NULL, frame, 1, true);
    ub_log_reader_expect_seq(NULL, 1);
    assert_int_equal(ub_log_reader_consumed(NULL), 0);
    assert_null(ub_log_reader_stats(NULL));
    assert_int_equal(ub_log_reader_ignored(NULL), 0);
    pair_free(p);
}

static void test_driver_contracts(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    uint16_t port = 0;
    /* UDP */
    ub_udp_t udp;
    assert_int_equal(ub_udp_open(NULL, "127.0.0.1", 0, "127.0.0.1", 9), UB_ERR_INVAL);
    assert_int_equal(ub_udp_open(&udp, "not an address", 0, "127.0.0.1", 9), UB_ERR_INVAL);
    assert_int_equal(ub_udp_open(&udp, "203.0.113.1", 0, "127.0.0.1", 9), UB_ERR_IO); /* not ours to bind */
    assert_int_equal(ub_udp_set_peer(NULL, "127.0.0.1", 9), UB_ERR_INVAL);
    assert_int_equal(ub_udp_local_port(NULL, &port), UB_ERR_INVAL);
    assert_int_equal(ub_udp_attach(NULL, p->pub_node, p->pub_link), UB_ERR_INVAL);
    assert_int_equal(ub_udp_service(NULL, p->pub_node, 0), UB_ERR_INVAL);
    assert_int_equal(ub_udp_set_batching(NULL, 1), UB_ERR_INVAL);
    assert_int_equal(ub_udp_flush(NULL), UB_ERR_INVAL);
    assert_int_equal(ub_udp_tx_pending(NULL), 0);
    assert_int_equal(ub_udp_fileno(NULL), -1);
    ub_udp_close(NULL);
    assert_int_equal(ub_udp_open(&udp, "127.0.0.1", 0, "127.0.0.1", 9), UB_OK);
    assert_int_equal(ub_udp_set_peer(&udp, "nowhere", 9), UB_ERR_INVAL);
    assert_int_equal(ub_udp_local_port(&udp, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_udp_attach(&udp, p->pub_node, 99), UB_ERR_INVAL);
    assert_int_equal(ub_udp_service(&udp, p->sub_node, 0), UB_ERR_INVAL); /* not attached to that node */
    ub_udp_close(&udp);
    ub_udp_close(&udp);
    assert_int_equal(ub_udp_local_port(&udp, &port), UB_ERR_INVAL);
    /* TCP */
    ub_tcp_t tcp;
    assert_int_equal(ub_tcp_client_init(NULL, "127.0.0.1", 1, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_server_open(NULL, "127.0.0.1", 0, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_server_open(&tcp, "bad", 0, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_server_open(&tcp, "203.0.113.1", 0, NULL), UB_ERR_IO);
    assert_int_equal(ub_tcp_local_port(NULL, &port), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_attach(NULL, p->pub_node, 0), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_service(NULL, p->pub_node, 0), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_fileno(NULL), -1);
    assert_int_equal(ub_tcp_listen_fileno(NULL), -1);
    assert_int_equal(ub_tcp_state(NULL), UB_TCP_DOWN);
    assert_int_equal(ub_tcp_tx_pending(NULL), 0);
    assert_null(ub_tcp_stats(NULL));
    ub_tcp_close(NULL);
    ub_tcp_options_t odd = {.backoff_initial_ms = 500, .backoff_max_ms = 100}; /* max below initial: raised */
    assert_int_equal(ub_tcp_client_init(&tcp, "127.0.0.1", 1, &odd), UB_OK);
    assert_int_equal(tcp.opt.backoff_max_ms, 500);
    assert_int_equal(ub_tcp_local_port(&tcp, &port), UB_ERR_INVAL); /* a client has no listening port */
    assert_int_equal(ub_tcp_attach(&tcp, p->pub_node, 99), UB_ERR_INVAL);
    assert_int_equal(ub_tcp_flush(&tcp, 0), 0); /* not connected: nothing queued */
    ub_tcp_close(&tcp);
    /* Serial */
    ub_serial_t ser;
    assert_int_equal(ub_serial_open(NULL, "/dev/null", 9600), UB_ERR_INVAL);
    assert_int_equal(ub_serial_open(&ser, NULL, 9600), UB_ERR_INVAL);
    char longpath[UB_SERIAL_PATH_MAX + 4];
    memset(longpath, 'd', sizeof longpath - 1);
    longpath[sizeof longpath - 1] = '\0';
    assert_int_equal(ub_serial_open(&ser, longpath, 9600), UB_ERR_NOSPACE);
    assert_int_equal(ub_serial_adopt(NULL, 0, 0), UB_ERR_INVAL);
    int fd = open("/dev/null", O_RDWR);
    assert_int_equal(ub_serial_adopt(&ser, fd, 1234), UB_ERR_RANGE);
    assert_int_equal(ub_serial_adopt(&ser, fd, 9600), UB_ERR_IO); /* not a tty */
    assert_int_equal(ub_serial_adopt(&ser, 1000, 0), UB_ERR_IO);  /* not open */
    close(fd);
    assert_int_equal(ub_serial_attach(NULL, p->pub_node, 0), UB_ERR_INVAL);
    assert_int_equal(ub_serial_service(NULL, p->pub_node, 0), UB_ERR_INVAL);
    assert_int_equal(ub_serial_fileno(NULL), -1);
    assert_int_equal(ub_serial_state(NULL), UB_SERIAL_DOWN);
    assert_false(ub_serial_next_retry(NULL, NULL));
    assert_int_equal(ub_serial_tx_pending(NULL), 0);
    assert_null(ub_serial_stats(NULL));
    ub_serial_close(NULL);
    pair_free(p);
}

/* ub_ports: argument contracts, a serial port opened from a spec (pty), poll sets that do not fit. */
static void test_ports_contracts_and_serial_ports(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_ports_t *ports = calloc(1, sizeof *ports);
    assert_non_null(ports);
    char err[UB_PORTS_ERR_LEN];
    ub_port_spec_t spec;
    char name[64];
    assert_int_equal(ub_ports_init(NULL, p->sub_node), UB_ERR_INVAL);
    assert_int_equal(ub_ports_init(ports, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_port_spec_parse(NULL, &spec, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_spec_parse("udp", NULL, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_spec_parse("", &spec, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_spec_parse("pigeon", &spec, NULL, 0), UB_ERR_INVAL); /* no message wanted */
    assert_int_equal(ub_port_arg_parse(NULL, name, sizeof name, &spec, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_arg_parse("a=mem", NULL, sizeof name, &spec, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_arg_parse("a=mem", name, 0, &spec, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_arg_parse("a=mem", name, sizeof name, NULL, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_arg_parse("abcdef=mem", name, 4, &spec, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_spec_from_config(NULL, "x", &spec, err, sizeof err), UB_ERR_INVAL);
    ub_nodecfg_port_t entry;
    memset(&entry, 0, sizeof entry);
    snprintf(entry.name, sizeof entry.name, "subPort");
    snprintf(entry.transport, sizeof entry.transport, "carrier-pigeon");
    assert_int_equal(ub_port_spec_from_config(&entry, NULL, &spec, err, sizeof err), UB_ERR_CONFIG);
    assert_non_null(strstr(err, "<config>:0: port 'subPort', field 'transport': unknown transport"));
    snprintf(entry.transport, sizeof entry.transport, "serial");
    assert_int_equal(ub_port_spec_from_config(&entry, "c.json", &spec, err, sizeof err), UB_ERR_CONFIG);
    assert_non_null(strstr(err, "serial needs device=PATH"));
    char text[16];
    ub_port_spec_format(NULL, text, sizeof text);
    ub_port_spec_format(&spec, NULL, 4);
    assert_int_equal(ub_port_spec_parse("tcp:connect=127.0.0.1:5001", &spec, err, sizeof err), UB_OK);
    ub_port_spec_format(&spec, text, sizeof text); /* cut, ends in "..." */
    assert_string_equal(text + strlen(text) - 3, "...");
    assert_string_equal(ub_port_kind_transport((ub_port_kind_t)99), "none");

    assert_int_equal(ub_ports_init(ports, p->sub_node), UB_OK);
    assert_int_equal(ub_ports_open(NULL, "subPort", &spec, 0, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_ports_open(ports, NULL, &spec, 0, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_ports_open(ports, "subPort", NULL, 0, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_ports_open(ports, ":subPort", &spec, 0, err, sizeof err), UB_ERR_NOTFOUND);
    assert_int_equal(ub_ports_open(ports, "a-much-too-long-entity:subPort", &spec, 0, err, sizeof err),
                     UB_ERR_NOTFOUND);
    assert_int_equal(ub_ports_open_text(ports, NULL, "bogus", 0, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "port '?'"));
    assert_int_equal(ub_ports_open_config(NULL, NULL, 0, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_ports_close(NULL, "subPort"), UB_ERR_INVAL);
    assert_int_equal(ub_ports_close(ports, "subPort"), UB_ERR_NOTFOUND);
    ub_ports_close_all(NULL);
    assert_int_equal(ub_ports_service(NULL, 0), 0);
    struct pollfd fds[4];
    assert_int_equal(ub_ports_pollfds(NULL, fds, 4), UB_ERR_INVAL);
    assert_int_equal(ub_ports_pollfds(ports, NULL, 4), UB_ERR_INVAL);
    assert_int_equal(ub_ports_pollfds(ports, fds, -1), UB_ERR_INVAL);
    assert_int_equal(ub_ports_poll_timeout(NULL, 0, -5), 0);
    assert_int_equal(ub_ports_poll_timeout(NULL, 0, 7), 7);
    uint16_t port;
    assert_int_equal(ub_ports_local_port(NULL, "subPort", &port), UB_ERR_INVAL);
    assert_int_equal(ub_ports_local_port(ports, "subPort", NULL), UB_ERR_INVAL);
    assert_null(ub_ports_find(NULL, "subPort"));
    assert_int_equal(ub_ports_set_impairment(NULL, NULL, 0), UB_ERR_INVAL);

    /* A serial port from a spec, on a pty, under impairment: polled, serviced, hung up, reopened by path. */
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    assert_true(master >= 0);
    assert_int_equal(grantpt(master), 0);
    assert_int_equal(unlockpt(master), 0);
    char spec_text[128];
    snprintf(spec_text, sizeof spec_text, "serial:device=%s,baud=57600", ptsname(master));
    ub_impair_params_t imp = {.loss_ppm = 1};
    assert_int_equal(ub_ports_set_impairment(ports, &imp, 3), UB_OK);
    assert_int_equal(ub_ports_open_text(ports, "subPort", spec_text, 0, err, sizeof err), UB_OK);
    assert_int_equal(ub_ports_local_port(ports, "subPort", &port), UB_ERR_INVAL); /* serial: no local port */
    assert_int_equal(ub_ports_pollfds(ports, fds, 0), UB_ERR_NOSPACE);
    assert_int_equal(ub_ports_pollfds(ports, fds, 4), 1);
    assert_int_equal(ub_ports_service(ports, 1), 0);
    close(master); /* hang-up: the pty slave vanishes */
    assert_int_equal(ub_ports_service(ports, 2), 0);
    const ub_serial_t *sp = ub_ports_state(ports, "subPort", &ub_serial_driver);
    assert_non_null(sp);
    assert_int_equal(ub_serial_stats(sp)->hangups, 1);
    assert_int_equal(ub_ports_pollfds(ports, fds, 4), 0); /* nothing to poll while down */
    assert_int_equal(ub_ports_poll_timeout(ports, 2, 1000), UB_SERIAL_RETRY_MIN_MS); /* woken for the retry */
    assert_int_equal(ub_ports_set_impairment(ports, NULL, 3), UB_OK);
    assert_int_equal(ub_ports_close(ports, "subPort"), UB_OK);
    ub_ports_close_all(ports);
    free(ports);
    pair_free(p);
}

/* UDP paths of the driver that the exchange tests do not take: a datagram larger than any frame
 * (truncated on receive: one rejection), batching with every slot full, turning batching off. */
static void test_udp_oversize_and_full_batches(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_udp_t a, b;
    uint16_t pa = 0, pb = 0;
    assert_int_equal(ub_udp_open(&a, "127.0.0.1", 0, "127.0.0.1", 9), UB_OK);
    assert_int_equal(ub_udp_open(&b, "127.0.0.1", 0, "127.0.0.1", 9), UB_OK);
    assert_int_equal(ub_udp_local_port(&a, &pa), UB_OK);
    assert_int_equal(ub_udp_local_port(&b, &pb), UB_OK);
    assert_int_equal(ub_udp_set_peer(&a, "127.0.0.1", pb), UB_OK);
    assert_int_equal(ub_udp_set_peer(&b, "127.0.0.1", pa), UB_OK);
    assert_int_equal(ub_udp_attach(&a, p->pub_node, p->pub_link), UB_OK);
    assert_int_equal(ub_udp_attach(&b, p->sub_node, p->sub_link), UB_OK);
    /* Oversize: sent from a's socket so it is from the peer. */
    static uint8_t big[UB_UDP_DATAGRAM_MAX + 100];
    memset(big, 0xA5, sizeof big);
    struct sockaddr_in to = {.sin_family = AF_INET, .sin_port = htons(pb)};
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    assert_int_equal(sendto(ub_udp_fileno(&a), big, sizeof big, 0, (struct sockaddr *)&to, sizeof to), (ssize_t)sizeof big);
    assert_int_equal(ub_udp_service(&b, p->sub_node, 0), 1);
    assert_int_equal(b.stats.rejected, 1);
    /* Batching: fill every slot with frames too big to share a datagram, then one more. */
    assert_int_equal(ub_udp_set_batching(&a, 1), UB_OK);
    test_rng_t rng = {5};
    uint8_t frame[UB_FRAME_MAX];
    size_t n = random_frame(&rng, frame, UB_MAX_PAYLOAD);
    for (int i = 0; i < UB_UDP_TX_SLOTS + 1; i++) assert_int_equal(ub_udp_ops.send(&a, frame, n, 0), UB_OK);
    assert_int_equal(ub_udp_tx_pending(&a), 1); /* the full slots went out in one sendmmsg() */
    assert_int_equal(ub_udp_ops.send(&a, frame, UB_UDP_DATAGRAM_MAX + 1, 0), UB_ERR_INVAL);
    assert_int_equal(ub_udp_set_batching(&a, 0), UB_OK); /* flushes the rest first */
    assert_int_equal(ub_udp_tx_pending(&a), 0);
    for (int i = 0; i < 20; i++) assert_true(ub_udp_service(&b, p->sub_node, (uint64_t)i) >= 0);
    assert_int_equal(b.stats.frames_in, 1 + UB_UDP_TX_SLOTS + 1);
    ub_udp_close(&a);
    assert_int_equal(ub_udp_ops.send(&a, frame, n, 0), UB_ERR_CLOSED);
    assert_int_equal(ub_udp_flush(&a), 0);
    ub_udp_close(&b);
    pair_free(p);
}

/* Every error code has its own name; codes nobody defined say so. */
static void test_error_names(void **state) {
    (void)state;
    static const struct {
        int code;
        const char *name;
    } k[] = {{UB_OK, "UB_OK"},           {UB_ERR_INVAL, "UB_ERR_INVAL"},       {UB_ERR_NOSPACE, "UB_ERR_NOSPACE"},
             {UB_ERR_TRUNCATED, "UB_ERR_TRUNCATED"}, {UB_ERR_FULL, "UB_ERR_FULL"}, {UB_ERR_NOTFOUND, "UB_ERR_NOTFOUND"},
             {UB_ERR_EXISTS, "UB_ERR_EXISTS"}, {UB_ERR_CHECKSUM, "UB_ERR_CHECKSUM"}, {UB_ERR_LAYOUT, "UB_ERR_LAYOUT"},
             {UB_ERR_NOROUTE, "UB_ERR_NOROUTE"}, {UB_ERR_IO, "UB_ERR_IO"},     {UB_ERR_AGAIN, "UB_ERR_AGAIN"},
             {UB_ERR_CONFIG, "UB_ERR_CONFIG"}, {UB_ERR_CLOSED, "UB_ERR_CLOSED"}, {UB_ERR_RANGE, "UB_ERR_RANGE"},
             {UB_ERR_AUTH, "UB_ERR_AUTH"}, {UB_ERR_UNSUPPORTED, "UB_ERR_UNSUPPORTED"},
             {UB_ERR_REFUSED, "UB_ERR_REFUSED"}, {UB_ERR_NOANSWER, "UB_ERR_NOANSWER"},
             {-17, "UB_ERR_UNKNOWN"},    {-99, "UB_ERR_UNKNOWN"},    {7, "UB_OK"}};
    for (size_t i = 0; i < sizeof k / sizeof k[0]; i++) assert_string_equal(ub_strerror(k[i].code), k[i].name);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_error_names),
        cmocka_unit_test(test_node_contracts),
        cmocka_unit_test(test_log_contracts),
        cmocka_unit_test(test_driver_contracts),
        cmocka_unit_test(test_ports_contracts_and_serial_ports),
        cmocka_unit_test(test_udp_oversize_and_full_batches),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

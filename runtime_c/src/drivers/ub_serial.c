/* Baud rates above 38400 are Linux/BSD extensions of termios. */
#define _DEFAULT_SOURCE 1

#include "ub/ub_serial.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

#include "ub/ub_node.h"
#include "ub/ub_ports.h"
#include "ub/ub_service.h"
#include "drivers/ub_stream_tx_private.h"

typedef struct baud_entry {
    uint32_t baud;
    speed_t speed;
} baud_entry_t;

static const baud_entry_t baud_table[] = {
    {1200, B1200},     {2400, B2400},     {4800, B4800},     {9600, B9600},     {19200, B19200},   {38400, B38400},
    {57600, B57600},   {115200, B115200}, {230400, B230400}, {460800, B460800}, {921600, B921600},
};

static int find_speed(uint32_t baud, speed_t *speed) {
    for (size_t i = 0; i < sizeof baud_table / sizeof baud_table[0]; i++) {
        if (baud_table[i].baud == baud) {
            *speed = baud_table[i].speed;
            return UB_OK;
        }
    }
    return UB_ERR_RANGE;
}

/* Raw 8N1 without flow control, spelled out flag by flag (cfmakeraw() is not POSIX and leaves CRTSCTS alone). */
static int configure(int fd, speed_t speed) {
    struct termios tio;
    if (tcgetattr(fd, &tio) < 0) return UB_ERR_IO;
    tio.c_iflag &=
        ~(tcflag_t)(IGNBRK | BRKINT | PARMRK | ISTRIP | INLCR | IGNCR | ICRNL | IXON | IXOFF | IXANY | INPCK);
    tio.c_oflag &= ~(tcflag_t)OPOST;
    tio.c_lflag &= ~(tcflag_t)(ECHO | ECHONL | ICANON | ISIG | IEXTEN);
    tio.c_cflag &= ~(tcflag_t)(CSIZE | PARENB | CSTOPB | CRTSCTS);
    tio.c_cflag |= CS8 | CREAD | CLOCAL;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    if (cfsetispeed(&tio, speed) < 0 || cfsetospeed(&tio, speed) < 0) return UB_ERR_IO;
    return tcsetattr(fd, TCSANOW, &tio) < 0 ? UB_ERR_IO : UB_OK;
}

static void reset(ub_serial_t *serial) {
    memset(serial, 0, sizeof *serial);
    serial->fd = -1;
    serial->link_id = -1;
    serial->state = UB_SERIAL_DOWN;
    serial->backoff_ms = UB_SERIAL_RETRY_MIN_MS;
}

/* open() + configure(); @return the descriptor, or -1 with errno set. */
static int open_device(const char *path, speed_t speed) {
    int fd = open(path, O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (fd < 0) return -1;
    if (configure(fd, speed) < 0) {
        int saved = errno;
        close(fd);
        errno = saved;
        return -1;
    }
    return fd;
}

int ub_serial_open(ub_serial_t *serial, const char *path, uint32_t baud) {
    if (serial == NULL || path == NULL) return UB_ERR_INVAL;
    reset(serial);
    speed_t speed;
    if (find_speed(baud, &speed) < 0) return UB_ERR_RANGE;
    size_t n = strlen(path);
    if (n >= sizeof serial->path) return UB_ERR_NOSPACE;
    int fd = open_device(path, speed);
    if (fd < 0) return UB_ERR_IO;
    memcpy(serial->path, path, n + 1);
    serial->baud = baud;
    serial->fd = fd;
    serial->owns_fd = 1;
    serial->state = UB_SERIAL_UP;
    return UB_OK;
}

int ub_serial_adopt(ub_serial_t *serial, int fd, uint32_t baud) {
    if (serial == NULL || fd < 0) return UB_ERR_INVAL;
    reset(serial);
    speed_t speed;
    if (baud != 0 && find_speed(baud, &speed) < 0) return UB_ERR_RANGE;
    int flags = fcntl(fd, F_GETFL);
    if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) < 0) return UB_ERR_IO;
    if (baud != 0 && configure(fd, speed) < 0) return UB_ERR_IO;
    serial->fd = fd;
    serial->baud = baud;
    serial->state = UB_SERIAL_UP;
    return UB_OK;
}

/* errno values that mean the device itself is gone (pulled adapter, closed pty end, dropped carrier). */
static bool gone(int err) { return err == EIO || err == ENXIO || err == ENODEV || err == EPIPE; }

/* The device went away: count it and close the descriptor at once (a hung-up tty polls readable forever,
 * so keeping it would spin the caller's poll loop); a device opened by path is retried after the backoff. */
static void hang_up(ub_serial_t *serial, uint64_t now_ms) {
    serial->stats.hangups++;
    serial->stats.tx_discarded += serial->tx_len;
    serial->tx_len = 0;
    if (serial->owns_fd) close(serial->fd);
    serial->fd = -1;
    serial->state = UB_SERIAL_DOWN;
    serial->hung = 1;
    serial->next_attempt_ms = now_ms + serial->backoff_ms;
    /* Carrier lost, adapter pulled, the pty's other end closed: transport evidence (ub_node_link_event()). */
    if (serial->node != NULL) ub_node_link_event(serial->node, serial->link_id, UB_LINK_EVENT_DOWN, now_ms);
}

/* Reopens a device opened by path when its retry is due; a new device re-attaches the node slot, which
 * resets the slot's decoder (counting the bytes it held), so the new stream starts clean. */
static void try_reopen(ub_serial_t *serial, uint64_t now_ms) {
    if (serial->path[0] == '\0' || now_ms < serial->next_attempt_ms) return;
    speed_t speed = B115200;
    (void)find_speed(serial->baud, &speed); /* cannot fail: checked by ub_serial_open() */
    int fd = open_device(serial->path, speed);
    if (fd < 0) {
        serial->stats.reopen_failures++;
        serial->backoff_ms = serial->backoff_ms > UB_SERIAL_RETRY_MAX_MS / 2u ? UB_SERIAL_RETRY_MAX_MS
                                                                              : serial->backoff_ms * 2u;
        serial->next_attempt_ms = now_ms + serial->backoff_ms;
        return;
    }
    serial->fd = fd;
    serial->state = UB_SERIAL_UP;
    serial->hung = 0;
    serial->backoff_ms = UB_SERIAL_RETRY_MIN_MS;
    serial->stats.reopens++;
    /* Only ub_serial_service() gets here, which checked that `serial->node` is the (non-NULL) node it serves. */
    int attached = ub_driver_reattach(serial->node, serial->link_id, serial->ops, serial->ops_impl);
    (void)attached; /* cannot fail: ub_serial_attach() succeeded with these arguments */
    ub_node_link_event(serial->node, serial->link_id, UB_LINK_EVENT_UP, now_ms); /* the link is back: evidence */
    ub_decoder_restart(serial->dec); /* the same restart for the caller's decoder, keeping its handler (NULL: none) */
}

static long device_write(int fd, const uint8_t *data, size_t len) { return (long)write(fd, data, len); }

/* Writes whole or nothing through the transmit buffer; `counter` counts what went in (a frame, a foreign message). */
static int serial_write(ub_serial_t *serial, const uint8_t *data, size_t len, uint64_t now_ms, uint64_t *counter) {
    if (serial->state != UB_SERIAL_UP) {
        serial->stats.send_closed++;
        return UB_ERR_CLOSED;
    }
    int rc = ub_stream_tx_send(serial->fd, device_write, serial->tx, sizeof serial->tx, &serial->tx_len, data, len,
                               &serial->stats.bytes_out);
    if (rc == UB_ERR_AGAIN) {
        serial->stats.backpressure++;
        return rc;
    }
    if (rc < 0) {
        if (gone(errno)) {
            hang_up(serial, now_ms);
            return UB_ERR_CLOSED;
        }
        serial->stats.io_errors++;
        return rc;
    }
    (*counter)++;
    return UB_OK;
}

static int serial_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    ub_serial_t *serial = impl;
    return serial_write(serial, frame, len, now_ms, &serial->stats.frames_out);
}

int ub_serial_write_foreign(ub_serial_t *serial, const uint8_t *data, size_t len, uint64_t now_ms) {
    if (serial == NULL || (data == NULL && len != 0) || len > sizeof serial->tx) return UB_ERR_INVAL;
    return serial_write(serial, data, len, now_ms, &serial->stats.foreign_out);
}

int ub_serial_set_rx_hook(ub_serial_t *serial, int (*hook)(void *user, const uint8_t *data, size_t len, uint64_t now_ms),
                          void *user) {
    if (serial == NULL) return UB_ERR_INVAL;
    serial->rx_hook = hook;
    serial->rx_user = hook != NULL ? user : NULL;
    return UB_OK;
}

int ub_serial_set_decoder(ub_serial_t *serial, ub_decoder_t *dec) {
    if (serial == NULL) return UB_ERR_INVAL;
    serial->dec = dec;
    return UB_OK;
}

int ub_serial_set_foreign(ub_serial_t *serial, ub_foreign_cb cb, void *user) {
    if (serial == NULL) return UB_ERR_INVAL;
    if (cb == NULL) { /* back to the slot's decoder: what the own one still held is counted garbage there */
        if (serial->dec == &serial->own_dec) {
            ub_decoder_restart(&serial->own_dec);
            serial->dec = NULL;
        }
        return UB_OK;
    }
    if (serial->dec != &serial->own_dec) ub_decoder_init(&serial->own_dec);
    ub_decoder_set_foreign(&serial->own_dec, cb, user);
    serial->dec = &serial->own_dec;
    return UB_OK;
}

static int serial_fileno(void *impl) { return ub_serial_fileno(impl); }

const ub_link_ops_t ub_serial_ops = {.kind = "serial", .send = serial_send, .fileno = serial_fileno};

int ub_serial_attach(ub_serial_t *serial, ub_node_t *node, int link_id) {
    return ub_serial_attach_as(serial, node, link_id, &ub_serial_ops, serial);
}

int ub_serial_attach_as(ub_serial_t *serial, ub_node_t *node, int link_id, const ub_link_ops_t *ops, void *impl) {
    if (serial == NULL || ops == NULL) return UB_ERR_INVAL;
    int rc = ub_driver_attach(node, link_id, ops, impl, &serial->node, &serial->link_id);
    if (rc == UB_OK) {
        serial->ops = ops;
        serial->ops_impl = impl;
    }
    return rc;
}

/* read() returned 0. With VMIN = VTIME = 0 that is also "no data now", so ask poll(): a hung-up tty
 * (carrier lost, USB adapter gone, the other end of a pty closed) reports POLLHUP (with POLLERR); POLLIN
 * alone is not enough, since a byte may have arrived just after the read(). */
static bool at_end_of_file(int fd) {
    struct pollfd p = {.fd = fd, .events = POLLIN};
    if (poll(&p, 1, 0) <= 0) return false;
    return (p.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0;
}

int ub_serial_service(ub_serial_t *serial, ub_node_t *node, uint64_t now_ms) {
    if (serial == NULL || node == NULL || node != serial->node) return UB_ERR_INVAL;
    if (serial->state != UB_SERIAL_UP) {
        if (!serial->hung) return UB_ERR_INVAL; /* closed (or never opened), not hung up */
        try_reopen(serial, now_ms);
        if (serial->state != UB_SERIAL_UP) return 0;
    }
    if (serial->tx_len > 0 &&
        ub_stream_tx_flush(serial->fd, device_write, serial->tx, &serial->tx_len, &serial->stats.bytes_out) < 0) {
        if (gone(errno)) {
            hang_up(serial, now_ms);
            return 0;
        }
        serial->stats.io_errors++;
        return UB_ERR_IO;
    }
    int frames = 0;
    for (int i = 0; i < UB_SERIAL_RX_BUDGET; i++) {
        ssize_t n = read(serial->fd, serial->rx, sizeof serial->rx);
        if (n > 0) {
            serial->stats.bytes_in += (uint64_t)n;
            int found = serial->rx_hook != NULL
                            ? serial->rx_hook(serial->rx_user, serial->rx, (size_t)n, now_ms)
                            : ub_node_rx_stream(node, serial->link_id, serial->dec, serial->rx, (size_t)n, now_ms, NULL);
            if (found > 0) frames += found;
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if ((n == 0 && i == 0 && at_end_of_file(serial->fd)) || (n < 0 && gone(errno))) {
            hang_up(serial, now_ms);
            return frames;
        }
        if (n == 0 || errno == EAGAIN || errno == EWOULDBLOCK) break;
        serial->stats.io_errors++;
        return UB_ERR_IO;
    }
    return frames;
}

int ub_serial_fileno(const ub_serial_t *serial) { return serial == NULL ? -1 : serial->fd; }

ub_serial_state_t ub_serial_state(const ub_serial_t *serial) {
    return serial == NULL ? UB_SERIAL_DOWN : (ub_serial_state_t)serial->state;
}

bool ub_serial_next_retry(const ub_serial_t *serial, uint64_t *due_ms) {
    if (serial == NULL || !serial->hung || serial->path[0] == '\0') return false;
    if (due_ms != NULL) *due_ms = serial->next_attempt_ms;
    return true;
}

size_t ub_serial_tx_pending(const ub_serial_t *serial) { return serial == NULL ? 0 : serial->tx_len; }

const ub_serial_stats_t *ub_serial_stats(const ub_serial_t *serial) { return serial == NULL ? NULL : &serial->stats; }

void ub_serial_close(ub_serial_t *serial) {
    if (serial == NULL) return;
    if (serial->fd >= 0 && serial->owns_fd) close(serial->fd);
    serial->fd = -1;
    serial->state = UB_SERIAL_DOWN;
    serial->hung = 0; /* an explicit close ends reopening */
}

/* ---- the driver entry (ub_driver.h): "serial:device=PATH[,baud=RATE]" ---- */

enum { SEEN_DEVICE = 1u };

static void serial_spec_init(ub_port_spec_t *spec) {
    spec->kind = UB_PORT_SERIAL;
    spec->baud = UB_PORT_DEFAULT_BAUD;
}

static int serial_spec_param(ub_port_spec_t *s, uint32_t *seen, const char *key, const char *value, char *err,
                             size_t cap) {
    if (strcmp(key, "device") == 0) {
        size_t n = strlen(value);
        if (n == 0 || n >= UB_PORT_DEVICE_LEN) {
            snprintf(err, cap, "'device': give a device path of 1 to %d characters, e.g. /dev/ttyUSB0",
                     UB_PORT_DEVICE_LEN - 1);
            return UB_ERR_INVAL;
        }
        /* A config file could name one, but the spec text (--port, rebind, the "ready" event) could not say it. */
        if (strchr(value, ',') != NULL) {
            snprintf(err, cap, "'device=%.40s': a device path cannot contain ',' (it separates a spec's parameters); "
                     "use a symlink without one", value);
            return UB_ERR_INVAL;
        }
        memcpy(s->device, value, n + 1);
        *seen |= SEEN_DEVICE;
        return UB_OK;
    }
    if (strcmp(key, "baud") == 0) {
        uint32_t v = 0;
        speed_t speed;
        if (!ub_driver_parse_u32(value, 10000000u, &v) || find_speed(v, &speed) != UB_OK) {
            snprintf(err, cap,
                     "'baud=%.20s': use one of 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, "
                     "921600",
                     value);
            return UB_ERR_INVAL;
        }
        s->baud = v;
        return UB_OK;
    }
    return UB_ERR_NOTFOUND;
}

static int serial_spec_finish(ub_port_spec_t *s, uint32_t seen, char *err, size_t cap) {
    (void)s;
    if (!(seen & SEEN_DEVICE)) {
        snprintf(err, cap, "serial needs device=PATH, e.g. serial:device=/dev/ttyUSB0,baud=115200");
        return UB_ERR_INVAL;
    }
    return UB_OK;
}

static int serial_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    return snprintf(out, cap, "serial:device=%s,baud=%u", spec->device, (unsigned)spec->baud);
}

static int serial_open(void *state, const ub_port_spec_t *spec) { return ub_serial_open(state, spec->device, spec->baud); }
static void serial_close(void *state) { ub_serial_close(state); }
static int serial_attach_op(void *state, ub_node_t *node, int link_id) { return ub_serial_attach(state, node, link_id); }
static int serial_service_op(void *state, ub_node_t *node, uint64_t now_ms) {
    return ub_serial_service(state, node, now_ms);
}

static int serial_pollfds(const void *state, struct pollfd *fds, int cap) {
    const ub_serial_t *serial = state;
    if (serial->fd < 0) return 0; /* down: the retry time wakes the loop (serial_next_due) */
    if (cap < 1) return UB_ERR_NOSPACE;
    fds[0].fd = serial->fd;
    fds[0].events = (short)(POLLIN | (serial->tx_len > 0 ? POLLOUT : 0));
    fds[0].revents = 0;
    return 1;
}

/* A device that hung up and waits to be reopened has no descriptor to wake the loop: its retry time must. */
static bool serial_next_due(const void *state, uint64_t *due_ms) { return ub_serial_next_retry(state, due_ms); }

static int serial_set_foreign_op(void *state, ub_foreign_cb cb, void *user) {
    return ub_serial_set_foreign(state, cb, user);
}

static int serial_write_foreign_op(void *state, const uint8_t *data, size_t len, uint64_t now_ms) {
    return ub_serial_write_foreign(state, data, len, now_ms);
}

static size_t serial_counters(const void *state, ub_driver_counter_t *out, size_t cap) {
    const ub_serial_stats_t *s = &((const ub_serial_t *)state)->stats;
    const ub_driver_counter_t all[] = {
        {"bytes_in", s->bytes_in},         {"bytes_out", s->bytes_out},
        {"frames_out", s->frames_out},     {"foreign_out", s->foreign_out},     {"backpressure", s->backpressure},
        {"io_errors", s->io_errors},       {"hangups", s->hangups},
        {"reopens", s->reopens},           {"reopen_failures", s->reopen_failures},
        {"send_closed", s->send_closed},   {"tx_discarded", s->tx_discarded},
    };
    size_t n = sizeof all / sizeof all[0];
    for (size_t i = 0; i < n && i < cap && out != NULL; i++) out[i] = all[i];
    return n;
}

static int serial_describe(const void *state, char *out, size_t cap) {
    const ub_serial_t *serial = state;
    const ub_serial_stats_t *s = &serial->stats;
    return snprintf(out, cap,
                    "\"state\":\"%s\",\"bytes_in\":%llu,\"bytes_out\":%llu,\"backpressure\":%llu,\"io_errors\":%llu,"
                    "\"hangups\":%llu,\"reopens\":%llu,\"reopen_failures\":%llu,\"send_closed\":%llu,"
                    "\"tx_discarded\":%llu,\"foreign_out\":%llu,\"foreign_bytes\":%llu,\"foreign_refused\":%llu",
                    serial->state == UB_SERIAL_UP ? "up" : "down", (unsigned long long)s->bytes_in,
                    (unsigned long long)s->bytes_out, (unsigned long long)s->backpressure,
                    (unsigned long long)s->io_errors, (unsigned long long)s->hangups, (unsigned long long)s->reopens,
                    (unsigned long long)s->reopen_failures, (unsigned long long)s->send_closed,
                    (unsigned long long)s->tx_discarded, (unsigned long long)s->foreign_out,
                    (unsigned long long)(serial->dec != NULL ? serial->dec->stats.foreign_bytes : 0),
                    (unsigned long long)(serial->dec != NULL ? serial->dec->stats.foreign_refused : 0));
}

const ub_driver_t ub_serial_driver = {
    .name = "serial",
    .keys = "device, baud",
    .examples = "serial:device=/dev/ttyUSB0,baud=115200",
    .wire_params = true,
    .state_size = sizeof(ub_serial_t),
    .spec_init = serial_spec_init,
    .spec_param = serial_spec_param,
    .spec_finish = serial_spec_finish,
    .spec_format = serial_spec_format,
    .open = serial_open,
    .close = serial_close,
    .attach = serial_attach_op,
    .link_ops = &ub_serial_ops,
    .service = serial_service_op,
    .pollfds = serial_pollfds,
    .next_due = serial_next_due,
    .counters = serial_counters,
    .describe = serial_describe,
    .set_foreign = serial_set_foreign_op,
    .write_foreign = serial_write_foreign_op,
};

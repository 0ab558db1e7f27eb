/* Baud rates above 38400 are Linux/BSD extensions of termios. */
#define _DEFAULT_SOURCE 1

#include "ub/ub_serial.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

#include "ub/ub_node.h"
#include "ub_stream_tx_private.h"

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
}

int ub_serial_open(ub_serial_t *serial, const char *path, uint32_t baud) {
    if (serial == NULL || path == NULL) return UB_ERR_INVAL;
    reset(serial);
    speed_t speed;
    if (find_speed(baud, &speed) < 0) return UB_ERR_RANGE;
    int fd = open(path, O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (fd < 0) return UB_ERR_IO;
    if (configure(fd, speed) < 0) {
        int saved = errno;
        close(fd);
        errno = saved;
        return UB_ERR_IO;
    }
    serial->fd = fd;
    serial->owns_fd = 1;
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
    return UB_OK;
}

static long device_write(int fd, const uint8_t *data, size_t len) { return (long)write(fd, data, len); }

static int serial_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)now_ms;
    ub_serial_t *serial = impl;
    if (serial->fd < 0) return UB_ERR_CLOSED;
    int rc = ub_stream_tx_send(serial->fd, device_write, serial->tx, sizeof serial->tx, &serial->tx_len, frame, len,
                               &serial->stats.bytes_out);
    if (rc == UB_ERR_AGAIN) {
        serial->stats.backpressure++;
        return rc;
    }
    if (rc < 0) {
        serial->stats.io_errors++;
        return rc;
    }
    serial->stats.frames_out++;
    return UB_OK;
}

static int serial_fileno(void *impl) { return ub_serial_fileno(impl); }

const ub_link_ops_t ub_serial_ops = {.kind = "serial", .send = serial_send, .fileno = serial_fileno};

int ub_serial_attach(ub_serial_t *serial, ub_node_t *node, int link_id) {
    if (serial == NULL) return UB_ERR_INVAL;
    int rc = ub_node_link_attach(node, link_id, &ub_serial_ops, serial);
    if (rc < 0) return rc;
    serial->node = node;
    serial->link_id = link_id;
    return UB_OK;
}

int ub_serial_service(ub_serial_t *serial, ub_node_t *node, uint64_t now_ms) {
    if (serial == NULL || serial->fd < 0 || node == NULL || node != serial->node) return UB_ERR_INVAL;
    if (serial->tx_len > 0 &&
        ub_stream_tx_flush(serial->fd, device_write, serial->tx, &serial->tx_len, &serial->stats.bytes_out) < 0) {
        serial->stats.io_errors++;
        return UB_ERR_IO;
    }
    int frames = 0;
    for (int i = 0; i < UB_SERIAL_RX_BUDGET; i++) {
        ssize_t n = read(serial->fd, serial->rx, sizeof serial->rx);
        if (n > 0) {
            serial->stats.bytes_in += (uint64_t)n;
            int found = ub_node_rx(node, serial->link_id, serial->rx, (size_t)n, now_ms);
            if (found > 0) frames += found;
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        /* 0 with VMIN = VTIME = 0, or EAGAIN: nothing more now. */
        if (n == 0 || errno == EAGAIN || errno == EWOULDBLOCK) break;
        serial->stats.io_errors++;
        return UB_ERR_IO;
    }
    return frames;
}

int ub_serial_fileno(const ub_serial_t *serial) { return serial == NULL ? -1 : serial->fd; }

size_t ub_serial_tx_pending(const ub_serial_t *serial) { return serial == NULL ? 0 : serial->tx_len; }

const ub_serial_stats_t *ub_serial_stats(const ub_serial_t *serial) { return serial == NULL ? NULL : &serial->stats; }

void ub_serial_close(ub_serial_t *serial) {
    if (serial == NULL || serial->fd < 0) return;
    if (serial->owns_fd) close(serial->fd);
    serial->fd = -1;
}

/**
 * @file ub_serial.h
 * @brief Serial link driver: a tty device opened non-blocking and set to raw
 *        8N1 at a chosen baud rate (termios), e.g. a radio modem ("wireless
 *        serial") or a flight computer's UART.
 *
 * The bytes read are handed to the node with ub_node_rx(); the slot's decoder
 * resynchronises on the frame sync word, so frames survive any read chunking
 * and line noise between them (rejections counted in the decoder's stats, see
 * ub_node_link_bad_frames()).
 *
 * Sending goes through a fixed transmit buffer of UB_SERIAL_TX_BUFFER bytes: a
 * partial write leaves the rest queued for ub_serial_service() (poll for
 * POLLOUT while ub_serial_tx_pending() is non-zero); a frame that does not fit
 * is refused whole with UB_ERR_AGAIN (counted as backpressure by the node and
 * here). Nothing is dropped silently.
 *
 * Tests and simulations use a pseudo-terminal: open the slave side with
 * ub_serial_open() and drive the master side, raw, with ub_serial_adopt().
 */
#ifndef UB_SERIAL_H
#define UB_SERIAL_H

#include <stddef.h>
#include <stdint.h>

#include "ub_error.h"
#include "ub_frame.h"
#include "ub_link.h"

#ifdef __cplusplus
extern "C" {
#endif

#ifndef UB_SERIAL_TX_BUFFER
#define UB_SERIAL_TX_BUFFER (2 * UB_FRAME_MAX)
#endif
/** Bytes per read() call, and read() calls per ub_serial_service() at most. */
#ifndef UB_SERIAL_RX_CHUNK
#define UB_SERIAL_RX_CHUNK 512
#endif
#ifndef UB_SERIAL_RX_BUDGET
#define UB_SERIAL_RX_BUDGET 16
#endif

#if UB_SERIAL_TX_BUFFER < UB_FRAME_MAX
#error "UB_SERIAL_TX_BUFFER must hold at least one whole frame (UB_FRAME_MAX)"
#endif

typedef struct ub_node ub_node_t;

typedef struct ub_serial_stats {
    uint64_t bytes_in;
    uint64_t bytes_out;    /**< bytes the device accepted */
    uint64_t frames_out;   /**< frames accepted into the transmit path */
    uint64_t backpressure; /**< frames refused with UB_ERR_AGAIN: transmit buffer full */
    uint64_t io_errors;    /**< read or write errors */
} ub_serial_stats_t;

/** A serial link. Caller-owned; treat the fields as private. */
typedef struct ub_serial {
    int fd;
    uint8_t owns_fd;
    ub_node_t *node;
    int link_id;
    ub_serial_stats_t stats;
    size_t tx_len;
    uint8_t tx[UB_SERIAL_TX_BUFFER];
    uint8_t rx[UB_SERIAL_RX_CHUNK];
} ub_serial_t;

/** The transport vtable (kind "serial"); `impl` is the ub_serial_t. */
extern const ub_link_ops_t ub_serial_ops;

/**
 * Opens `path` (O_RDWR | O_NOCTTY | O_NONBLOCK) and sets it raw, 8 data bits,
 * no parity, 1 stop bit, no flow control, at `baud` (one of 1200, 2400, 4800,
 * 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600).
 * @return UB_OK; UB_ERR_INVAL (NULL path); UB_ERR_RANGE (baud not supported);
 *         UB_ERR_IO (open or termios failed, errno set; not a tty is ENOTTY).
 */
UB_CHECK int ub_serial_open(ub_serial_t *serial, const char *path, uint32_t baud);

/**
 * Uses an already open descriptor (e.g. a pty master), made non-blocking.
 * With `baud` non-zero it is configured like ub_serial_open(); with 0 its
 * termios settings are left alone. ub_serial_close() does not close an adopted descriptor.
 * @return UB_OK; UB_ERR_INVAL (fd < 0); UB_ERR_RANGE; UB_ERR_IO.
 */
UB_CHECK int ub_serial_adopt(ub_serial_t *serial, int fd, uint32_t baud);

/** Puts this driver behind slot `link_id` of `node`. @return UB_OK or the error of ub_node_link_attach(). */
UB_CHECK int ub_serial_attach(ub_serial_t *serial, ub_node_t *node, int link_id);

/**
 * Flushes the transmit buffer, then reads what is available (at most
 * UB_SERIAL_RX_BUDGET reads) into the node with ub_node_rx().
 * @return frames the node found; UB_ERR_INVAL (not attached to `node`);
 *         UB_ERR_IO (read/write error other than would-block, e.g. the device went away).
 */
UB_CHECK int ub_serial_service(ub_serial_t *serial, ub_node_t *node, uint64_t now_ms);

/** @return the device descriptor, or -1 when closed. */
int ub_serial_fileno(const ub_serial_t *serial);

/** @return bytes waiting in the transmit buffer. */
size_t ub_serial_tx_pending(const ub_serial_t *serial);

/** @return the driver counters. */
const ub_serial_stats_t *ub_serial_stats(const ub_serial_t *serial);

/** Closes the device (not an adopted descriptor). Safe to call twice. */
void ub_serial_close(ub_serial_t *serial);

#ifdef __cplusplus
}
#endif
#endif /* UB_SERIAL_H */

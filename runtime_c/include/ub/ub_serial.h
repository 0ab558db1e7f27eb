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
 * Hang-ups: a device that goes away (a USB adapter pulled, the other end of a
 * pty closed, a modem dropping carrier) is detected by ub_serial_service() --
 * end of file, POLLHUP/POLLERR, or EIO/ENXIO/ENODEV from read or write -- and
 * counted (`hangups`); the descriptor is closed at once (so a poll loop never
 * spins on it), the link is down (ub_serial_state(), sends refused with
 * UB_ERR_CLOSED and counted `send_closed`, queued bytes counted in
 * `tx_discarded`), and a device opened by path is reopened with exponential
 * backoff (UB_SERIAL_RETRY_MIN_MS doubling to UB_SERIAL_RETRY_MAX_MS, driven
 * by the `now_ms` given to ub_serial_service(): call it periodically while
 * down). A reopened device re-attaches the node slot, so no half frame from
 * before the hang-up is glued to the new stream. An adopted descriptor cannot
 * be reopened: it stays down.
 *
 * Tests and simulations use a pseudo-terminal: open the slave side with
 * ub_serial_open() and drive the master side, raw, with ub_serial_adopt().
 */
#ifndef UB_SERIAL_H
#define UB_SERIAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_driver.h"
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

/** Reopen backoff after a hang-up: first wait, and the cap it doubles up to (ms of node time). */
#ifndef UB_SERIAL_RETRY_MIN_MS
#define UB_SERIAL_RETRY_MIN_MS 100u
#endif
#ifndef UB_SERIAL_RETRY_MAX_MS
#define UB_SERIAL_RETRY_MAX_MS 5000u
#endif
/** Longest device path kept for reopening, NUL included. */
#ifndef UB_SERIAL_PATH_MAX
#define UB_SERIAL_PATH_MAX 128
#endif

#if UB_SERIAL_TX_BUFFER < UB_FRAME_MAX
#error "UB_SERIAL_TX_BUFFER must hold at least one whole frame (UB_FRAME_MAX)"
#endif

typedef struct ub_node ub_node_t;

typedef enum ub_serial_state {
    UB_SERIAL_DOWN = 0, /**< no device: hung up (reopening by path with backoff) or closed */
    UB_SERIAL_UP = 1
} ub_serial_state_t;

typedef struct ub_serial_stats {
    uint64_t bytes_in;
    uint64_t bytes_out;    /**< bytes the device accepted */
    uint64_t frames_out;   /**< frames accepted into the transmit path */
    uint64_t backpressure; /**< frames refused with UB_ERR_AGAIN: transmit buffer full */
    uint64_t io_errors;    /**< read or write errors other than a hang-up */
    uint64_t hangups;      /**< the device went away: EOF, POLLHUP/POLLERR, EIO/ENXIO/ENODEV */
    uint64_t reopens;      /**< the device came back (opened again by path) */
    uint64_t reopen_failures; /**< reopen attempts that failed (device still absent) */
    uint64_t send_closed;  /**< frames refused with UB_ERR_CLOSED while down */
    uint64_t tx_discarded; /**< queued bytes thrown away with a hang-up */
    uint64_t foreign_out;  /**< foreign messages written (ub_serial_write_foreign()) */
} ub_serial_stats_t;

/** A serial link. Caller-owned; treat the fields as private. */
typedef struct ub_serial {
    int fd;
    uint8_t owns_fd;
    uint8_t state;         /**< ub_serial_state_t */
    uint8_t hung;          /**< down because the device went away (not closed by the caller) */
    ub_node_t *node;
    int link_id;
    uint32_t baud;         /**< 0: adopted without configuring */
    uint32_t backoff_ms;
    uint64_t next_attempt_ms;
    char path[UB_SERIAL_PATH_MAX]; /**< "" for an adopted descriptor */
    ub_serial_stats_t stats;
    ub_decoder_t *dec;     /**< ub_serial_set_decoder(); NULL: the node slot's */
    ub_decoder_t own_dec;  /**< the decoder ub_serial_set_foreign() reads through */
    const ub_link_ops_t *ops; /**< what the slot is attached with (ub_serial_attach_as()); a reopen re-attaches it */
    void *ops_impl;
    int (*rx_hook)(void *user, const uint8_t *data, size_t len, uint64_t now_ms); /**< ub_serial_set_rx_hook() */
    void *rx_user;
    size_t tx_len;
    uint8_t tx[UB_SERIAL_TX_BUFFER];
    uint8_t rx[UB_SERIAL_RX_CHUNK];
} ub_serial_t;

/** The transport vtable (kind "serial"); `impl` is the ub_serial_t. */
extern const ub_link_ops_t ub_serial_ops;

/** The driver entry (ub_driver.h) ub_ports opens "serial:..." specs with; its instance is a ub_serial_t. */
extern const ub_driver_t ub_serial_driver;

/**
 * Opens `path` (O_RDWR | O_NOCTTY | O_NONBLOCK) and sets it raw, 8 data bits,
 * no parity, 1 stop bit, no flow control, at `baud` (one of 1200, 2400, 4800,
 * 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600). The path is
 * kept to reopen the device after a hang-up.
 * @return UB_OK; UB_ERR_INVAL (NULL path); UB_ERR_RANGE (baud not supported);
 *         UB_ERR_NOSPACE (path longer than UB_SERIAL_PATH_MAX - 1);
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

/** The same with another link vtable and impl in front of the serial link (a driver that frames the stream
 *  itself, ub_legacy_link.h); a reopened device re-attaches these. */
UB_CHECK int ub_serial_attach_as(ub_serial_t *serial, ub_node_t *node, int link_id, const ub_link_ops_t *ops,
                                 void *impl);

/**
 * Flushes the transmit buffer, then reads what is available (at most
 * UB_SERIAL_RX_BUDGET reads) into the node with ub_node_rx(). Detects a
 * hang-up (see the file comment); while down, reopens the device by path when
 * the backoff allows.
 * @return frames the node found (0 while down); UB_ERR_INVAL (not attached to
 *         `node`, or closed); UB_ERR_IO (a read/write error that is neither
 *         would-block nor a hang-up; counted in io_errors).
 */
UB_CHECK int ub_serial_service(ub_serial_t *serial, ub_node_t *node, uint64_t now_ms);

/**
 * Reads the device through `dec` (caller-owned, outliving the serial link) instead of the node slot's
 * decoder: for an adapter that gives the link a foreign-traffic handler (ub_decoder_set_foreign(), a GPS
 * sharing the wire, issue #24). Set it after open (open zeroes the struct). When the device is reopened,
 * `dec` restarts as the slot's would (the bytes it held counted as garbage) and keeps its handler.
 * Frames still go to the node (ub_node_rx_stream()); the decoder's rejections are counted in `dec`, not
 * in the slot's. `dec` NULL: back to the slot's decoder.
 * @return UB_OK, or UB_ERR_INVAL for a NULL `serial`.
 */
UB_CHECK int ub_serial_set_decoder(ub_serial_t *serial, ub_decoder_t *dec);

/**
 * Gives the link a foreign-traffic handler (ub_frame.h): from now on it is read through a decoder of its
 * own (ub_serial_set_decoder() with the struct's `own_dec`) whose handler is `cb`; bytes the slot's decoder
 * still held stay there, so set it right after opening. `cb` NULL removes it (and goes back to the slot's
 * decoder if `own_dec` was in use).
 * @return UB_OK, or UB_ERR_INVAL for a NULL `serial`.
 */
UB_CHECK int ub_serial_set_foreign(ub_serial_t *serial, ub_foreign_cb cb, void *user);

/**
 * Writes bytes that are not a uavbus frame (a device's own protocol: a GPS receiver's configuration
 * message, a legacy datalink message) onto the link through the same transmit buffer as frames, whole or
 * not at all, so they never split a frame; counted in `foreign_out` and `bytes_out`.
 * @return UB_OK; UB_ERR_AGAIN (no room beside what is queued: counted `backpressure`, try later);
 *         UB_ERR_CLOSED (down); UB_ERR_INVAL (NULL, or longer than UB_SERIAL_TX_BUFFER); UB_ERR_IO.
 */
UB_CHECK int ub_serial_write_foreign(ub_serial_t *serial, const uint8_t *data, size_t len, uint64_t now_ms);

/**
 * Hands every byte read to `hook` instead of the node (a link mode that frames the stream itself: the legacy
 * datalink envelope, ub_legacy_link.h); it returns the frames it handed to the node. NULL: back to the node.
 * @return UB_OK, or UB_ERR_INVAL for a NULL `serial`.
 */
UB_CHECK int ub_serial_set_rx_hook(ub_serial_t *serial, int (*hook)(void *user, const uint8_t *data, size_t len,
                                                                    uint64_t now_ms),
                                   void *user);

/** @return the device descriptor, or -1 when closed or down. */
int ub_serial_fileno(const ub_serial_t *serial);

/** @return UB_SERIAL_UP or UB_SERIAL_DOWN. */
ub_serial_state_t ub_serial_state(const ub_serial_t *serial);

/**
 * When a down device opened by path is next tried (node time).
 * @return true and `*due_ms` set while such a retry is pending; false otherwise.
 */
bool ub_serial_next_retry(const ub_serial_t *serial, uint64_t *due_ms);

/** @return bytes waiting in the transmit buffer. */
size_t ub_serial_tx_pending(const ub_serial_t *serial);

/** @return the driver counters. */
const ub_serial_stats_t *ub_serial_stats(const ub_serial_t *serial);

/** Closes the device (not an adopted descriptor) and stops reopening. Safe to call twice. */
void ub_serial_close(ub_serial_t *serial);

#ifdef __cplusplus
}
#endif
#endif /* UB_SERIAL_H */

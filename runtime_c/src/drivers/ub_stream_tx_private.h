/*
 * Private to the stream drivers (ub_tcp.c, ub_serial.c): a fixed-size
 * transmit buffer in front of a non-blocking descriptor. Whole frames go in or
 * nothing does, so a refused frame never leaves half a frame on the wire.
 */
#ifndef UB_STREAM_TX_PRIVATE_H
#define UB_STREAM_TX_PRIVATE_H

#include <errno.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <unistd.h>

#include "ub/ub_error.h"

/* Writes what the descriptor takes, like write(2). Sockets use send(MSG_NOSIGNAL): a dead peer
 * must come back as an error code, not as SIGPIPE. */
typedef long (*ub_stream_write_fn)(int fd, const uint8_t *data, size_t len);

/* Pushes buffered bytes out. @return UB_OK (maybe bytes left), UB_ERR_IO/UB_ERR_CLOSED on a dead descriptor. */
static inline int ub_stream_tx_flush(int fd, ub_stream_write_fn write_fn, uint8_t *buf, size_t *len,
                                     uint64_t *bytes_written) {
    size_t done = 0;
    while (done < *len) {
        long n = write_fn(fd, buf + done, *len - done);
        if (n > 0) {
            done += (size_t)n;
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
        memmove(buf, buf + done, *len - done);
        *len -= done;
        *bytes_written += done;
        return (n < 0 && (errno == EPIPE || errno == ECONNRESET)) ? UB_ERR_CLOSED : UB_ERR_IO;
    }
    memmove(buf, buf + done, *len - done);
    *len -= done;
    *bytes_written += done;
    return UB_OK;
}

/*
 * Sends one whole frame through the buffer: flush first (order), write directly
 * when the buffer is empty, keep the unwritten rest.
 * @return UB_OK; UB_ERR_AGAIN when the frame does not fit beside what is queued
 *         (nothing of it was written); UB_ERR_IO/UB_ERR_CLOSED from the descriptor.
 */
static inline int ub_stream_tx_send(int fd, ub_stream_write_fn write_fn, uint8_t *buf, size_t cap, size_t *len,
                                    const uint8_t *frame, size_t frame_len, uint64_t *bytes_written) {
    int rc = ub_stream_tx_flush(fd, write_fn, buf, len, bytes_written);
    if (rc < 0) return rc;
    if (frame_len > cap - *len) return UB_ERR_AGAIN;
    memcpy(buf + *len, frame, frame_len);
    *len += frame_len;
    return ub_stream_tx_flush(fd, write_fn, buf, len, bytes_written);
}

#endif /* UB_STREAM_TX_PRIVATE_H */

/* cffi cdef for runtime_c/include/ub/ub_serial.h (normally opened through ub_ports). */

typedef struct ub_serial_stats {
    uint64_t bytes_in;
    uint64_t bytes_out;
    uint64_t frames_out;
    uint64_t backpressure;
    uint64_t io_errors;
    ...;
} ub_serial_stats_t;

typedef struct ub_serial { ...; } ub_serial_t;

int ub_serial_open(ub_serial_t *serial, const char *path, uint32_t baud);
int ub_serial_adopt(ub_serial_t *serial, int fd, uint32_t baud);
int ub_serial_attach(ub_serial_t *serial, ub_node_t *node, int link_id);
int ub_serial_service(ub_serial_t *serial, ub_node_t *node, uint64_t now_ms);
int ub_serial_fileno(const ub_serial_t *serial);
size_t ub_serial_tx_pending(const ub_serial_t *serial);
const ub_serial_stats_t *ub_serial_stats(const ub_serial_t *serial);
void ub_serial_close(ub_serial_t *serial);

/* cffi cdef for runtime_c/include/ub/ub_log.h: the binary log writer (Contract 3). Python installs
 * the C tap `ub_log_tap` itself, so recording never runs Python code per frame. */

typedef struct ub_log_stats {
    uint64_t records;
    uint64_t bytes;
    uint64_t write_errors;
    uint64_t skipped_tx;
    int last_errno;
    ...;
} ub_log_stats_t;

typedef struct ub_log { ...; } ub_log_t;

int ub_log_open(ub_log_t *log, int fd, const ub_node_t *node, const char *node_name, bool record_tx,
                uint64_t start_unix_ms, uint64_t start_t_ms);
int ub_log_write(ub_log_t *log, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t t_ms);
void ub_log_tap(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms);
const ub_log_stats_t *ub_log_stats(const ub_log_t *log);
void ub_log_close(ub_log_t *log);

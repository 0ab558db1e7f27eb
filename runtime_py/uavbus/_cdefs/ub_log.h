/* cffi cdef for runtime_c/include/ub/ub_log.h: the binary log writer and the resynchronising reader.
 * Python installs the C tap `ub_log_tap` itself, so recording never runs Python code per frame, and
 * reads logs through the C reader, so both languages skip and count damage the same way. */

#define UB_LOG_FORMAT ...
#define UB_LOG_FILE_HEADER_LEN ...
#define UB_LOG_RECORD_HEADER_LEN ...
#define UB_LOG_V1_RECORD_HEADER_LEN ...
#define UB_LOG_HEADER_COPIES ...
#define UB_LOG_COPY_PRIMARY ...
#define UB_LOG_COPY_SPARE ...

typedef struct ub_log_rotation {
    uint64_t max_bytes;
    uint64_t max_ms;
    uint32_t max_files;
} ub_log_rotation_t;

typedef struct ub_log_stats {
    uint64_t records;
    uint64_t bytes;
    uint64_t write_errors;
    uint64_t skipped_tx;
    int last_errno;
    uint64_t torn_writes;
    uint64_t torn_bytes;
    uint64_t recoveries;
    uint64_t files;
    uint64_t files_deleted;
    uint64_t open_errors;
    uint64_t limit_rotations;
    uint64_t delete_errors;
    ...;
} ub_log_stats_t;

typedef struct ub_log { ...; } ub_log_t;

int ub_log_open(ub_log_t *log, int fd, const ub_node_t *node, const char *node_name, bool record_tx,
                uint64_t start_unix_ms, uint64_t start_t_ms);
int ub_log_open_path(ub_log_t *log, const char *path, const ub_log_rotation_t *rot, const ub_node_t *node,
                     const char *node_name, bool record_tx, uint64_t start_unix_ms, uint64_t start_t_ms);
int ub_log_file_name(const char *path, uint32_t index, char *out, size_t cap);
int ub_log_rotation_floor(const ub_node_t *node, const char *node_name, uint64_t *out);
int ub_log_write(ub_log_t *log, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t t_ms);
void ub_log_tap(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms);
const ub_log_stats_t *ub_log_stats(const ub_log_t *log);
uint32_t ub_log_file_index(const ub_log_t *log);
void ub_log_close(ub_log_t *log);

typedef struct ub_log_header {
    const char *meta;
    uint32_t meta_len;
    const char *catalogue;
    uint32_t catalogue_len;
    uint8_t version;
    size_t size;
    uint8_t damaged;
    ...;
} ub_log_header_t;

typedef struct ub_log_record {
    uint64_t t_ms;
    uint8_t link_id;
    uint8_t dir;
    const uint8_t *frame;
    uint16_t len;
    uint32_t seq;
    size_t offset;
    ...;
} ub_log_record_t;

typedef struct ub_log_reader_stats {
    uint64_t records;
    uint64_t record_bytes;
    uint64_t skipped_bytes;
    uint64_t damaged_records;
    uint64_t resyncs;
    uint64_t truncated_bytes;
    uint64_t missing_records;
    uint64_t seq_restarts;
    ...;
} ub_log_reader_stats_t;

typedef struct ub_log_reader { ...; } ub_log_reader_t;

int ub_log_header_parse(const uint8_t *buf, size_t len, ub_log_header_t *hdr);
int ub_log_header_repair(uint8_t *buf, size_t len);
void ub_log_reader_begin(ub_log_reader_t *rd, uint8_t version);
void ub_log_reader_data(ub_log_reader_t *rd, const uint8_t *buf, size_t len, bool final);
int ub_log_reader_next(ub_log_reader_t *rd, ub_log_record_t *rec);
size_t ub_log_reader_consumed(const ub_log_reader_t *rd);
void ub_log_reader_expect_seq(ub_log_reader_t *rd, uint32_t seq);
const ub_log_reader_stats_t *ub_log_reader_stats(const ub_log_reader_t *rd);

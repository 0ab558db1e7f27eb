/* cffi cdef for runtime_c/include/ub/ub_memlink.h: the in-process link (tests, TUI test). */

typedef struct ub_memlink_faults {
    uint32_t loss_ppm;
    uint32_t duplicate_ppm;
    uint32_t reorder_ppm;
    uint32_t corrupt_ppm;
    uint32_t delay_ms;
    uint32_t jitter_ms;
    uint32_t reorder_delay_ms;
    ...;
} ub_memlink_faults_t;

typedef struct ub_memlink_stats {
    uint64_t sent;
    uint64_t delivered;
    uint64_t lost;
    uint64_t duplicated;
    uint64_t reordered;
    uint64_t corrupted;
    uint64_t overflow;
    uint64_t rejected;
    ...;
} ub_memlink_stats_t;

typedef struct ub_memlink { ...; } ub_memlink_t;

void ub_memlink_init(ub_memlink_t *ml, const ub_memlink_faults_t *faults, uint64_t seed);
void ub_memlink_set_faults(ub_memlink_t *ml, const ub_memlink_faults_t *faults);
int ub_memlink_connect(ub_memlink_t *ml, ub_node_t *a, int link_a, ub_node_t *b, int link_b);
void ub_memlink_disconnect(ub_memlink_t *ml);
size_t ub_memlink_pump(ub_memlink_t *ml, uint64_t now_ms);
size_t ub_memlink_pending(const ub_memlink_t *ml);
const ub_memlink_stats_t *ub_memlink_stats(const ub_memlink_t *ml, int side);

/* cffi cdef for runtime_c/include/ub/ub_impair.h: seeded frame-level impairment (Contract 4). */

#define UB_IMPAIR_PPM_MAX ...

typedef struct ub_impair_params {
    uint32_t loss_ppm;
    uint32_t dup_ppm;
    uint32_t reorder_ppm;
    uint32_t delay_ms;
    uint32_t jitter_ms;
    uint32_t reorder_hold_ms;
    uint32_t rate_Bps;
    uint32_t mtu;
    uint32_t prio;
    ...;
} ub_impair_params_t;

typedef struct ub_impair_stats {
    uint64_t offered;
    uint64_t lost;
    uint64_t duplicated;
    uint64_t reordered;
    uint64_t delayed;
    uint64_t queue_full;
    uint64_t passed;
    uint64_t inner_again;
    uint64_t inner_errors;
    uint64_t too_big;
    uint64_t rate_waits;
    uint64_t bytes;
    uint64_t shed;
    uint64_t overtaken;
    ...;
} ub_impair_stats_t;

typedef struct ub_impair { ...; } ub_impair_t;

const ub_impair_stats_t *ub_impair_stats(const ub_impair_t *imp);
size_t ub_impair_pending(const ub_impair_t *imp);
int ub_impair_parse(const char *text, ub_impair_params_t *params, uint64_t *seed, char *err, size_t err_cap);

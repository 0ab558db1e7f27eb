/* cffi cdef for runtime_c/include/ub/ub_sec.h: keyring, protect/verify, counters, replay windows.
 * The typedefs ub_sec_t / ub_sec_options_t come from _cdefs/ub_node.h and ub_nodecfg.h (name order). */

#define UB_SEC_KEY_LEN ...
#define UB_SEC_NONCE_LEN ...
#define UB_SEC_SIGNING_HEADER_LEN ...
#define UB_SEC_DEFAULT_RESERVE_BLOCK ...

typedef int (*ub_sec_reserve_fn)(void *user, uint64_t mark);

struct ub_sec_options {
    ub_random_fn random;
    void *random_user;
    ub_sec_reserve_fn reserve;
    void *reserve_user;
    uint64_t reserve_block;
    uint32_t challenge_retry_ms;
    uint32_t reply_min_ms;
    uint32_t max_counter_rate;
    uint32_t replay_streak;
    uint32_t rechallenge_min_ms;
    ...;
};

typedef struct ub_sec_stats {
    uint64_t signed_out;
    uint64_t encrypted_out;
    uint64_t verified_in;
    uint64_t decrypted_in;
    uint64_t auth_failures;
    uint64_t unknown_keys;
    uint64_t challenges_sent;
    uint64_t challenges_completed;
    uint64_t replies_sent;
    uint64_t replies_suppressed;
    uint64_t reservations;
    uint64_t reserve_failures;
    uint64_t tx_refused;
    uint64_t rechallenges;
    uint64_t window_resets;
    ...;
} ub_sec_stats_t;

/* Private fields stay hidden: Python uses the functions. */
struct ub_sec {
    uint64_t counter;
    ...;
};

bool ub_sec_available(void);
int ub_sec_init(ub_sec_t *sec, const ub_sec_options_t *opt);
int ub_sec_add_key(ub_sec_t *sec, uint8_t id, const uint8_t key[]);
int ub_sec_remove_key(ub_sec_t *sec, uint8_t id);
int ub_sec_set_tx_key(ub_sec_t *sec, uint8_t id);
uint8_t ub_sec_tx_key(const ub_sec_t *sec);
bool ub_sec_has_key(const ub_sec_t *sec, uint8_t id);
size_t ub_sec_key_ids(const ub_sec_t *sec, uint8_t *ids, size_t cap);
uint64_t ub_sec_wall_counter(uint64_t unix_us);
int ub_sec_start(ub_sec_t *sec, uint64_t persisted_mark, uint64_t wall_counter);
int ub_sec_next_counter(ub_sec_t *sec, uint64_t *counter);
int ub_sec_protect(ub_sec_t *sec, const ub_frame_header_t *h, const uint8_t *payload, uint8_t *frame, size_t cap);
int ub_sec_verify(ub_sec_t *sec, const ub_frame_header_t *h, const uint8_t *frame, size_t len, uint8_t *plain,
                  size_t plain_cap);
int ub_sec_keygen(uint8_t key[]);
void ub_sec_signing_header(const ub_frame_header_t *h, uint8_t out[]);
const ub_sec_stats_t *ub_sec_stats(const ub_sec_t *sec);

/**
 * @file ub_policy.h
 * @brief Who may administer, read and write, and how much one requester may
 *        ask for: the authorization of the administration plane (issue #11
 *        items 5 and 6; docs/pubsub.md, "Authorization and limits").
 *
 * A policy is a caller-owned value (capacities in ub_config.h, no allocation)
 * attached to a node with ub_node_set_policy(); the node reads it and never
 * changes it, so one policy may serve several nodes. A node without a policy
 * behaves exactly as before (the paper's closed lab: every entity has the
 * "exclusive rights"). With a policy, frames received on links are judged by
 * their source entity (verified by the frame security layer where it is on):
 *
 *  - **Administrators** hold the paper's exclusive rights (III.B): only they
 *    may send SUB_REQUEST / SUB_STOP, PUB_REQUEST / PUB_STOP whose data goes
 *    to anyone but the requester itself, and change or stop rows they do not
 *    own. Anyone else: NACK NOT_AUTHORIZED, counted `not_authorized`.
 *  - **Read rules** (target entity, requester, content): once any read rule is
 *    given (or ub_policy_restrict_reads()), a non-administrator's PUB_REQUEST
 *    needs a matching rule, else NACK NOT_AUTHORIZED. Without, anyone may ask
 *    for data sent to itself.
 *  - **Write rules** (target entity, source, content): DATA received for a
 *    local entity is stored only if the entity subscribed to it from that
 *    source, its own administration table set it up to arrive there, or a
 *    write rule names it; else it is dropped `not_allowed` before storage is
 *    touched.
 *  - **Limits** bound what one requester can make a node send: every
 *    non-administrator has `limits`, every administrator `admin_limits` (its
 *    own, higher defaults; never none: a request set of an administrator's
 *    name, which any group-key holder can forge, cannot make a vehicle flood
 *    its radio, issue #23 item 5).
 *  - **Exclusive administrator** (optional, ub_policy_set_exclusive(); config
 *    "exclusive_admin": true): the paper's "only one entity interfaces with
 *    the global table" per node. While one administrator keeps a live row in
 *    this node's tables, requests from any other administrator are answered
 *    NACK OTHER_ADMIN; once its rows are stopped or their leases lapsed, the
 *    next administrator may take over. Without it, two administrators are told
 *    apart per row only (docs/pubsub.md, "Two administrators").
 *
 * Frames that entities of the same node send each other are not judged: they
 * share one process and its storage.
 *
 * Patterns (targets, requesters/sources, contents) are names with `*`
 * standing for any run of characters: "gcs1", "gcs*", "*", "gcsMission*",
 * "batteryCell[0]*". Entity patterns match entity names (the ID without its
 * NUL padding), content patterns the catalogue's instance names.
 */
#ifndef UB_POLICY_H
#define UB_POLICY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_catalogue.h"
#include "ub_config.h"
#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Longest entity pattern (an entity name is at most UB_ENTITY_ID_LEN characters; `*` adds a few). */
#define UB_POLICY_ENTITY_PATTERN_MAX 15

/* Limits used when a policy gives none (0 in a ub_policy_limits_t field). */
#define UB_POLICY_DEFAULT_MIN_PERIOD_MS 10u     /**< 100 Hz */
#define UB_POLICY_DEFAULT_MAX_ROWS 8u           /**< per requester, all hosted entities' tables together */
#define UB_POLICY_DEFAULT_MAX_BYTES_PER_S 32768u /**< about three 50 Hz streams of 100-byte directories */
#define UB_POLICY_DEFAULT_MAX_LEASE_MS 10000u   /**< 10 renewals at the default renew_ms */
/* Administrators' limits when a policy gives none: higher, never unbounded (an administrator's table renews
 * every renew_ms = 1000 with lease 3000, well inside the lease bound). */
#define UB_POLICY_DEFAULT_ADMIN_MIN_PERIOD_MS 5u        /**< 200 Hz */
#define UB_POLICY_DEFAULT_ADMIN_MAX_ROWS 32u            /**< per administrator, all hosted entities' tables together */
#define UB_POLICY_DEFAULT_ADMIN_MAX_BYTES_PER_S 131072u /**< 128 KiB/s of whole frames */
#define UB_POLICY_DEFAULT_ADMIN_MAX_LEASE_MS 60000u     /**< lease 0 ("no lease") is granted as this */
/** Smallest max_lease_ms accepted: below the default renewal period every lease would lapse. */
#define UB_POLICY_MIN_LEASE_MS 1000u

/** Which rule list: who may ask for data (read) or write into storage (write). */
typedef enum ub_policy_dir { UB_POLICY_READ = 0, UB_POLICY_WRITE = 1 } ub_policy_dir_t;

/** Bounds on what one requester (a non-administrator, or an administrator) may make this node do. */
typedef struct ub_policy_limits {
    uint32_t min_period_ms;   /**< shorter periods are refused (NACK LIMIT) */
    uint32_t max_rows;        /**< rows one requester may own in this node's tables, all local entities together */
    uint32_t max_bytes_per_s; /**< sum of ub_policy_row_bytes_per_s() over the requester's rows */
    uint32_t max_lease_ms;    /**< longer leases, and lease 0 ("no lease"), are granted as this */
} ub_policy_limits_t;

/** One read or write rule; config lists ("from": [a, b]) become one rule per combination. */
typedef struct ub_policy_rule {
    uint8_t dir;                                    /**< ub_policy_dir_t */
    char target[UB_POLICY_ENTITY_PATTERN_MAX + 1];  /**< the entity read from / written to */
    char from[UB_POLICY_ENTITY_PATTERN_MAX + 1];    /**< the requester (read) or the data's source (write) */
    char content[UB_POLICY_PATTERN_MAX + 1];        /**< catalogue instance name pattern */
    uint32_t line;                                  /**< config line it came from (0 = added through the API) */
} ub_policy_rule_t;

/**
 * The certified roles of entity `id` (identity per entity, ub_ident.h): UB_OK with `*roles` set (UB_ROLE_*
 * bits), or a negative code when it has no valid identity (unknown, revoked, expired: no role). Typically
 * ub_ident_peer_roles() on the node's identity store at the caller's wall clock.
 */
typedef int (*ub_policy_roles_fn)(void *user, const uint8_t id[UB_ENTITY_ID_LEN], uint16_t *roles);

/** A policy. Caller-owned; fill it with the functions below (or from a config, ub_nodecfg.h). */
typedef struct ub_policy {
    uint8_t n_admins;
    uint8_t admins[UB_POLICY_MAX_ADMINS][UB_ENTITY_ID_LEN];
    uint8_t read_restricted; /**< PUB_REQUESTs of non-administrators need a read rule */
    uint8_t exclusive_admin; /**< one administrator at a time per node (ub_policy_set_exclusive()) */
    uint16_t n_rules;
    ub_policy_rule_t rules[UB_POLICY_MAX_RULES];
    ub_policy_limits_t limits;       /**< every non-administrator's; defaults filled in */
    ub_policy_limits_t admin_limits; /**< every administrator's; defaults (UB_POLICY_DEFAULT_ADMIN_*) filled in */
    ub_policy_roles_fn roles;  /**< NULL: administrators by name (group-key mode); see ub_policy_use_roles() */
    void *roles_user;
} ub_policy_t;

/**
 * An empty policy: no administrators, reads unrestricted, writes limited to
 * the defaults (subscribed / set up by the entity's own administration
 * table), default limits.
 */
void ub_policy_init(ub_policy_t *pol);

/** Adds an administrator. @return UB_OK; UB_ERR_EXISTS; UB_ERR_FULL (UB_POLICY_MAX_ADMINS); UB_ERR_INVAL. */
UB_CHECK int ub_policy_add_admin(ub_policy_t *pol, const uint8_t id[UB_ENTITY_ID_LEN]);

/**
 * Adds a rule: `from` may read `content` from `target` (UB_POLICY_READ), or
 * write `content` into `target`'s storage (UB_POLICY_WRITE). A read rule
 * restricts reads (ub_policy_restrict_reads()).
 * @return UB_OK; UB_ERR_FULL (UB_POLICY_MAX_RULES); UB_ERR_INVAL (a NULL or
 *         empty pattern, too long, or a character outside ub_policy_pattern_ok()).
 */
UB_CHECK int ub_policy_add_rule(ub_policy_t *pol, ub_policy_dir_t dir, const char *target, const char *from,
                                const char *content);

/** From now on a non-administrator's PUB_REQUEST needs a matching read rule (none given = nobody). */
void ub_policy_restrict_reads(ub_policy_t *pol);

/** One administrator at a time per node (see the file comment), or with `on` false any number (the default). */
void ub_policy_set_exclusive(ub_policy_t *pol, bool on);

/** Sets the limits; 0 in a field = its default. @return UB_OK, or UB_ERR_RANGE (max_lease_ms below UB_POLICY_MIN_LEASE_MS). */
UB_CHECK int ub_policy_set_limits(ub_policy_t *pol, const ub_policy_limits_t *limits);

/**
 * Sets the administrators' limits; 0 in a field = its UB_POLICY_DEFAULT_ADMIN_* default (never "unbounded").
 * @return UB_OK, or UB_ERR_RANGE (max_lease_ms below UB_POLICY_MIN_LEASE_MS).
 */
UB_CHECK int ub_policy_set_admin_limits(ub_policy_t *pol, const ub_policy_limits_t *limits);

/** @return the limits that apply to an administrator (`admin`) or to anyone else. */
const ub_policy_limits_t *ub_policy_limits_for(const ub_policy_t *pol, bool admin);

/**
 * Administrators by certified role (issue 23 item 3): with `roles` set, an entity is an administrator only
 * if its valid, unrevoked certificate carries UB_ROLE_ADMIN, and, when the policy also lists
 * administrators by name, it is listed too (the list narrows, never widens). NULL restores the
 * group-key mode: administrators by name only. The frame's source ID must be the verified originator for
 * this to mean anything (origin authentication, ub_origin.h); with only a group key, any key holder can
 * claim an administrator's name.
 */
void ub_policy_use_roles(ub_policy_t *pol, ub_policy_roles_fn roles, void *user);

/** @return whether `id` is an administrator (by certified role when ub_policy_use_roles() set a source). */
bool ub_policy_is_admin(const ub_policy_t *pol, const uint8_t id[UB_ENTITY_ID_LEN]);

/**
 * @return whether a rule of `dir` names (target, from, content). Only the
 *         rules: the defaults (unrestricted reads, subscribed writes) are the
 *         node's to apply.
 */
bool ub_policy_rule_matches(const ub_policy_t *pol, ub_policy_dir_t dir, const uint8_t target[UB_ENTITY_ID_LEN],
                            const uint8_t from[UB_ENTITY_ID_LEN], const char *content);

/**
 * What one row costs on the wire, in bytes per second, rounded up: a whole
 * frame (header + packed directory) every period. The byte budget counts
 * frames, not payloads: a 4-byte directory every 10 ms costs 6.8 kB/s of
 * link, not 400 B/s.
 */
uint64_t ub_policy_row_bytes_per_s(uint32_t packed_size, uint32_t period_ms);

/** @return whether `text[0, len)` matches `pattern` (`*` = any run of characters, possibly empty). */
bool ub_policy_match(const char *pattern, const char *text, size_t len);

/**
 * @return whether `pattern` is a valid pattern of at most `max` characters:
 *         1 or more of A-Z a-z 0-9 _ . - [ ] and `*`.
 */
bool ub_policy_pattern_ok(const char *pattern, size_t max);

#ifdef __cplusplus
}
#endif
#endif /* UB_POLICY_H */

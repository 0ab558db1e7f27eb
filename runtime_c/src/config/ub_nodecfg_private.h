/*
 * Internal contract between the config loader (ub_nodecfg.c) and the parsers of
 * its sections that live with their own concern: ub_policy.c reads the
 * "security" keys administrators, read, write and limits. A section parser
 * reports where and what went wrong; the loader adds the file name, so every
 * message reads "<file>:<line>: [entity '<e>', ]field '<path>': <message>".
 * Not installed; symbols are prefixed ub_priv_.
 */
#ifndef UB_NODECFG_PRIVATE_H
#define UB_NODECFG_PRIVATE_H

#include <stdint.h>

#include "ub/ub_nodecfg.h"
#include "ub/ub_policy.h"
#include "codec/ub_json.h"

typedef struct ub_cfg_error {
    uint32_t line;
    char entity[UB_ENTITY_ID_LEN + 1]; /* "" when no entity applies */
    char field[96];
    char message[160];
} ub_cfg_error_t;

/* The "security" keys parsed by ub_policy.c, in the order the loader lists them in messages. */
#define UB_PRIV_POLICY_KEYS "administrators", "read", "write", "limits", "exclusive_admin", "admin_limits"

/*
 * Parses security member `key` (one of UB_PRIV_POLICY_KEYS) into `pol`, which
 * the caller initialised with ub_policy_init(). Entity names are checked
 * against cfg->entities (already parsed).
 * Returns UB_OK; UB_ERR_NOTFOUND when `key` is not a policy key; UB_ERR_CONFIG
 * with `err` filled.
 */
int ub_priv_policy_parse_key(ub_policy_t *pol, const ub_nodecfg_t *cfg, const ub_json_doc_t *doc, const char *key,
                             const ub_json_value_t *value, ub_cfg_error_t *err);

#endif /* UB_NODECFG_PRIVATE_H */

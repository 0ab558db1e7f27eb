#include "ub/ub_link.h"

#include <string.h>

static const char *const drop_reason_names[UB_DROP_REASON_COUNT] = {
    [UB_DROP_NO_ROUTE] = "no_route",
    [UB_DROP_HOP_LIMIT] = "hop_limit",
    [UB_DROP_DUPLICATE] = "duplicate",
    [UB_DROP_LAYOUT_MISMATCH] = "layout_mismatch",
    [UB_DROP_UNKNOWN_CONTENT] = "unknown_content",
    [UB_DROP_UNBOUND] = "unbound",
    [UB_DROP_BAD_PAYLOAD] = "bad_payload",
    [UB_DROP_TX_ERROR] = "tx_error",
    [UB_DROP_BACKPRESSURE] = "backpressure",
    [UB_DROP_DETACHED] = "detached",
    [UB_DROP_NOT_ALLOWED] = "not_allowed",
    [UB_DROP_NOT_AUTHORIZED] = "not_authorized",
    [UB_DROP_ROUTING_OFF] = "routing_off",
    [UB_DROP_UNSIGNED] = "unsigned",
    [UB_DROP_BAD_TAG] = "bad_tag",
    [UB_DROP_UNKNOWN_KEY] = "unknown_key",
    [UB_DROP_REPLAY] = "replay",
    [UB_DROP_UNVERIFIED] = "unverified",
    [UB_DROP_TOO_BIG] = "too_big",
    [UB_DROP_INCOMPLETE] = "incomplete",
    [UB_DROP_COUNTER_JUMP] = "counter_jump",
    [UB_DROP_BAD_ORIGIN] = "bad_origin",
    [UB_DROP_NO_ORIGIN] = "no_origin",
    [UB_DROP_NO_IDENTITY] = "no_identity",
    [UB_DROP_SHED] = "shed",
};

const char *ub_drop_reason_name(ub_drop_reason_t reason) {
    if ((unsigned)reason >= UB_DROP_REASON_COUNT) return "?";
    return drop_reason_names[reason];
}

int ub_link_mask_parse(const char *text, uint8_t *mask) {
    if (text == NULL || mask == NULL) return UB_ERR_INVAL;
    if (text[0] != '0' || (text[1] != 'x' && text[1] != 'X')) return UB_ERR_INVAL;
    const char *digits = text + 2;
    size_t n = strlen(digits);
    /* 1..16 digits, as the config format documents; Figure 8 itself prints nine. */
    if (n == 0 || n > 16) return UB_ERR_INVAL;
    unsigned value = 0;
    /* The rightmost digit is link[0]; every digit is a yes/no for one link. */
    for (size_t pos = 0; pos < n; pos++) {
        char c = digits[n - 1 - pos];
        if (c == '0') continue;
        if (c != '1') return UB_ERR_INVAL;
        if (pos >= UB_MAX_LINKS_PER_ENTITY) return UB_ERR_RANGE;
        value |= 1u << pos;
    }
    *mask = (uint8_t)value;
    return UB_OK;
}

void ub_link_mask_format(uint8_t mask, char out[11]) {
    out[0] = '0';
    out[1] = 'x';
    for (unsigned link = 0; link < 8; link++) out[9 - link] = ((unsigned)mask >> link) & 1u ? '1' : '0';
    out[10] = '\0';
}

int ub_link_fileno(const ub_link_t *link) {
    if (link == NULL || link->ops == NULL || link->ops->fileno == NULL) return -1;
    return link->ops->fileno(link->impl);
}

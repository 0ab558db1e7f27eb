#include "ub/ub_catalogue.h"

#include <string.h>

#include "ub/ub_config.h"

uint32_t ub_catalogue_payload_limit(void) { return (uint32_t)UB_MAX_DIRECTORY; }

const ub_type_desc_t *ub_catalogue_oversize(const ub_catalogue_t *cat, uint32_t limit) {
    if (cat == NULL) return NULL;
    for (size_t i = 0; i < cat->n_types; i++)
        if (cat->types[i].packed_size > limit) return &cat->types[i];
    return NULL;
}

int ub_catalogue_find(const ub_catalogue_t *cat, const uint8_t id[UB_DIR_ID_LEN]) {
    size_t lo = 0, hi = cat->n_instances;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        int c = memcmp(cat->instances[mid].id, id, UB_DIR_ID_LEN);
        if (c == 0) return (int)mid;
        if (c < 0) lo = mid + 1;
        else hi = mid;
    }
    return UB_ERR_NOTFOUND;
}

int ub_catalogue_find_name(const ub_catalogue_t *cat, const char *name) {
    for (size_t i = 0; i < cat->n_instances; i++) {
        if (strcmp(cat->instances[i].name, name) == 0) return (int)i;
    }
    return UB_ERR_NOTFOUND;
}

/* Copies up to 8 characters into an 8-byte half, padding the rest with 0x00. */
static void fill_half(uint8_t half[8], const char *src, size_t n) {
    memset(half, 0, 8);
    memcpy(half, src, n < 8 ? n : 8);
}

void ub_dir_id_paper(const char *name, uint8_t out[UB_DIR_ID_LEN]) {
    size_t n = strlen(name);
    fill_half(out, name, n);
    if (n <= 8) fill_half(out + 8, name, n);
    else fill_half(out + 8, name + n - 8, 8);
}

int ub_entity_id(const char *name, uint8_t out[UB_ENTITY_ID_LEN]) {
    size_t n = strlen(name);
    if (n == 0 || n > UB_ENTITY_ID_LEN) return UB_ERR_RANGE;
    memset(out, 0, UB_ENTITY_ID_LEN);
    memcpy(out, name, n);
    return UB_OK;
}

/*
 * Contracts of the service registry, the driver helpers, the revocation service and the impairment
 * wrapper, called the wrong way on purpose (issue #29 item 6): every refusal returns the documented code
 * and registers nothing. The scenario tests cover the working paths.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_driver.h"
#include "ub/ub_ident.h"
#include "ub/ub_impair.h"
#include "ub/ub_member.h"
#include "ub/ub_node.h"
#include "ub/ub_revoke.h"
#include "ub/ub_service.h"

static const ub_type_desc_t k_types[] = {{"struct eight", 0x0BADCAFEu, 8, 8, NULL, NULL}};
static const ub_instance_desc_t k_insts[] = {{{'a', 'l', 'p', 'h', 'a'}, "alpha", &k_types[0]}};
static const ub_catalogue_t k_cat = {.name = "contracts", .abi_version = UB_CATALOGUE_ABI_VERSION, .types = k_types, .n_types = 1, .instances = k_insts,
                                     .n_instances = 1, .max_packed_size = 8};
static ub_node_t g_node;
static ub_ident_store_t g_store;
static ub_revoke_t g_rv;
static ub_impair_t g_imp;

static int sink_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)impl, (void)frame, (void)now_ms;
    return (int)len;
}
static const ub_link_ops_t k_sink = {.kind = "sink", .send = sink_send};
static const ub_link_ops_t k_no_send = {.kind = "nosend"};

static bool on_frame(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx, const ub_frame_header_t *h,
                     const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop) {
    (void)svc, (void)node, (void)rx, (void)h, (void)payload, (void)now_ms, (void)drop;
    return true;
}
static bool may_write(const ub_service_t *svc, const ub_node_t *node, int slot, uint32_t instance,
                      const uint8_t src_id[UB_ENTITY_ID_LEN]) {
    (void)svc, (void)node, (void)slot, (void)instance, (void)src_id;
    return true;
}
static int seal(const ub_service_t *svc, ub_node_t *node, int slot, ub_frame_header_t *h, const uint8_t *payload,
                uint64_t now_ms, ub_drop_reason_t *drop) {
    (void)svc, (void)node, (void)slot, (void)h, (void)payload, (void)now_ms, (void)drop;
    return 0;
}

static void test_service_registry_refusals(void **state) {
    (void)state;
    assert_int_equal(ub_node_init(&g_node, &k_cat, NULL), UB_OK);
    static const uint8_t dup[2] = {200, 200}, one[1] = {201};
    ub_service_t s = {.name = "dup", .codes = dup, .n_codes = 2, .order = UB_SVC_ORDER_USER, .on_frame = on_frame};
    assert_int_equal(ub_node_add_service(NULL, &s), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_service(&g_node, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_service(&g_node, &s), UB_ERR_INVAL); /* a code twice */
    ub_service_t nocodes = {.name = "nocodes", .n_codes = 1, .on_frame = on_frame};
    assert_int_equal(ub_node_add_service(&g_node, &nocodes), UB_ERR_INVAL);
    ub_service_t noreply = {.name = "noreply", .reply_codes = one, .n_reply_codes = 1};
    assert_int_equal(ub_node_add_service(&g_node, &noreply), UB_ERR_INVAL); /* reply codes, no on_reply */
    ub_service_t nolocal = {.name = "nolocal", .n_link_local_codes = 1};
    assert_int_equal(ub_node_add_service(&g_node, &nolocal), UB_ERR_INVAL);
    ub_service_t half = {.name = "half", .on_data = NULL, .may_write = may_write};
    /* the standard publish/subscribe service holds the DATA observers already */
    assert_int_equal(ub_node_add_service(&g_node, &half), UB_ERR_EXISTS);
    ub_service_t sealer = {.name = "sealer", .seal = seal}, sealer2 = {.name = "sealer2", .seal = seal};
    assert_int_equal(ub_node_add_service(&g_node, &sealer), UB_OK);
    assert_int_equal(ub_node_add_service(&g_node, &sealer2), UB_ERR_EXISTS); /* one sealing service */
    assert_int_equal(ub_node_remove_service(&g_node, &sealer), UB_OK);
    assert_int_equal(ub_node_add_service(&g_node, &sealer2), UB_OK);
    assert_int_equal(ub_node_remove_service(&g_node, &sealer2), UB_OK);
    assert_int_equal(ub_node_remove_service(&g_node, &sealer2), UB_ERR_NOTFOUND);
    assert_int_equal(ub_node_remove_service(NULL, &sealer2), UB_ERR_INVAL);
    assert_int_equal(ub_node_remove_service(&g_node, NULL), UB_ERR_INVAL);
    assert_null(ub_node_service_for(NULL, UB_SVC_CODE, 200));
    assert_null(ub_node_service_for(&g_node, (ub_service_kind_t)7, 200));
    assert_null(ub_node_service_for(&g_node, UB_SVC_CODE, 200)); /* nothing registered for it */
}

static void test_driver_helpers(void **state) {
    (void)state;
    assert_int_equal(ub_node_init(&g_node, &k_cat, NULL), UB_OK);
    uint8_t id[UB_ENTITY_ID_LEN] = "me";
    int e = ub_node_add_entity(&g_node, id, true);
    assert_true(e >= 0);
    int l = ub_node_add_link(&g_node, e, 0, "l0");
    assert_true(l >= 0);
    ub_node_t *node_out = NULL;
    int link_out = -1, impl = 1;
    assert_int_equal(ub_driver_attach(&g_node, l, &k_sink, NULL, &node_out, &link_out), UB_ERR_INVAL);
    assert_int_equal(ub_driver_attach(&g_node, l, &k_sink, &impl, NULL, &link_out), UB_ERR_INVAL);
    assert_int_equal(ub_driver_attach(&g_node, l, &k_sink, &impl, &node_out, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_driver_attach(&g_node, l, &k_sink, &impl, &node_out, &link_out), UB_OK);
    assert_ptr_equal(node_out, &g_node);
    assert_int_equal(link_out, l);
    assert_int_equal(ub_driver_reattach(NULL, l, &k_sink, &impl), UB_ERR_INVAL);
    assert_int_equal(ub_driver_reattach(&g_node, l, &k_sink, &impl), UB_OK);
    ub_driver_counter_t c[2] = {{"rx", 3}, {"tx", 4}};
    char out[64];
    assert_int_equal(ub_driver_format_counters(c, 2, NULL, sizeof out), 0);
    assert_int_equal(ub_driver_format_counters(c, 2, out, 0), 0);
    assert_true(ub_driver_format_counters(c, 2, out, sizeof out) > 0);
    assert_non_null(strstr(out, "rx"));
    assert_non_null(strstr(out, "4"));
}

static void test_revoke_and_impair_contracts(void **state) {
    (void)state;
    assert_int_equal(ub_node_init(&g_node, &k_cat, NULL), UB_OK);
    ub_ident_store_init(&g_store);
    assert_int_equal(ub_revoke_init(NULL, &g_node, &g_store, NULL, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_revoke_init(&g_rv, NULL, &g_store, NULL, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_revoke_init(&g_rv, &g_node, NULL, NULL, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_revoke_remove(NULL), UB_ERR_INVAL);
    uint8_t rec[UB_REVOCATION_LEN] = {0};
    assert_int_equal(ub_revoke_submit(NULL, rec, sizeof rec, 0), UB_ERR_INVAL);
    assert_int_equal(ub_revoke_submit(&g_rv, NULL, sizeof rec, 0), UB_ERR_INVAL);
    assert_null(ub_revoke_stats(NULL));
    assert_int_equal(ub_revoke_spread_certificates(NULL, NULL, NULL, 0), UB_ERR_INVAL);
    assert_int_equal(ub_revoke_init(&g_rv, &g_node, &g_store, NULL, NULL, NULL), UB_OK);
    assert_non_null(ub_revoke_stats(&g_rv));
    uint8_t cert[UB_CERT_LEN] = {0};
    assert_int_equal(ub_revoke_submit_certificate(NULL, cert, sizeof cert, 0), UB_ERR_INVAL);
    assert_int_equal(ub_revoke_submit_certificate(&g_rv, NULL, sizeof cert, 0), UB_ERR_INVAL);
    assert_int_equal(ub_revoke_remove(&g_rv), UB_OK);
    static ub_revoke_t never; /* never initialised: nothing to remove */
    assert_int_equal(ub_revoke_remove(&never), UB_ERR_INVAL);
    /* Options given are kept (0 means the default). */
    ub_revoke_options_t opt = {.min_interval_ms = 7, .repeat_ms = 11, .repeats = 2, .verify_per_s = 3};
    assert_int_equal(ub_revoke_init(&g_rv, &g_node, &g_store, &opt, NULL, NULL), UB_OK);
    assert_int_equal(g_rv.opt.min_interval_ms, 7);
    assert_int_equal(g_rv.opt.repeat_ms, 11);
    assert_int_equal(g_rv.opt.repeats, 2);
    assert_int_equal(g_rv.opt.verify_per_s, 3);
    assert_int_equal(ub_revoke_remove(&g_rv), UB_OK);

    ub_impair_init(NULL, NULL, 1);
    ub_impair_reseed(NULL, 1);
    ub_impair_set_params(NULL, NULL);
    ub_impair_init(&g_imp, NULL, 0); /* seed 0: replaced, never a stuck generator */
    ub_impair_set_params(&g_imp, NULL);
    assert_int_equal(ub_impair_wrap(NULL, &k_sink, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_impair_wrap(&g_imp, &k_no_send, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_impair_wrap(&g_imp, &ub_impair_ops, &g_imp), UB_ERR_INVAL); /* itself */
    assert_int_equal(ub_impair_wrap(&g_imp, &k_sink, NULL), UB_OK);
    assert_int_equal(ub_impair_pending(NULL), 0);
    assert_null(ub_impair_stats(NULL));
}

/* The membership requester: names, and every spec it refuses before sending (ub_member_request()). */
static ub_member_t g_m;
static void test_member_contracts(void **state) {
    (void)state;
    assert_string_equal(ub_member_op_name(UB_MEMBER_ADD_LINK), "add_link");
    assert_string_equal(ub_member_op_name((ub_member_op_t)0), "?");
    assert_string_equal(ub_member_op_name((ub_member_op_t)77), "?");
    assert_string_equal(ub_member_status_name((ub_member_status_t)77), "?");
    assert_int_equal(ub_node_init(&g_node, &k_cat, NULL), UB_OK);
    uint8_t me[UB_ENTITY_ID_LEN] = "me";
    int e = ub_node_add_entity(&g_node, me, true);
    assert_true(e >= 0);
    assert_int_equal(ub_member_init(NULL, &g_node, e, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_member_init(&g_m, NULL, e, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_member_init(&g_m, &g_node, 9, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_member_init(&g_m, &g_node, e, NULL), UB_OK);
    ub_member_spec_t ok = {.op = UB_MEMBER_ADD_ENTITY};
    memcpy(ok.target, "target", 6);
    memcpy(ok.subject, "subject", 7);
    ub_member_spec_t sp = ok;
    memset(sp.target, 0, sizeof sp.target);
    assert_int_equal(ub_member_request(&g_m, &sp, 0), UB_ERR_INVAL); /* no target */
    sp = ok;
    memset(sp.subject, 0, sizeof sp.subject);
    assert_int_equal(ub_member_request(&g_m, &sp, 0), UB_ERR_INVAL); /* no subject */
    sp.op = UB_MEMBER_SET_MASK;
    assert_int_equal(ub_member_request(&g_m, &sp, 0), UB_ERR_INVAL);
    sp = ok;
    sp.op = UB_MEMBER_ADD_LINK; /* no link name */
    assert_int_equal(ub_member_request(&g_m, &sp, 0), UB_ERR_INVAL);
    strcpy(sp.link_name, "radio");
    sp.link_index = UB_MAX_LINKS_PER_ENTITY;
    assert_int_equal(ub_member_request(&g_m, &sp, 0), UB_ERR_INVAL);
    sp.link_index = 0;
    memset(sp.port_spec, 'x', sizeof sp.port_spec); /* not terminated */
    assert_int_equal(ub_member_request(&g_m, &sp, 0), UB_ERR_INVAL);
    sp = ok;
    sp.op = UB_MEMBER_REMOVE_LINK;
    memset(sp.link_name, 'y', sizeof sp.link_name); /* not terminated */
    assert_int_equal(ub_member_request(&g_m, &sp, 0), UB_ERR_INVAL);
    sp.op = 99;
    assert_int_equal(ub_member_request(&g_m, &sp, 0), UB_ERR_INVAL);
    assert_int_equal(ub_member_request(&g_m, NULL, 0), UB_ERR_INVAL);
    assert_int_equal(ub_member_request(NULL, &ok, 0), UB_ERR_INVAL);
    int row = ub_member_request(&g_m, &ok, 0);
    assert_true(row >= 0);
    ub_member_info_t info;
    assert_int_equal(ub_member_status(&g_m, row, &info), UB_OK);
    assert_int_equal(info.status, UB_MEMBER_PENDING);
    assert_int_equal(ub_member_status(&g_m, row, NULL), UB_ERR_NOTFOUND);
    assert_int_equal(ub_member_status(&g_m, -1, &info), UB_ERR_NOTFOUND);
    assert_int_equal(ub_member_status(NULL, row, &info), UB_ERR_NOTFOUND);
    assert_int_equal(ub_member_forget(&g_m, UB_MAX_MEMBER_REQUESTS), UB_ERR_NOTFOUND);
    assert_int_equal(ub_member_forget(NULL, row), UB_ERR_NOTFOUND);
    assert_int_equal(ub_member_forget(&g_m, row), UB_OK);
    assert_int_equal(ub_member_forget(&g_m, row), UB_ERR_NOTFOUND);
    assert_null(ub_member_counters(NULL));
    assert_int_equal(ub_member_counters(&g_m)->sent, 0);
    ub_member_set_link_handler(NULL, NULL, NULL);
    ub_member_detach(&g_m);
    assert_int_equal(ub_member_request(&g_m, &ok, 0), UB_ERR_INVAL); /* detached */
    ub_member_detach(&g_m);
    ub_member_detach(NULL);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_service_registry_refusals),
        cmocka_unit_test(test_driver_helpers),
        cmocka_unit_test(test_revoke_and_impair_contracts),
        cmocka_unit_test(test_member_contracts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

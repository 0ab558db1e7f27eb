/* The two-node pair (ub_test_pair.h) joined by a real TCP connection on 127.0.0.1 instead of its memlink:
 * the pub node's link is the client, the sub node's the server on a port the kernel picks. Shared by test_tcp
 * and test_tcp_edges. Header-only, included after <cmocka.h>; each test file has its own copy. */
#ifndef UB_TEST_TCP_PAIR_H
#define UB_TEST_TCP_PAIR_H

#include <stdlib.h>

#include "support/ub_test_pair.h"
#include "ub/ub_tcp.h"

typedef struct tcp_pair {
    pair_t *p;
    ub_tcp_t client; /* pub side */
    ub_tcp_t server; /* sub side */
    uint16_t port;
} tcp_pair_t;

/* Opens the server on `port` (0: the kernel picks; t->port says which) and attaches it to the sub node. */
static inline void tcp_pair_open_server(tcp_pair_t *t, uint16_t port) {
    assert_int_equal(ub_tcp_server_open(&t->server, "127.0.0.1", port, NULL), UB_OK);
    assert_int_equal(ub_tcp_local_port(&t->server, &t->port), UB_OK);
    assert_int_equal(ub_tcp_attach(&t->server, t->p->sub_node, t->p->sub_link), UB_OK);
}

/* A pair whose client (backoff 20 ms doubling to 160 ms) is set to connect to the server: nothing is served yet. */
static inline tcp_pair_t *tcp_pair_new(void) {
    tcp_pair_t *t = calloc(1, sizeof *t);
    assert_non_null(t);
    t->p = pair_new(NULL);
    tcp_pair_open_server(t, 0);
    ub_tcp_options_t opt = {.backoff_initial_ms = 20, .backoff_max_ms = 160};
    assert_int_equal(ub_tcp_client_init(&t->client, "127.0.0.1", t->port, &opt), UB_OK);
    assert_int_equal(ub_tcp_attach(&t->client, t->p->pub_node, t->p->pub_link), UB_OK);
    return t;
}

static inline void tcp_pair_free(tcp_pair_t *t) {
    ub_tcp_close(&t->client);
    ub_tcp_close(&t->server);
    pair_free(t->p);
    free(t);
}

#endif /* UB_TEST_TCP_PAIR_H */

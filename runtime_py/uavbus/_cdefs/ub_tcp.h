/* cffi cdef for runtime_c/include/ub/ub_tcp.h (normally opened through ub_ports). */

typedef enum ub_tcp_state { UB_TCP_DOWN, UB_TCP_CONNECTING, UB_TCP_UP, ... } ub_tcp_state_t;

typedef struct ub_tcp_options {
    uint32_t backoff_initial_ms;
    uint32_t backoff_max_ms;
    ...;
} ub_tcp_options_t;

typedef struct ub_tcp_stats {
    uint64_t connects;
    uint64_t reconnects;
    uint64_t disconnects;
    uint64_t attempts;
    uint64_t failed_attempts;
    uint64_t replaced;
    uint64_t bytes_in;
    uint64_t bytes_out;
    uint64_t frames_out;
    uint64_t backpressure;
    uint64_t send_closed;
    uint64_t tx_discarded;
    ...;
} ub_tcp_stats_t;

typedef struct ub_tcp { ...; } ub_tcp_t;

int ub_tcp_client_init(ub_tcp_t *tcp, const char *addr, uint16_t port, const ub_tcp_options_t *opt);
int ub_tcp_server_open(ub_tcp_t *tcp, const char *addr, uint16_t port, const ub_tcp_options_t *opt);
int ub_tcp_local_port(const ub_tcp_t *tcp, uint16_t *port);
int ub_tcp_attach(ub_tcp_t *tcp, ub_node_t *node, int link_id);
int ub_tcp_service(ub_tcp_t *tcp, ub_node_t *node, uint64_t now_ms);
int ub_tcp_fileno(const ub_tcp_t *tcp);
int ub_tcp_listen_fileno(const ub_tcp_t *tcp);
ub_tcp_state_t ub_tcp_state(const ub_tcp_t *tcp);
size_t ub_tcp_tx_pending(const ub_tcp_t *tcp);
const ub_tcp_stats_t *ub_tcp_stats(const ub_tcp_t *tcp);
void ub_tcp_close(ub_tcp_t *tcp);

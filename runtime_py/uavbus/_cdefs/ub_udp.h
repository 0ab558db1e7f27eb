/* cffi cdef for runtime_c/include/ub/ub_udp.h (normally opened through ub_ports). */

typedef struct ub_udp_stats {
    uint64_t datagrams_in;
    uint64_t rejected;
    uint64_t foreign;
    uint64_t datagrams_out;
    uint64_t again;
    uint64_t send_errors;
    uint64_t frames_in;
    uint64_t frames_out;
    ...;
} ub_udp_stats_t;

typedef struct ub_udp { ub_udp_stats_t stats; ...; } ub_udp_t;

int ub_udp_open(ub_udp_t *udp, const char *bind_addr, uint16_t bind_port, const char *peer_addr, uint16_t peer_port);
int ub_udp_set_peer(ub_udp_t *udp, const char *peer_addr, uint16_t peer_port);
int ub_udp_local_port(const ub_udp_t *udp, uint16_t *port);
int ub_udp_attach(ub_udp_t *udp, ub_node_t *node, int link_id);
int ub_udp_service(ub_udp_t *udp, ub_node_t *node, uint64_t now_ms);
int ub_udp_flush(ub_udp_t *udp);
size_t ub_udp_tx_pending(const ub_udp_t *udp);
int ub_udp_fileno(const ub_udp_t *udp);
void ub_udp_close(ub_udp_t *udp);

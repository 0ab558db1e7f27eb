/* cffi cdef for runtime_c/include/ub/ub_udp.h (normally opened through ub_ports). */

typedef enum ub_udp_accept { UB_UDP_ACCEPT_PEER, UB_UDP_ACCEPT_LEARN, UB_UDP_ACCEPT_ANY, ... } ub_udp_accept_t;

typedef struct ub_udp_stats {
    uint64_t datagrams_in;
    uint64_t rejected;
    uint64_t foreign;
    uint64_t datagrams_out;
    uint64_t again;
    uint64_t send_errors;
    uint64_t frames_in;
    uint64_t frames_out;
    uint64_t peers_learned;
    uint64_t peers_forgotten;
    uint64_t no_peer;
    uint64_t copy_errors;
    uint64_t foreign_datagrams;
    uint64_t foreign_refused;
    ...;
} ub_udp_stats_t;

typedef struct ub_udp { uint8_t accept; ub_udp_stats_t stats; ...; } ub_udp_t;

int ub_udp_open(ub_udp_t *udp, const char *bind_addr, uint16_t bind_port, const char *peer_addr, uint16_t peer_port);
int ub_udp_set_peer(ub_udp_t *udp, const char *peer_addr, uint16_t peer_port);
int ub_udp_set_accept(ub_udp_t *udp, ub_udp_accept_t accept);
int ub_udp_peer_at(const ub_udp_t *udp, int i, char host[16], uint16_t *port);
int ub_udp_local_port(const ub_udp_t *udp, uint16_t *port);
int ub_udp_attach(ub_udp_t *udp, ub_node_t *node, int link_id);
int ub_udp_service(ub_udp_t *udp, ub_node_t *node, uint64_t now_ms);
int ub_udp_flush(ub_udp_t *udp);
size_t ub_udp_tx_pending(const ub_udp_t *udp);
int ub_udp_fileno(const ub_udp_t *udp);
void ub_udp_close(ub_udp_t *udp);

/* From ub_ports.h, declared here because it needs ub_udp_t (cdefs load in name order). */
const ub_udp_t *ub_ports_udp(const ub_ports_t *ports, const char *link_name);

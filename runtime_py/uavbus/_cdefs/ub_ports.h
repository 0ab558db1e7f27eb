/* cffi cdef for runtime_c/include/ub/ub_ports.h: port specs, opening/rebinding, one poll loop
 * (Contract 1). ub_ports_t is opaque; its size comes from the compiler. */

#define UB_PORTS_MAX ...
#define UB_PORTS_ERR_LEN ...

typedef enum ub_port_kind {
    UB_PORT_NONE, UB_PORT_UDP, UB_PORT_TCP_LISTEN, UB_PORT_TCP_CONNECT, UB_PORT_SERIAL, UB_PORT_MEM, ...
} ub_port_kind_t;

typedef struct ub_port_spec {
    ub_port_kind_t kind;
    char host[...];
    uint16_t port;
    char peer_host[...];
    uint16_t peer_port;
    uint8_t accept;
    char device[...];
    uint32_t baud;
    uint8_t batch;
    ...;
} ub_port_spec_t;

typedef struct ub_port {
    uint8_t in_use;
    uint8_t impaired;
    int link_id;
    ub_port_spec_t spec;
    uint32_t rebinds;
    uint64_t service_errors;
    ub_impair_t impair;
    ...;
} ub_port_t;

typedef struct ub_ports { ...; } ub_ports_t;

struct pollfd { int fd; short events; short revents; ...; };

typedef enum ub_drain_end {
    UB_DRAIN_EMPTY = 0, UB_DRAIN_IDLE = 1, UB_DRAIN_FULL = 2, UB_DRAIN_AGED = 3, UB_DRAIN_WOKEN = 4
} ub_drain_end_t;

typedef struct ub_ports_drain {
    int wake_fd;
    uint32_t idle_us;
    uint32_t max_us;
    const size_t *pending;
    size_t flush_at;
    struct pollfd fds[...];
    int nfds;
    uint32_t fds_gen;
    uint64_t drains, rounds;
    uint64_t ends[5];
    ...;
} ub_ports_drain_t;

int ub_ports_drain(ub_ports_t *ports, ub_ports_drain_t *how, uint64_t now_ms);
const char *ub_port_kind_transport(ub_port_kind_t kind);
int ub_port_spec_parse(const char *text, ub_port_spec_t *spec, char *err, size_t err_cap);
void ub_port_spec_format(const ub_port_spec_t *spec, char *out, size_t cap);
int ub_ports_init(ub_ports_t *ports, ub_node_t *node);
int ub_ports_open(ub_ports_t *ports, const char *link_name, const ub_port_spec_t *spec, uint64_t now_ms, char *err,
                  size_t err_cap);
int ub_ports_open_text(ub_ports_t *ports, const char *link_name, const char *spec_text, uint64_t now_ms, char *err,
                       size_t err_cap);
int ub_ports_open_config(ub_ports_t *ports, const ub_nodecfg_t *cfg, uint64_t now_ms, char *err, size_t err_cap);
int ub_ports_close(ub_ports_t *ports, const char *link_name);
void ub_ports_close_all(ub_ports_t *ports);
int ub_ports_service(ub_ports_t *ports, uint64_t now_ms);
int ub_ports_flush(ub_ports_t *ports);
int ub_ports_pollfds(const ub_ports_t *ports, struct pollfd *fds, int cap);
int ub_ports_poll_timeout(const ub_ports_t *ports, uint64_t now_ms, int max_ms);
int ub_ports_local_port(const ub_ports_t *ports, const char *link_name, uint16_t *port);
const ub_port_t *ub_ports_find(const ub_ports_t *ports, const char *link_name);
int ub_ports_set_impairment(ub_ports_t *ports, const ub_impair_params_t *params, uint64_t seed);
int ub_ports_set_link_impairment(ub_ports_t *ports, const char *link_name, const ub_impair_params_t *params,
                                 uint64_t seed);
int ub_ports_notice(ub_ports_t *ports, char *out, size_t cap);
int ub_ports_set_foreign(ub_ports_t *ports, const char *link_name, ub_foreign_cb cb, void *user);
int ub_ports_write_foreign(ub_ports_t *ports, const char *link_name, const uint8_t *data, size_t len, uint64_t now_ms);
int ub_ports_describe(const ub_ports_t *ports, const char *link_name, char *out, size_t cap);

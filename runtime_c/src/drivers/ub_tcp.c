#include "ub/ub_tcp.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "ub/ub_node.h"
#include "ub/ub_ports.h"
#include "ub/ub_sec.h"
#include "ub/ub_service.h"
#include "drivers/ub_sock_private.h"
#include "drivers/ub_stream_tx_private.h"

#define DEFAULT_BACKOFF_INITIAL_MS 100u
#define DEFAULT_BACKOFF_MAX_MS 5000u
#define DEFAULT_IDLE_MS 3000u
#define DEFAULT_CANDIDATE_MS 10000u

/* Frames are small and latency matters more than packet count. */
static void set_nodelay(int fd) {
    int one = 1;
    (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}

static long socket_write(int fd, const uint8_t *data, size_t len) { return (long)send(fd, data, len, MSG_NOSIGNAL); }

static void reset(ub_tcp_t *tcp, ub_tcp_role_t role, const ub_tcp_options_t *opt) {
    memset(tcp, 0, sizeof *tcp);
    tcp->role = role;
    tcp->fd = -1;
    tcp->listen_fd = -1;
    tcp->link_id = -1;
    if (opt != NULL) tcp->opt = *opt;
    if (tcp->opt.backoff_initial_ms == 0) tcp->opt.backoff_initial_ms = DEFAULT_BACKOFF_INITIAL_MS;
    if (tcp->opt.backoff_max_ms == 0) tcp->opt.backoff_max_ms = DEFAULT_BACKOFF_MAX_MS;
    if (tcp->opt.backoff_max_ms < tcp->opt.backoff_initial_ms) tcp->opt.backoff_max_ms = tcp->opt.backoff_initial_ms;
    if (tcp->opt.idle_ms == 0) tcp->opt.idle_ms = DEFAULT_IDLE_MS;
    if (tcp->opt.candidate_ms == 0) tcp->opt.candidate_ms = DEFAULT_CANDIDATE_MS;
    tcp->backoff_ms = tcp->opt.backoff_initial_ms;
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES; i++) tcp->cand[i].fd = -1;
}

int ub_tcp_client_init(ub_tcp_t *tcp, const char *addr, uint16_t port, const ub_tcp_options_t *opt) {
    if (tcp == NULL) return UB_ERR_INVAL;
    reset(tcp, UB_TCP_CLIENT, opt);
    if (port == 0) return UB_ERR_INVAL;
    return ub_sock_address(addr, port, &tcp->addr);
}

int ub_tcp_server_open(ub_tcp_t *tcp, const char *addr, uint16_t port, const ub_tcp_options_t *opt) {
    if (tcp == NULL) return UB_ERR_INVAL;
    reset(tcp, UB_TCP_SERVER, opt);
    if (ub_sock_address(addr, port, &tcp->addr) < 0) return UB_ERR_INVAL;
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) return UB_ERR_IO;
    int one = 1;
    if (setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) < 0 || ub_sock_set_nonblocking(fd) < 0 ||
        bind(fd, (const struct sockaddr *)&tcp->addr, sizeof tcp->addr) < 0 || listen(fd, 4) < 0) {
        ub_sock_close_keep_errno(fd);
        return UB_ERR_IO;
    }
    tcp->listen_fd = fd;
    return UB_OK;
}

int ub_tcp_local_port(const ub_tcp_t *tcp, uint16_t *port) {
    if (tcp == NULL || port == NULL || tcp->listen_fd < 0) return UB_ERR_INVAL;
    return ub_sock_local_port(tcp->listen_fd, port);
}

/* Drops the connection; a client schedules its next attempt with the current backoff, then doubles it. */
static void connection_lost(ub_tcp_t *tcp, uint64_t now_ms, int was_up) {
    if (tcp->fd >= 0) close(tcp->fd);
    tcp->fd = -1;
    tcp->stats.tx_discarded += tcp->tx_len;
    tcp->tx_len = 0;
    tcp->state = UB_TCP_DOWN;
    if (was_up) {
        tcp->stats.disconnects++;
        /* Reset, orderly close or a failed write: transport evidence, heard by the routing service at once
         * instead of after its hello timeout (ub_node_link_event()). */
        if (tcp->node != NULL) ub_node_link_event(tcp->node, tcp->link_id, UB_LINK_EVENT_DOWN, now_ms);
    }
    if (tcp->role == UB_TCP_CLIENT) {
        tcp->next_attempt_ms = now_ms + tcp->backoff_ms;
        uint32_t max = tcp->opt.backoff_max_ms;
        tcp->backoff_ms = tcp->backoff_ms > max / 2u ? max : tcp->backoff_ms * 2u;
    }
}

/* Whole or nothing through the transmit buffer; `counter` counts what went in (a frame, a foreign message). */
static int tcp_write(ub_tcp_t *tcp, const uint8_t *frame, size_t len, uint64_t now_ms, uint64_t *counter) {
    if (tcp->state != UB_TCP_UP) {
        tcp->stats.send_closed++;
        return UB_ERR_CLOSED;
    }
    int rc;
    if (tcp->batching && len <= sizeof tcp->tx - tcp->tx_len) {
        /* Batching: queue only; the buffer goes out in one send() when full, at flush or at service. */
        memcpy(tcp->tx + tcp->tx_len, frame, len);
        tcp->tx_len += len;
        rc = UB_OK;
    } else if (tcp->batching) {
        rc = ub_stream_tx_flush(tcp->fd, socket_write, tcp->tx, &tcp->tx_len, &tcp->stats.bytes_out);
        if (rc == UB_OK && len > sizeof tcp->tx - tcp->tx_len) rc = UB_ERR_AGAIN;
        if (rc == UB_OK) {
            memcpy(tcp->tx + tcp->tx_len, frame, len);
            tcp->tx_len += len;
        }
    } else {
        rc = ub_stream_tx_send(tcp->fd, socket_write, tcp->tx, sizeof tcp->tx, &tcp->tx_len, frame, len,
                               &tcp->stats.bytes_out);
    }
    if (rc == UB_ERR_AGAIN) {
        tcp->stats.backpressure++;
        return rc;
    }
    if (rc < 0) {
        /* The frame was copied into the buffer before the failure, so it is among the discarded bytes. */
        connection_lost(tcp, now_ms, 1);
        return UB_ERR_CLOSED;
    }
    (*counter)++;
    return UB_OK;
}

static int tcp_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    ub_tcp_t *tcp = impl;
    return tcp_write(tcp, frame, len, now_ms, &tcp->stats.frames_out);
}

int ub_tcp_write_foreign(ub_tcp_t *tcp, const uint8_t *data, size_t len, uint64_t now_ms) {
    if (tcp == NULL || (data == NULL && len != 0) || len > sizeof tcp->tx) return UB_ERR_INVAL;
    return tcp_write(tcp, data, len, now_ms, &tcp->stats.foreign_out);
}

static int tcp_fileno(void *impl) { return ub_tcp_fileno(impl); }

const ub_link_ops_t ub_tcp_ops = {.kind = "tcp", .send = tcp_send, .fileno = tcp_fileno};

int ub_tcp_attach(ub_tcp_t *tcp, ub_node_t *node, int link_id) {
    if (tcp == NULL) return UB_ERR_INVAL;
    return ub_driver_attach(node, link_id, &ub_tcp_ops, tcp, &tcp->node, &tcp->link_id);
}

/* A new stream starts: re-attaching resets the slot's decoder (no half frame from the old stream survives). */
static void connection_up(ub_tcp_t *tcp, int fd, uint64_t now_ms) {
    tcp->fd = fd;
    tcp->state = UB_TCP_UP;
    tcp->last_fresh_ms = now_ms;
    if (tcp->node != NULL) ub_node_link_event(tcp->node, tcp->link_id, UB_LINK_EVENT_UP, now_ms);
    tcp->tx_len = 0;
    tcp->backoff_ms = tcp->opt.backoff_initial_ms;
    tcp->stats.connects++;
    if (tcp->had_connection) tcp->stats.reconnects++;
    tcp->had_connection = 1;
    set_nodelay(fd);
    /* Cannot fail: ub_tcp_attach() succeeded with these same arguments. */
    int attached = ub_driver_reattach(tcp->node, tcp->link_id, &ub_tcp_ops, tcp);
    (void)attached;
    if (tcp->foreign_on) ub_decoder_restart(&tcp->own_dec); /* the same for the link's own decoder */
    /* The link hello (ub_tcp.h): a listener requiring signed frames adopts this connection on its proof,
     * also when this side has nothing else to send. Without a transmit key there is nothing to prove. */
    ub_sec_t *sec = ub_node_security(tcp->node);
    if (tcp->role == UB_TCP_CLIENT && sec != NULL && ub_sec_tx_key(sec) != 0) {
        uint8_t nonce[UB_SEC_NONCE_LEN];
        ub_sec_random(sec, nonce, sizeof nonce);
        if (ub_node_send_link_local(tcp->node, tcp->link_id, UB_ADMIN_CHALLENGE, nonce, sizeof nonce, now_ms) > 0)
            tcp->stats.hellos++;
    }
}

/* A candidate ends (closed or adopted): what its decoder refused goes into the driver's counters. */
static void account_candidate(ub_tcp_t *tcp, ub_tcp_candidate_t *c) {
    for (int r = 0; r < UB_RX_REASON_COUNT; r++) tcp->stats.candidate_rejected += c->dec.stats.rejected[r];
    tcp->stats.candidate_garbage += c->dec.stats.garbage_bytes + ub_decoder_pending(&c->dec);
    ub_decoder_init(&c->dec);
}

static void close_candidate(ub_tcp_t *tcp, ub_tcp_candidate_t *c) {
    if (c->fd >= 0) {
        close(c->fd);
        account_candidate(tcp, c);
    }
    c->fd = -1;
    c->proven = 0;
}

/* The candidate a new connection from `addr` may take the slot of, or NULL: the oldest unproven one of
 * `addr` once it holds UB_TCP_CANDIDATES_PER_ADDR of them, else a free slot, else the oldest unproven one
 * of any address (ub_tcp.h). *evict tells whether the slot is taken. */
static ub_tcp_candidate_t *slot_for(ub_tcp_t *tcp, uint32_t addr, bool *evict) {
    ub_tcp_candidate_t *free_slot = NULL, *own = NULL, *any = NULL;
    int own_n = 0;
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES; i++) {
        ub_tcp_candidate_t *c = &tcp->cand[i];
        if (c->fd < 0) {
            if (free_slot == NULL) free_slot = c;
            continue;
        }
        if (c->proven) continue;
        if (any == NULL || c->since_ms < any->since_ms) any = c;
        if (c->addr != addr) continue;
        own_n++;
        if (own == NULL || c->since_ms < own->since_ms) own = c;
    }
    *evict = true;
    if (own_n >= UB_TCP_CANDIDATES_PER_ADDR) return own;
    if (free_slot != NULL) {
        *evict = false;
        return free_slot;
    }
    return any;
}

/* New connections never displace the established peer here: they become candidates (see ub_tcp.h). */
static void server_accept(ub_tcp_t *tcp, uint64_t now_ms) {
    for (;;) {
        struct sockaddr_in from;
        socklen_t from_len = sizeof from;
        memset(&from, 0, sizeof from);
        int fd = accept(tcp->listen_fd, (struct sockaddr *)&from, &from_len);
        if (fd < 0) return; /* EAGAIN: nobody waiting; other errors: the next service retries */
        if (ub_sock_set_nonblocking(fd) < 0) {
            close(fd);
            continue;
        }
        if (tcp->state != UB_TCP_UP && !ub_node_link_requires_signed(tcp->node, tcp->link_id)) {
            connection_up(tcp, fd, now_ms); /* nobody to displace and nothing to prove */
            continue;
        }
        bool evict;
        ub_tcp_candidate_t *c = slot_for(tcp, from.sin_addr.s_addr, &evict);
        if (c == NULL) {
            close(fd);
            tcp->stats.candidates_refused++;
            continue;
        }
        if (evict) {
            close_candidate(tcp, c);
            tcp->stats.candidates_evicted++;
        }
        c->fd = fd;
        c->proven = 0;
        c->since_ms = now_ms;
        c->addr = from.sin_addr.s_addr;
        ub_decoder_init(&c->dec);
        set_nodelay(fd);
        tcp->stats.candidates++;
    }
}

/* Reads what a candidate sent into the node, through its own decoder. */
static void read_candidate(ub_tcp_t *tcp, ub_tcp_candidate_t *c, uint64_t now_ms) {
    for (int i = 0; i < UB_TCP_RX_BUDGET && c->fd >= 0; i++) {
        ssize_t n = recv(c->fd, tcp->rx, sizeof tcp->rx, 0);
        if (n > 0) {
            tcp->stats.bytes_in += (uint64_t)n;
            ub_rx_verdicts_t v = {0, 0};
            int found = ub_node_rx_stream(tcp->node, tcp->link_id, &c->dec, tcp->rx, (size_t)n, now_ms, &v);
            if (found >= 0 && v.fresh > 0) c->proven = 2;
            else if (found >= 0 && v.authentic > 0 && c->proven == 0) c->proven = 1;
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
        close_candidate(tcp, c);
        tcp->stats.candidates_lost++;
    }
}

/* Candidates: read them, expire the ones that prove nothing, adopt a proven one when the established
 * peer is gone or silent. */
static void service_candidates(ub_tcp_t *tcp, uint64_t now_ms) {
    ub_tcp_candidate_t *pick = NULL;
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES; i++) {
        ub_tcp_candidate_t *c = &tcp->cand[i];
        if (c->fd < 0) continue;
        read_candidate(tcp, c, now_ms);
        if (c->fd < 0) continue;
        /* Absolute age: proven or not, a candidate the node never needed is not kept for good. */
        if (now_ms >= c->since_ms && now_ms - c->since_ms >= tcp->opt.candidate_ms) {
            close_candidate(tcp, c);
            tcp->stats.candidates_expired++;
            continue;
        }
        if (c->proven && (pick == NULL || c->proven > pick->proven)) pick = c;
    }
    if (pick == NULL) return;
    bool silent = tcp->state != UB_TCP_UP ||
                  (now_ms >= tcp->last_fresh_ms && now_ms - tcp->last_fresh_ms >= tcp->opt.idle_ms);
    if (!silent) return;
    if (tcp->state == UB_TCP_UP) {
        tcp->stats.replaced++;
        connection_lost(tcp, now_ms, 1);
    }
    int fd = pick->fd;
    account_candidate(tcp, pick);
    pick->fd = -1;
    pick->proven = 0;
    tcp->stats.adopted++;
    connection_up(tcp, fd, now_ms);
}

static void client_start_attempt(ub_tcp_t *tcp, uint64_t now_ms) {
    tcp->stats.attempts++;
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0 || ub_sock_set_nonblocking(fd) < 0) {
        if (fd >= 0) close(fd);
        tcp->stats.failed_attempts++;
        connection_lost(tcp, now_ms, 0);
        return;
    }
    if (connect(fd, (const struct sockaddr *)&tcp->addr, sizeof tcp->addr) == 0) {
        connection_up(tcp, fd, now_ms);
        return;
    }
    if (errno == EINPROGRESS || errno == EINTR) {
        tcp->fd = fd;
        tcp->state = UB_TCP_CONNECTING;
        return;
    }
    close(fd);
    tcp->stats.failed_attempts++;
    connection_lost(tcp, now_ms, 0);
}

/* Checks a connect() in progress without waiting: writable means finished, SO_ERROR says how. */
static void client_check_attempt(ub_tcp_t *tcp, uint64_t now_ms) {
    struct pollfd p = {.fd = tcp->fd, .events = POLLOUT};
    if (poll(&p, 1, 0) <= 0) return;
    int err = 0;
    socklen_t len = sizeof err;
    if (getsockopt(tcp->fd, SOL_SOCKET, SO_ERROR, &err, &len) < 0 || err != 0) {
        tcp->stats.failed_attempts++;
        connection_lost(tcp, now_ms, 0);
        return;
    }
    int fd = tcp->fd;
    connection_up(tcp, fd, now_ms);
}

/* @return frames found, or -1 when the connection was lost. */
static int read_available(ub_tcp_t *tcp, uint64_t now_ms) {
    int frames = 0;
    for (int i = 0; i < UB_TCP_RX_BUDGET && tcp->state == UB_TCP_UP; i++) {
        ssize_t n = recv(tcp->fd, tcp->rx, sizeof tcp->rx, 0);
        if (n > 0) {
            tcp->stats.bytes_in += (uint64_t)n;
            ub_rx_verdicts_t v = {0, 0};
            ub_decoder_t *dec = tcp->foreign_on ? &tcp->own_dec : NULL; /* NULL: the slot's */
            int found = ub_node_rx_stream(tcp->node, tcp->link_id, dec, tcp->rx, (size_t)n, now_ms, &v);
            if (found > 0) frames += found;
            /* Alive only by frames whose freshness is proven: replays, even authentic ones, keep nothing alive. */
            if (v.fresh > 0) tcp->last_fresh_ms = now_ms;
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
        connection_lost(tcp, now_ms, 1); /* 0: orderly close by the peer; < 0: reset or error */
        break;
    }
    return frames;
}

int ub_tcp_service(ub_tcp_t *tcp, ub_node_t *node, uint64_t now_ms) {
    if (tcp == NULL || node == NULL || node != tcp->node) return UB_ERR_INVAL;
    if (tcp->role == UB_TCP_SERVER && tcp->listen_fd >= 0) {
        server_accept(tcp, now_ms);
        service_candidates(tcp, now_ms);
    }
    if (tcp->role == UB_TCP_CLIENT && tcp->state == UB_TCP_DOWN && now_ms >= tcp->next_attempt_ms)
        client_start_attempt(tcp, now_ms);
    if (tcp->state == UB_TCP_CONNECTING) client_check_attempt(tcp, now_ms);
    if (tcp->state != UB_TCP_UP) return 0;
    if (tcp->tx_len > 0 &&
        ub_stream_tx_flush(tcp->fd, socket_write, tcp->tx, &tcp->tx_len, &tcp->stats.bytes_out) < 0) {
        connection_lost(tcp, now_ms, 1);
        return 0;
    }
    return read_available(tcp, now_ms);
}

int ub_tcp_set_foreign(ub_tcp_t *tcp, ub_foreign_cb cb, void *user) {
    if (tcp == NULL) return UB_ERR_INVAL;
    if (cb == NULL) { /* back to the slot's decoder: what the link's own still held is counted garbage there */
        if (tcp->foreign_on) ub_decoder_restart(&tcp->own_dec);
        tcp->foreign_on = 0;
        return UB_OK;
    }
    if (!tcp->foreign_on) ub_decoder_init(&tcp->own_dec);
    ub_decoder_set_foreign(&tcp->own_dec, cb, user);
    tcp->foreign_on = 1;
    return UB_OK;
}

int ub_tcp_set_batching(ub_tcp_t *tcp, int on) {
    if (tcp == NULL) return UB_ERR_INVAL;
    tcp->batching = on != 0;
    return UB_OK;
}

int ub_tcp_flush(ub_tcp_t *tcp, uint64_t now_ms) {
    if (tcp == NULL) return UB_ERR_INVAL;
    if (tcp->state != UB_TCP_UP || tcp->tx_len == 0) return (int)tcp->tx_len;
    if (ub_stream_tx_flush(tcp->fd, socket_write, tcp->tx, &tcp->tx_len, &tcp->stats.bytes_out) < 0) {
        connection_lost(tcp, now_ms, 1);
        return UB_ERR_CLOSED;
    }
    return (int)tcp->tx_len;
}

int ub_tcp_fileno(const ub_tcp_t *tcp) { return tcp == NULL ? -1 : tcp->fd; }

int ub_tcp_listen_fileno(const ub_tcp_t *tcp) { return tcp == NULL ? -1 : tcp->listen_fd; }

ub_tcp_state_t ub_tcp_state(const ub_tcp_t *tcp) { return tcp == NULL ? UB_TCP_DOWN : tcp->state; }

size_t ub_tcp_tx_pending(const ub_tcp_t *tcp) { return tcp == NULL ? 0 : tcp->tx_len; }

const ub_tcp_stats_t *ub_tcp_stats(const ub_tcp_t *tcp) { return tcp == NULL ? NULL : &tcp->stats; }

int ub_tcp_candidates(const ub_tcp_t *tcp) {
    int n = 0;
    for (int i = 0; tcp != NULL && i < UB_TCP_MAX_CANDIDATES; i++) n += tcp->cand[i].fd >= 0;
    return n;
}

void ub_tcp_close(ub_tcp_t *tcp) {
    if (tcp == NULL) return;
    for (int i = 0; i < UB_TCP_MAX_CANDIDATES; i++) close_candidate(tcp, &tcp->cand[i]);
    if (tcp->fd >= 0) close(tcp->fd);
    if (tcp->listen_fd >= 0) close(tcp->listen_fd);
    tcp->fd = -1;
    tcp->listen_fd = -1;
    tcp->state = UB_TCP_DOWN;
}

/* ---- the driver entry (ub_driver.h): "tcp:listen=HOST:PORT" (server) or "tcp:connect=HOST:PORT" (client) ---- */

static int tcp_spec_param(ub_port_spec_t *s, uint32_t *seen, const char *key, const char *value, char *err,
                          size_t cap) {
    if (strcmp(key, "listen") != 0 && strcmp(key, "connect") != 0) return UB_ERR_NOTFOUND;
    if (*seen != 0) {
        snprintf(err, cap, "'%s': a tcp port either listens or connects: give exactly one of listen=, connect=", key);
        return UB_ERR_INVAL;
    }
    if (!ub_sock_parse_hostport(value, s->host, UB_PORT_HOST_LEN, &s->port)) {
        snprintf(err, cap, "'%s=%.40s': %s", key, value, UB_SOCK_HOSTPORT_HELP);
        return UB_ERR_INVAL;
    }
    if (key[0] == 'c') {
        if (s->port == 0) {
            snprintf(err, cap, "'connect=%.40s': the port to connect to must not be 0", value);
            return UB_ERR_INVAL;
        }
        s->kind = UB_PORT_TCP_CONNECT;
    } else {
        s->kind = UB_PORT_TCP_LISTEN;
    }
    *seen = 1;
    return UB_OK;
}

static int tcp_spec_finish(ub_port_spec_t *s, uint32_t seen, char *err, size_t cap) {
    (void)s;
    if (seen == 0) {
        snprintf(err, cap,
                 "tcp needs listen=HOST:PORT (server) or connect=HOST:PORT (client), e.g. tcp:connect=127.0.0.1:5001");
        return UB_ERR_INVAL;
    }
    return UB_OK;
}

static int tcp_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    return snprintf(out, cap, "tcp:%s=%s:%u", spec->kind == UB_PORT_TCP_CONNECT ? "connect" : "listen", spec->host,
                    (unsigned)spec->port);
}

static int tcp_open(void *state, const ub_port_spec_t *spec) {
    return spec->kind == UB_PORT_TCP_CONNECT ? ub_tcp_client_init(state, spec->host, spec->port, NULL)
                                             : ub_tcp_server_open(state, spec->host, spec->port, NULL);
}

static void tcp_close(void *state) { ub_tcp_close(state); }
static int tcp_attach(void *state, ub_node_t *node, int link_id) { return ub_tcp_attach(state, node, link_id); }
static int tcp_service(void *state, ub_node_t *node, uint64_t now_ms) { return ub_tcp_service(state, node, now_ms); }

/* A client starts its first connection attempt when it is opened rather than at the first service. */
static void tcp_start(void *state, ub_node_t *node, uint64_t now_ms) {
    ub_tcp_t *tcp = state;
    if (tcp->role != UB_TCP_CLIENT) return;
    int frames = ub_tcp_service(tcp, node, now_ms); /* none yet: the attempt has only started */
    (void)frames;
}

static int tcp_pollfds(const void *state, struct pollfd *fds, int cap) {
    const ub_tcp_t *tcp = state;
    int n = 0;
    bool out = tcp->tx_len > 0 || tcp->state == UB_TCP_CONNECTING;
    const int fd[2] = {tcp->listen_fd, tcp->fd};
    const short events[2] = {POLLIN, (short)(POLLIN | (out ? POLLOUT : 0))};
    for (int i = 0; i < 2; i++) {
        if (fd[i] < 0) continue;
        if (n >= cap) return UB_ERR_NOSPACE;
        fds[n].fd = fd[i];
        fds[n].events = events[i];
        fds[n].revents = 0;
        n++;
    }
    return n;
}

/* A client waiting to retry has no descriptor to wake the loop: its retry time must. */
static bool tcp_next_due(const void *state, uint64_t *due_ms) {
    const ub_tcp_t *tcp = state;
    if (tcp->role != UB_TCP_CLIENT || tcp->state != UB_TCP_DOWN) return false;
    *due_ms = tcp->next_attempt_ms;
    return true;
}

static int tcp_local_port(const void *state, uint16_t *port) {
    const ub_tcp_t *tcp = state;
    return tcp->role == UB_TCP_SERVER ? ub_tcp_local_port(tcp, port) : UB_ERR_INVAL;
}

static int tcp_set_foreign_op(void *state, ub_foreign_cb cb, void *user) { return ub_tcp_set_foreign(state, cb, user); }

static int tcp_write_foreign_op(void *state, const uint8_t *data, size_t len, uint64_t now_ms) {
    return ub_tcp_write_foreign(state, data, len, now_ms);
}

static size_t tcp_counters(const void *state, ub_driver_counter_t *out, size_t cap) {
    const ub_tcp_stats_t *s = &((const ub_tcp_t *)state)->stats;
    const ub_driver_counter_t all[] = {
        {"connects", s->connects},
        {"reconnects", s->reconnects},
        {"disconnects", s->disconnects},
        {"attempts", s->attempts},
        {"failed_attempts", s->failed_attempts},
        {"replaced", s->replaced},
        {"candidates", s->candidates},
        {"adopted", s->adopted},
        {"candidates_refused", s->candidates_refused},
        {"candidates_evicted", s->candidates_evicted},
        {"candidates_expired", s->candidates_expired},
        {"candidates_lost", s->candidates_lost},
        {"candidate_rejected", s->candidate_rejected},
        {"candidate_garbage", s->candidate_garbage},
        {"bytes_in", s->bytes_in},
        {"bytes_out", s->bytes_out},
        {"frames_out", s->frames_out},
        {"backpressure", s->backpressure},
        {"send_closed", s->send_closed},
        {"tx_discarded", s->tx_discarded},
        {"hellos", s->hellos},
        {"foreign_out", s->foreign_out},
        {"foreign_bytes", ((const ub_tcp_t *)state)->own_dec.stats.foreign_bytes},
        {"foreign_refused", ((const ub_tcp_t *)state)->own_dec.stats.foreign_refused},
    };
    size_t n = sizeof all / sizeof all[0];
    for (size_t i = 0; i < n && i < cap && out != NULL; i++) out[i] = all[i];
    return n;
}

static int tcp_describe(const void *state, char *out, size_t cap) {
    const ub_tcp_t *tcp = state;
    const ub_tcp_stats_t *s = &tcp->stats;
    static const char *const states[] = {"down", "connecting", "up"};
    return snprintf(out, cap,
                    "\"state\":\"%s\",\"connects\":%llu,\"reconnects\":%llu,\"disconnects\":%llu,"
                    "\"failed_attempts\":%llu,\"backpressure\":%llu,\"send_closed\":%llu,\"tx_discarded\":%llu,"
                    "\"candidates\":%llu,\"adopted\":%llu,\"replaced\":%llu,\"candidates_refused\":%llu,"
                    "\"candidates_evicted\":%llu,\"candidates_expired\":%llu,\"candidates_lost\":%llu,"
                    "\"candidate_rejected\":%llu,\"foreign_bytes\":%llu,\"foreign_refused\":%llu,\"foreign_out\":%llu,"
                    "\"candidates_open\":%d,\"hellos\":%llu",
                    states[tcp->state % 3], (unsigned long long)s->connects, (unsigned long long)s->reconnects,
                    (unsigned long long)s->disconnects, (unsigned long long)s->failed_attempts,
                    (unsigned long long)s->backpressure, (unsigned long long)s->send_closed,
                    (unsigned long long)s->tx_discarded, (unsigned long long)s->candidates,
                    (unsigned long long)s->adopted, (unsigned long long)s->replaced,
                    (unsigned long long)s->candidates_refused, (unsigned long long)s->candidates_evicted,
                    (unsigned long long)s->candidates_expired, (unsigned long long)s->candidates_lost,
                    (unsigned long long)s->candidate_rejected, (unsigned long long)tcp->own_dec.stats.foreign_bytes,
                    (unsigned long long)tcp->own_dec.stats.foreign_refused, (unsigned long long)s->foreign_out,
                    ub_tcp_candidates(tcp), (unsigned long long)s->hellos);
}

const ub_driver_t ub_tcp_driver = {
    .name = "tcp",
    .keys = "listen or connect",
    .examples = "tcp:listen=127.0.0.1:5001 | tcp:connect=127.0.0.1:5001",
    .wire_params = true,
    .state_size = sizeof(ub_tcp_t),
    .spec_init = NULL, /* the kind comes with listen= or connect= */
    .spec_param = tcp_spec_param,
    .spec_finish = tcp_spec_finish,
    .spec_format = tcp_spec_format,
    .open = tcp_open,
    .close = tcp_close,
    .attach = tcp_attach,
    .link_ops = &ub_tcp_ops,
    .start = tcp_start,
    .service = tcp_service,
    .pollfds = tcp_pollfds,
    .next_due = tcp_next_due,
    .local_port = tcp_local_port,
    .counters = tcp_counters,
    .set_foreign = tcp_set_foreign_op,
    .write_foreign = tcp_write_foreign_op,
    .describe = tcp_describe,
};

/* POSIX transports to the autopilot and the signing key file (ub_mavio.h). */
#include "ub_mavio.h"

#include <arpa/inet.h>
#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

static int fail(char *err, size_t cap, int rc, const char *what, const char *detail) {
    if (err != NULL && cap > 0) snprintf(err, cap, "%s: %s", what, detail);
    return rc;
}

static int open_udp(ub_mavio_t *io, const ub_port_spec_t *spec, char *err, size_t cap) {
    struct sockaddr_in local;
    memset(&local, 0, sizeof local);
    local.sin_family = AF_INET;
    local.sin_port = htons(spec->port);
    memset(&io->peer, 0, sizeof io->peer);
    io->peer.sin_family = AF_INET;
    io->peer.sin_port = htons(spec->peer_port);
    if (inet_pton(AF_INET, spec->host, &local.sin_addr) != 1 || inet_pton(AF_INET, spec->peer_host, &io->peer.sin_addr) != 1)
        return fail(err, cap, UB_ERR_INVAL, "udp", "bind and peer must be dotted IPv4 addresses");
    int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) return fail(err, cap, UB_ERR_IO, "udp socket", strerror(errno));
    int rcvbuf = UB_MAVIO_RCVBUF;
    (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf); /* best effort: a smaller one still works */
    if (bind(fd, (const struct sockaddr *)&local, sizeof local) < 0) {
        int e = errno;
        close(fd);
        char what[96];
        snprintf(what, sizeof what, "udp bind %s:%u", spec->host, (unsigned)spec->port);
        return fail(err, cap, UB_ERR_IO, what, strerror(e));
    }
    io->fd = fd;
    return UB_OK;
}

/* TCP client: starts a non-blocking connect (completed in ub_mavio_service()). */
static int tcp_connect(ub_mavio_t *io, uint64_t now_ms) {
    int fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) return UB_ERR_IO;
    int one = 1;
    (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one); /* MAVLink messages are small and urgent */
    int rc = connect(fd, (const struct sockaddr *)&io->peer, sizeof io->peer);
    if (rc < 0 && errno != EINPROGRESS) {
        close(fd);
        io->stats.connect_failures++;
        io->retry_ms = now_ms + UB_MAVIO_RECONNECT_MS;
        return UB_ERR_IO;
    }
    io->fd = fd;
    io->connecting = rc < 0;
    if (rc == 0) io->stats.connects++;
    return UB_OK;
}

static void tcp_drop(ub_mavio_t *io, uint64_t now_ms, bool was_up) {
    if (io->fd >= 0) close(io->fd);
    io->fd = -1;
    io->connecting = 0;
    io->tx_len = 0; /* half a message must not start the next connection */
    io->retry_ms = now_ms + UB_MAVIO_RECONNECT_MS;
    if (was_up) io->stats.disconnects++;
    else io->stats.connect_failures++;
}

int ub_mavio_open(ub_mavio_t *io, const ub_port_spec_t *spec, char *err, size_t err_cap) {
    if (io == NULL || spec == NULL) return UB_ERR_INVAL;
    memset(io, 0, sizeof *io);
    io->fd = -1;
    io->kind = spec->kind;
    if (spec->kind == UB_PORT_UDP) return open_udp(io, spec, err, err_cap);
    if (spec->kind == UB_PORT_TCP_CONNECT) {
        io->peer.sin_family = AF_INET;
        io->peer.sin_port = htons(spec->port);
        if (inet_pton(AF_INET, spec->host, &io->peer.sin_addr) != 1)
            return fail(err, err_cap, UB_ERR_INVAL, "tcp", "connect must be a dotted IPv4 address");
        (void)tcp_connect(io, 0); /* refused now: retried by ub_mavio_service(), as SITL may start later */
        return UB_OK;
    }
    if (spec->kind == UB_PORT_SERIAL) {
        int rc = ub_serial_open(&io->serial, spec->device, spec->baud);
        if (rc == UB_ERR_RANGE) return fail(err, err_cap, rc, spec->device, "unsupported baud rate");
        if (rc < 0) return fail(err, err_cap, UB_ERR_IO, spec->device, strerror(errno));
        io->fd = ub_serial_fileno(&io->serial);
        return UB_OK;
    }
    return fail(err, err_cap, UB_ERR_INVAL, "mavlink",
                "the autopilot link is udp:bind=HOST:PORT,peer=HOST:PORT, tcp:connect=HOST:PORT or serial:device=PATH[,baud=N]");
}

/* Writes what the device or the connection takes now; returns bytes written or a negative error. */
static ssize_t write_some(const ub_mavio_t *io, const uint8_t *p, size_t n) {
    int fd = io->fd;
    ssize_t w = io->kind == UB_PORT_TCP_CONNECT ? send(fd, p, n, MSG_NOSIGNAL) : write(fd, p, n);
    if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return 0;
    return w;
}

static int flush_serial(ub_mavio_t *io) {
    if (io->tx_len == 0) return UB_OK;
    ssize_t w = write_some(io, io->tx, io->tx_len);
    if (w < 0) {
        io->stats.send_errors++;
        return UB_ERR_IO;
    }
    io->stats.bytes_out += (uint64_t)w;
    memmove(io->tx, io->tx + w, io->tx_len - (size_t)w);
    io->tx_len -= (size_t)w;
    return UB_OK;
}

int ub_mavio_write(void *user, const uint8_t *bytes, size_t len) {
    ub_mavio_t *io = user;
    if (io != NULL && io->kind == UB_PORT_TCP_CONNECT && (io->fd < 0 || io->connecting)) {
        io->stats.again++; /* not connected (yet): the bridge counts it as backpressure */
        return UB_ERR_AGAIN;
    }
    if (io == NULL || io->fd < 0) return UB_ERR_CLOSED;
    if (io->kind == UB_PORT_UDP) {
        ssize_t w = sendto(io->fd, bytes, len, 0, (const struct sockaddr *)&io->peer, sizeof io->peer);
        if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
            io->stats.again++;
            return UB_ERR_AGAIN;
        }
        if (w < 0 || (size_t)w != len) {
            io->stats.send_errors++;
            return UB_ERR_IO;
        }
        io->stats.messages_out++;
        io->stats.bytes_out += len;
        return UB_OK;
    }
    /* Serial and TCP: keep order behind what waits; a message is queued whole or refused whole. */
    if (flush_serial(io) < 0) return UB_ERR_IO;
    if (io->tx_len == 0) {
        ssize_t w = write_some(io, bytes, len);
        if (w < 0) {
            io->stats.send_errors++;
            return UB_ERR_IO;
        }
        io->stats.bytes_out += (uint64_t)w;
        bytes += w;
        len -= (size_t)w;
        if (len == 0) {
            io->stats.messages_out++;
            return UB_OK;
        }
    }
    if (len > sizeof io->tx - io->tx_len) {
        io->stats.again++;
        return UB_ERR_AGAIN;
    }
    memcpy(io->tx + io->tx_len, bytes, len);
    io->tx_len += len;
    io->stats.messages_out++;
    return UB_OK;
}

static bool same_peer(const struct sockaddr_in *a, const struct sockaddr_in *b) {
    return a->sin_addr.s_addr == b->sin_addr.s_addr && a->sin_port == b->sin_port;
}

/* TCP: connects, completes a connect, flushes; a broken connection is dropped and retried.
 * @return whether the connection is up. */
static bool tcp_service(ub_mavio_t *io, uint64_t now_ms) {
    if (io->fd < 0) {
        if (now_ms < io->retry_ms || tcp_connect(io, now_ms) < 0) return false;
    }
    if (io->connecting) {
        int e = 0;
        socklen_t elen = sizeof e;
        struct pollfd pfd = {.fd = io->fd, .events = POLLOUT, .revents = 0};
        if (poll(&pfd, 1, 0) <= 0) return false; /* still in progress */
        if (getsockopt(io->fd, SOL_SOCKET, SO_ERROR, &e, &elen) < 0 || e != 0) {
            tcp_drop(io, now_ms, false);
            return false;
        }
        io->connecting = 0;
        io->stats.connects++;
    }
    if (flush_serial(io) < 0) {
        tcp_drop(io, now_ms, true);
        return false;
    }
    return true;
}

int ub_mavio_service(ub_mavio_t *io, ub_mavbridge_t *br, uint64_t now_ms) {
    if (io == NULL || br == NULL) return UB_ERR_INVAL;
    if (io->kind == UB_PORT_TCP_CONNECT && !tcp_service(io, now_ms)) return 0;
    if (io->fd < 0) return UB_ERR_INVAL;
    int accepted = 0;
    if (io->kind == UB_PORT_SERIAL && flush_serial(io) < 0) return UB_ERR_IO;
    for (int k = 0; k < UB_MAVIO_RX_BUDGET; k++) {
        ssize_t n;
        if (io->kind == UB_PORT_UDP) {
            struct sockaddr_in from;
            socklen_t flen = sizeof from;
            n = recvfrom(io->fd, io->rx, sizeof io->rx, 0, (struct sockaddr *)&from, &flen);
            if (n >= 0 && !same_peer(&from, &io->peer)) {
                io->stats.foreign++;
                continue;
            }
            if (n >= 0) io->stats.datagrams_in++;
        } else if (io->kind == UB_PORT_TCP_CONNECT) {
            n = recv(io->fd, io->rx, sizeof io->rx, 0);
            if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
                tcp_drop(io, now_ms, true); /* closed or broken: the autopilot restarts, SITL too */
                break;
            }
        } else {
            n = read(io->fd, io->rx, sizeof io->rx);
            if (n == 0) break; /* no data (VMIN 0) */
        }
        if (n < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) break;
            io->stats.read_errors++;
            return UB_ERR_IO;
        }
        io->stats.bytes_in += (uint64_t)n;
        int r = ub_mavbridge_rx(br, io->rx, (size_t)n, now_ms);
        if (r > 0) accepted += r;
    }
    return accepted;
}

void ub_mavio_pollfd(const ub_mavio_t *io, struct pollfd *pfd) {
    pfd->fd = io->fd;
    pfd->events = (short)(POLLIN | (io->tx_len > 0 || io->connecting ? POLLOUT : 0));
    pfd->revents = 0;
}

bool ub_mavio_up(const ub_mavio_t *io) { return io != NULL && io->fd >= 0 && !io->connecting; }

int ub_mavio_local_port(const ub_mavio_t *io, uint16_t *port) {
    if (io == NULL || port == NULL || io->kind != UB_PORT_UDP) return UB_ERR_INVAL;
    struct sockaddr_in local;
    socklen_t len = sizeof local;
    if (getsockname(io->fd, (struct sockaddr *)&local, &len) < 0) return UB_ERR_IO;
    *port = ntohs(local.sin_port);
    return UB_OK;
}

void ub_mavio_close(ub_mavio_t *io) {
    if (io == NULL || io->fd < 0) return;
    if (io->kind == UB_PORT_SERIAL) ub_serial_close(&io->serial);
    else close(io->fd);
    io->fd = -1;
}

/* ---- signing key file --------------------------------------------------------------------------- */

static int hexval(int c) {
    if (c >= '0' && c <= '9') return c - '0';
    c = tolower(c);
    return c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
}

int ub_mavbridge_load_key(const char *path, uint8_t key[32], char *err, size_t err_cap) {
    if (path == NULL || key == NULL) return UB_ERR_INVAL;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        if (err != NULL) snprintf(err, err_cap, "%s: cannot open the MAVLink key file: %s", path, strerror(errno));
        return UB_ERR_IO;
    }
    struct stat st;
    char text[1024];
    ssize_t n = fstat(fd, &st) == 0 ? read(fd, text, sizeof text - 1) : -1;
    int e = errno;
    close(fd);
    if (n < 0) {
        if (err != NULL) snprintf(err, err_cap, "%s: cannot read the MAVLink key file: %s", path, strerror(e));
        return UB_ERR_IO;
    }
    if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
        if (err != NULL)
            snprintf(err, err_cap, "%s:1: the MAVLink key file is accessible by group or others (chmod 600 %s)", path,
                     path);
        return UB_ERR_CONFIG;
    }
    text[n] = '\0';
    unsigned line = 0;
    char *save = NULL;
    bool found = false;
    for (char *l = strtok_r(text, "\n", &save); l != NULL; l = strtok_r(NULL, "\n", &save)) {
        line++;
        while (*l == ' ' || *l == '\t') l++;
        size_t len = strcspn(l, "\r#");
        while (len > 0 && (l[len - 1] == ' ' || l[len - 1] == '\t')) len--;
        if (len == 0) continue;
        if (found || len != 64) {
            if (err != NULL)
                snprintf(err, err_cap, "%s:%u: expected one line of 64 hex digits (the 32-byte key), e.g. the "
                                       "output of: printf %%s PASSPHRASE | sha256sum", path, line);
            return UB_ERR_CONFIG;
        }
        for (size_t i = 0; i < 32; i++) {
            int hi = hexval((unsigned char)l[2 * i]), lo = hexval((unsigned char)l[2 * i + 1]);
            if (hi < 0 || lo < 0) {
                if (err != NULL) snprintf(err, err_cap, "%s:%u: character %zu is not a hex digit", path, line, 2 * i + (hi < 0 ? 1 : 2));
                return UB_ERR_CONFIG;
            }
            key[i] = (uint8_t)(hi << 4 | lo);
        }
        found = true;
    }
    if (!found) {
        if (err != NULL) snprintf(err, err_cap, "%s:%u: no key (one line of 64 hex digits)", path, line > 0 ? line : 1);
        return UB_ERR_CONFIG;
    }
    return UB_OK;
}

/* ---- the GCS endpoint ------------------------------------------------------------------------------ */

int ub_mavgcs_open(ub_mavgcs_t *g, const ub_port_spec_t *spec, char *err, size_t cap) {
    if (g == NULL || spec == NULL) return UB_ERR_INVAL;
    memset(g, 0, sizeof *g);
    g->fd = -1;
    for (int c = 0; c < UB_MAVROUTE_MAX_CLIENTS; c++) g->clients[c].fd = -1;
    if (spec->kind == UB_PORT_SERIAL) {
        int rc = ub_serial_open(&g->ser, spec->device, spec->baud);
        if (rc == UB_ERR_RANGE) return fail(err, cap, rc, spec->device, "unsupported baud rate");
        if (rc < 0) return fail(err, cap, UB_ERR_IO, spec->device, strerror(errno));
        g->fd = ub_serial_fileno(&g->ser);
        g->serial = 1;
        g->clients[0].in_use = 1; /* the line is the ground station */
        g->stats.clients_new++;
        return UB_OK;
    }
    bool tcp = spec->kind == UB_PORT_TCP_LISTEN;
    if ((spec->kind != UB_PORT_UDP && !tcp) || (!tcp && spec->peer_port != 0))
        return fail(err, cap, UB_ERR_INVAL, "gcs",
                    "the GCS endpoint is udp:bind=HOST:PORT (ground stations are learned: no peer), tcp:listen=HOST:PORT "
                    "or serial:device=PATH[,baud=N]");
    struct sockaddr_in local;
    memset(&local, 0, sizeof local);
    local.sin_family = AF_INET;
    local.sin_port = htons(spec->port);
    if (inet_pton(AF_INET, spec->host, &local.sin_addr) != 1)
        return fail(err, cap, UB_ERR_INVAL, "gcs", "bind must be a dotted IPv4 address");
    int fd = socket(AF_INET, (tcp ? SOCK_STREAM : SOCK_DGRAM) | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) return fail(err, cap, UB_ERR_IO, "gcs socket", strerror(errno));
    int one = 1, rcvbuf = UB_MAVIO_RCVBUF;
    if (tcp) (void)setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one); /* restart while old ones linger */
    else (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    if (bind(fd, (const struct sockaddr *)&local, sizeof local) < 0 || (tcp && listen(fd, UB_MAVROUTE_MAX_CLIENTS) < 0)) {
        int e = errno;
        close(fd);
        char what[96];
        snprintf(what, sizeof what, "gcs %s %s:%u", tcp ? "tcp listen" : "udp bind", spec->host, (unsigned)spec->port);
        return fail(err, cap, UB_ERR_IO, what, strerror(e));
    }
    g->fd = fd;
    g->tcp = tcp;
    return UB_OK;
}

/* Serial: writes what waits, then as much of `bytes` as the device takes; the rest waits. A frame that does
 * not fit behind what waits is left out whole. */
static int gcs_serial_flush(ub_mavgcs_t *g) {
    if (g->tx_len == 0) return UB_OK;
    ssize_t w = write(g->fd, g->tx, g->tx_len);
    if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return UB_OK;
    if (w < 0) {
        g->stats.send_errors++;
        return UB_ERR_IO;
    }
    memmove(g->tx, g->tx + w, g->tx_len - (size_t)w);
    g->tx_len -= (size_t)w;
    return UB_OK;
}

static int gcs_serial_send(ub_mavgcs_t *g, const uint8_t *bytes, size_t len) {
    if (gcs_serial_flush(g) < 0) return UB_ERR_IO;
    if (g->tx_len == 0) {
        ssize_t w = write(g->fd, bytes, len);
        if (w < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
            g->stats.send_errors++;
            return UB_ERR_IO;
        }
        if (w > 0) {
            bytes += w;
            len -= (size_t)w;
        }
        if (len == 0) return UB_OK;
    }
    if (len > sizeof g->tx - g->tx_len) {
        g->stats.again++;
        return UB_ERR_AGAIN;
    }
    memcpy(g->tx + g->tx_len, bytes, len);
    g->tx_len += len;
    return UB_OK;
}

int ub_mavgcs_send(void *user, int client, const uint8_t *bytes, size_t len) {
    ub_mavgcs_t *g = user;
    if (g == NULL || g->fd < 0 || client < 0 || client >= UB_MAVROUTE_MAX_CLIENTS || !g->clients[client].in_use)
        return UB_ERR_INVAL;
    if (g->serial) return gcs_serial_send(g, bytes, len);
    if (g->tcp) {
        ssize_t w = send(g->clients[client].fd, bytes, len, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
            g->stats.again++; /* the whole message left out: the stream stays whole */
            return UB_ERR_AGAIN;
        }
        if (w < 0 || (size_t)w != len) {
            /* Half a frame went out: the stream is cut rather than left corrupt; the next service sees the
             * connection end (clients_closed) and the router forgets the client. */
            (void)shutdown(g->clients[client].fd, SHUT_RDWR);
            g->stats.send_errors++;
            return UB_ERR_IO;
        }
        return UB_OK;
    }
    ssize_t w = sendto(g->fd, bytes, len, 0, (const struct sockaddr *)&g->clients[client].addr, sizeof g->clients[client].addr);
    if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        g->stats.again++;
        return UB_ERR_AGAIN;
    }
    if (w < 0 || (size_t)w != len) {
        g->stats.send_errors++;
        return UB_ERR_IO;
    }
    return UB_OK;
}

static int client_of(ub_mavgcs_t *g, ub_mavroute_t *rt, const struct sockaddr_in *from, uint64_t now_ms, bool *fresh) {
    int free_slot = -1;
    *fresh = false;
    for (int c = 0; c < UB_MAVROUTE_MAX_CLIENTS; c++) {
        if (g->clients[c].in_use && same_peer(&g->clients[c].addr, from)) return c;
        if (!g->clients[c].in_use && free_slot < 0) free_slot = c;
    }
    if (free_slot < 0) {
        g->stats.clients_full++;
        return -1;
    }
    g->clients[free_slot].in_use = 1;
    g->clients[free_slot].addr = *from;
    g->clients[free_slot].last_ms = now_ms;
    ub_mavroute_client_gone(rt, free_slot); /* a fresh parser and nothing learned from a former client */
    *fresh = true;
    return free_slot;
}

static void tcp_client_gone(ub_mavgcs_t *g, ub_mavroute_t *rt, int c) {
    close(g->clients[c].fd);
    g->clients[c].fd = -1;
    g->clients[c].in_use = 0;
    g->stats.clients_closed++;
    ub_mavroute_client_gone(rt, c);
}

static int gcs_tcp_service(ub_mavgcs_t *g, ub_mavroute_t *rt, uint64_t now_ms) {
    for (;;) {
        struct sockaddr_in from;
        socklen_t flen = sizeof from;
        int fd = accept(g->fd, (struct sockaddr *)&from, &flen);
        if (fd < 0) break;
        if (fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK) < 0 || fcntl(fd, F_SETFD, FD_CLOEXEC) < 0) {
            close(fd);
            g->stats.read_errors++;
            continue;
        }
        int c = 0;
        while (c < UB_MAVROUTE_MAX_CLIENTS && g->clients[c].in_use) c++;
        if (c == UB_MAVROUTE_MAX_CLIENTS) {
            close(fd);
            g->stats.clients_full++;
            continue;
        }
        int one = 1;
        (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        g->clients[c].in_use = 1;
        g->clients[c].fd = fd;
        g->clients[c].addr = from;
        g->clients[c].last_ms = now_ms;
        ub_mavroute_client_gone(rt, c); /* a fresh parser */
        g->stats.clients_new++;
    }
    for (int c = 0; c < UB_MAVROUTE_MAX_CLIENTS; c++) {
        if (!g->clients[c].in_use) continue;
        for (int k = 0; k < UB_MAVIO_RX_BUDGET; k++) {
            ssize_t n = recv(g->clients[c].fd, g->rx, sizeof g->rx, 0);
            if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) break;
            if (n <= 0) {
                tcp_client_gone(g, rt, c);
                break;
            }
            g->stats.datagrams_in++;
            g->clients[c].last_ms = now_ms;
            if (ub_mavroute_from_client(rt, c, g->rx, (size_t)n, now_ms) < 0) return UB_ERR_INVAL; /* cannot happen */
        }
    }
    return UB_OK;
}

int ub_mavgcs_service(ub_mavgcs_t *g, ub_mavroute_t *rt, uint64_t now_ms) {
    if (g == NULL || rt == NULL || g->fd < 0) return UB_ERR_INVAL;
    if (g->tcp) return gcs_tcp_service(g, rt, now_ms);
    if (g->serial) {
        if (gcs_serial_flush(g) < 0) return UB_ERR_IO;
        for (int k = 0; k < UB_MAVIO_RX_BUDGET; k++) {
            ssize_t n = read(g->fd, g->rx, sizeof g->rx);
            if (n == 0 || (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR))) break;
            if (n < 0) {
                g->stats.read_errors++;
                return UB_ERR_IO;
            }
            g->stats.datagrams_in++;
            g->clients[0].last_ms = now_ms;
            if (ub_mavroute_from_client(rt, 0, g->rx, (size_t)n, now_ms) < 0) return UB_ERR_INVAL; /* cannot happen */
        }
        return UB_OK;
    }
    for (int k = 0; k < UB_MAVIO_RX_BUDGET; k++) {
        struct sockaddr_in from;
        socklen_t flen = sizeof from;
        ssize_t n = recvfrom(g->fd, g->rx, sizeof g->rx, 0, (struct sockaddr *)&from, &flen);
        if (n < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) break;
            g->stats.read_errors++;
            return UB_ERR_IO;
        }
        g->stats.datagrams_in++;
        bool fresh;
        int c = client_of(g, rt, &from, now_ms, &fresh);
        if (c < 0) continue;
        g->clients[c].last_ms = now_ms;
        if (ub_mavroute_from_client(rt, c, g->rx, (size_t)n, now_ms) < 0) return UB_ERR_INVAL; /* cannot happen */
        if (!ub_mavroute_client_up(rt, c)) {
            /* Nothing valid (with --gcs-key: nothing well signed) from this address yet: no place for it, so
             * that a spoofer cycling addresses cannot fill the endpoint (a datagram is whole frames). */
            g->clients[c].in_use = 0;
            g->stats.unauthenticated++;
            ub_mavroute_client_gone(rt, c);
        } else if (fresh) {
            g->stats.clients_new++;
        }
    }
    for (int c = 0; c < UB_MAVROUTE_MAX_CLIENTS; c++) {
        if (g->clients[c].in_use && now_ms - g->clients[c].last_ms > UB_MAVGCS_CLIENT_TIMEOUT_MS) {
            g->clients[c].in_use = 0;
            g->stats.clients_expired++;
            ub_mavroute_client_gone(rt, c);
        }
    }
    return UB_OK;
}

int ub_mavgcs_pollfds(const ub_mavgcs_t *g, struct pollfd *pfds, int max) {
    int n = 0;
    if (g == NULL || g->fd < 0 || max < 1) return 0;
    pfds[n++] = (struct pollfd){.fd = g->fd, .events = (short)(POLLIN | (g->tx_len > 0 ? POLLOUT : 0)), .revents = 0};
    for (int c = 0; g->tcp && c < UB_MAVROUTE_MAX_CLIENTS && n < max; c++)
        if (g->clients[c].in_use) pfds[n++] = (struct pollfd){.fd = g->clients[c].fd, .events = POLLIN, .revents = 0};
    return n;
}

int ub_mavgcs_local_port(const ub_mavgcs_t *g, uint16_t *port) {
    if (g == NULL || port == NULL || g->fd < 0 || g->serial) return UB_ERR_INVAL;
    struct sockaddr_in local;
    socklen_t len = sizeof local;
    if (getsockname(g->fd, (struct sockaddr *)&local, &len) < 0) return UB_ERR_IO;
    *port = ntohs(local.sin_port);
    return UB_OK;
}

int ub_mavgcs_clients(const ub_mavgcs_t *g) {
    int n = 0;
    for (int c = 0; g != NULL && c < UB_MAVROUTE_MAX_CLIENTS; c++) n += g->clients[c].in_use;
    return n;
}

void ub_mavgcs_close(ub_mavgcs_t *g) {
    if (g == NULL || g->fd < 0) return;
    for (int c = 0; g->tcp && c < UB_MAVROUTE_MAX_CLIENTS; c++) {
        if (g->clients[c].in_use) close(g->clients[c].fd);
        g->clients[c].in_use = 0;
    }
    if (g->serial) ub_serial_close(&g->ser);
    else close(g->fd);
    g->fd = -1;
}

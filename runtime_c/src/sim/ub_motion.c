/* The simulated vehicles' flight model (ub_motion.h). */
#include "ub/ub_motion.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#define EARTH_RADIUS_M 6378137.0
#define GRAVITY_MPS2 9.80665
#define DEG (M_PI / 180.0)

void ub_motion_default(ub_motion_t *m) {
    memset(m, 0, sizeof *m);
    m->kind = UB_MOTION_ORBIT;
    m->clockwise = true;
    m->loop = true;
    m->lat0_deg = 32.3738; /* Fort Benning range datum, 120 m MSL */
    m->lon0_deg = -84.9664;
    m->alt0_m = 120.0;
    m->radius_m = 200.0;
    m->speed_mps = 10.0;
}

/* ---- text form ---------------------------------------------------------------------------------------- */

static int fail(char *err, size_t cap, const char *what, const char *at, size_t n) {
    if (err != NULL && cap > 0) snprintf(err, cap, "motion: '%.*s': %s", (int)(n > 60 ? 60 : n), at, what);
    return UB_ERR_INVAL;
}

/* A decimal number filling exactly [v, v + n). */
static bool number(const char *v, size_t n, double *out) {
    char buf[48];
    if (n == 0 || n >= sizeof buf) return false;
    memcpy(buf, v, n);
    buf[n] = '\0';
    char *end = NULL;
    double d = strtod(buf, &end);
    if (end != buf + n || !isfinite(d)) return false;
    *out = d;
    return true;
}

/* "N/E[/U];N/E[/U];..." */
static int points(ub_motion_t *m, const char *v, size_t n, double up, char *err, size_t cap) {
    m->n_wp = 0;
    const char *p = v, *end = v + n;
    while (p < end) {
        const char *semi = memchr(p, ';', (size_t)(end - p));
        const char *stop = semi != NULL ? semi : end;
        if (m->n_wp >= UB_MOTION_MAX_WAYPOINTS) return fail(err, cap, "too many points (at most 16)", v, n);
        double c[3] = {0.0, 0.0, up};
        int k = 0;
        const char *q = p;
        while (q <= stop && k < 3) {
            const char *slash = memchr(q, '/', (size_t)(stop - q));
            const char *e = slash != NULL ? slash : stop;
            if (!number(q, (size_t)(e - q), &c[k])) return fail(err, cap, "a point is N/E or N/E/U in metres", p, (size_t)(stop - p));
            k++;
            q = e + 1;
            if (slash == NULL) break;
        }
        if (k < 2 || q <= stop) return fail(err, cap, "a point is N/E or N/E/U in metres", p, (size_t)(stop - p));
        m->wp[m->n_wp++] = (ub_motion_point_t){c[0], c[1], c[2]};
        p = stop + 1;
    }
    if (m->n_wp < 2) return fail(err, cap, "a path needs at least 2 points", v, n);
    return UB_OK;
}

int ub_motion_parse(const char *text, ub_motion_t *m, char *err, size_t err_cap) {
    if (text == NULL || m == NULL) return UB_ERR_INVAL;
    ub_motion_t o;
    ub_motion_default(&o);
    const char *colon = strchr(text, ':');
    size_t kn = colon != NULL ? (size_t)(colon - text) : strlen(text);
    if (kn == 5 && memcmp(text, "orbit", 5) == 0) o.kind = UB_MOTION_ORBIT;
    else if (kn == 9 && memcmp(text, "waypoints", 9) == 0) o.kind = UB_MOTION_WAYPOINTS;
    else if (kn == 6 && memcmp(text, "static", 6) == 0) o.kind = UB_MOTION_STATIC;
    else return fail(err, err_cap, "unknown motion (expected orbit:..., waypoints:... or static:...)", text, kn);
    const char *pts = NULL;
    size_t pts_n = 0;
    const char *s = colon != NULL ? colon + 1 : text + kn;
    while (*s != '\0') {
        /* `pts` runs to the end of its value, which contains no ','. */
        const char *comma = strchr(s, ',');
        size_t n = comma != NULL ? (size_t)(comma - s) : strlen(s);
        const char *eq = memchr(s, '=', n);
        if (eq == NULL) return fail(err, err_cap, "expected KEY=VALUE", s, n);
        size_t k = (size_t)(eq - s);
        const char *v = eq + 1;
        size_t vn = n - k - 1;
        double d = 0.0;
#define KEY(name) (k == sizeof(name) - 1 && memcmp(s, name, k) == 0)
        if (KEY("pts")) {
            pts = v;
            pts_n = vn;
        } else if (KEY("dir")) {
            if (vn == 2 && memcmp(v, "cw", 2) == 0) o.clockwise = true;
            else if (vn == 3 && memcmp(v, "ccw", 3) == 0) o.clockwise = false;
            else return fail(err, err_cap, "dir is cw or ccw", s, n);
        } else if (KEY("loop")) {
            if (vn == 1 && (*v == '0' || *v == '1')) o.loop = *v == '1';
            else return fail(err, err_cap, "loop is 0 or 1", s, n);
        } else if (!number(v, vn, &d)) {
            return fail(err, err_cap, "expected a number", s, n);
        } else if (KEY("r")) {
            o.radius_m = d;
        } else if (KEY("v")) {
            o.speed_mps = d;
        } else if (KEY("n")) {
            o.center_n_m = d;
        } else if (KEY("e")) {
            o.center_e_m = d;
        } else if (KEY("alt")) {
            o.up_m = d;
        } else if (KEY("phase")) {
            o.phase_rad = d * DEG;
        } else if (KEY("lat0")) {
            o.lat0_deg = d;
        } else if (KEY("lon0")) {
            o.lon0_deg = d;
        } else if (KEY("alt0")) {
            o.alt0_m = d;
        } else {
            return fail(err, err_cap,
                        "unknown key (r, v, n, e, alt, phase, dir for orbits; v, alt, loop, pts for waypoints; "
                        "n, e, alt for static; lat0, lon0, alt0 for any)",
                        s, n);
        }
#undef KEY
        s += n;
        if (*s == ',') s++;
    }
    if (o.kind == UB_MOTION_ORBIT && o.radius_m <= 0.0) return fail(err, err_cap, "r must be > 0 m", text, strlen(text));
    if (o.kind != UB_MOTION_STATIC && o.speed_mps <= 0.0) return fail(err, err_cap, "v must be > 0 m/s", text, strlen(text));
    if (o.kind == UB_MOTION_WAYPOINTS) {
        if (pts == NULL) return fail(err, err_cap, "waypoints need pts=N/E;N/E;...", text, strlen(text));
        int rc = points(&o, pts, pts_n, o.up_m, err, err_cap);
        if (rc != UB_OK) return rc;
    } else if (pts != NULL) {
        return fail(err, err_cap, "pts belongs to waypoints:", pts, pts_n);
    }
    *m = o;
    return UB_OK;
}

/* ---- sampling ----------------------------------------------------------------------------------------- */

/* Position, velocity (NED), turn rate and lateral acceleration (body y) of the path at t. */
typedef struct kin {
    double n, e, up, vn, ve, vd, r, lateral;
} kin_t;

static kin_t orbit(const ub_motion_t *m, double t) {
    kin_t k = {0};
    double dir = m->clockwise ? 1.0 : -1.0;
    double omega = m->speed_mps / m->radius_m;
    double a = m->phase_rad + dir * omega * t;
    k.n = m->center_n_m + m->radius_m * cos(a);
    k.e = m->center_e_m + m->radius_m * sin(a);
    k.up = m->up_m;
    k.vn = -dir * m->speed_mps * sin(a);
    k.ve = dir * m->speed_mps * cos(a);
    k.r = dir * omega;
    k.lateral = dir * m->speed_mps * omega; /* v^2 / r toward the centre: body right in a right turn */
    return k;
}

static double leg_length(const ub_motion_point_t *a, const ub_motion_point_t *b) {
    double dn = b->north_m - a->north_m, de = b->east_m - a->east_m, du = b->up_m - a->up_m;
    return sqrt(dn * dn + de * de + du * du);
}

static kin_t path(const ub_motion_t *m, double t) {
    kin_t k = {0};
    size_t legs = m->loop ? m->n_wp : (size_t)m->n_wp - 1u;
    double total = 0.0;
    for (size_t i = 0; i < legs; i++) total += leg_length(&m->wp[i], &m->wp[(i + 1) % m->n_wp]);
    double s = t * m->speed_mps;
    if (total <= 0.0 || (!m->loop && s >= total)) { /* hold at the last point */
        const ub_motion_point_t *p = &m->wp[m->n_wp - 1];
        k.n = p->north_m;
        k.e = p->east_m;
        k.up = p->up_m;
        return k;
    }
    s = fmod(s, total);
    for (size_t i = 0; i < legs; i++) {
        const ub_motion_point_t *a = &m->wp[i], *b = &m->wp[(i + 1) % m->n_wp];
        double len = leg_length(a, b);
        if (s > len && i + 1 < legs) {
            s -= len;
            continue;
        }
        double f = len > 0.0 ? s / len : 0.0;
        k.n = a->north_m + f * (b->north_m - a->north_m);
        k.e = a->east_m + f * (b->east_m - a->east_m);
        k.up = a->up_m + f * (b->up_m - a->up_m);
        if (len > 0.0) {
            k.vn = m->speed_mps * (b->north_m - a->north_m) / len;
            k.ve = m->speed_mps * (b->east_m - a->east_m) / len;
            k.vd = -m->speed_mps * (b->up_m - a->up_m) / len;
        }
        break;
    }
    return k;
}

void ub_motion_sample(const ub_motion_t *m, double t_s, ub_motion_state_t *out) {
    double t = t_s > 0.0 ? t_s : 0.0;
    kin_t k = {0};
    if (m->kind == UB_MOTION_ORBIT) k = orbit(m, t);
    else if (m->kind == UB_MOTION_WAYPOINTS && m->n_wp >= 2) k = path(m, t);
    else {
        k.n = m->center_n_m;
        k.e = m->center_e_m;
        k.up = m->up_m;
    }
    memset(out, 0, sizeof *out);
    out->north_m = k.n;
    out->east_m = k.e;
    out->up_m = k.up;
    out->lat_deg = m->lat0_deg + (k.n / EARTH_RADIUS_M) / DEG;
    out->lon_deg = m->lon0_deg + (k.e / (EARTH_RADIUS_M * cos(m->lat0_deg * DEG))) / DEG;
    out->alt_msl_m = m->alt0_m + k.up;
    out->vel_ned[0] = k.vn;
    out->vel_ned[1] = k.ve;
    out->vel_ned[2] = k.vd;
    /* A vehicle standing still keeps facing north. */
    out->heading_rad = (k.vn != 0.0 || k.ve != 0.0) ? atan2(k.ve, k.vn) : 0.0;
    /* A steady turn has constant body rates; a gentle, deterministic roll and pitch oscillation (as from
     * gusts and the pilot's corrections) gives receivers and plots values that change with time. */
    out->rates[0] = 0.20 * sin(2.0 * M_PI * 0.40 * t);
    out->rates[1] = 0.10 * sin(2.0 * M_PI * 0.25 * t + 1.0);
    out->rates[2] = k.r;
    out->specific_force[0] = 0.0;
    out->specific_force[1] = k.lateral;
    out->specific_force[2] = -GRAVITY_MPS2;
    out->attitude[0] = cos(out->heading_rad / 2.0);
    out->attitude[3] = sin(out->heading_rad / 2.0);
}

double ub_motion_distance(const ub_motion_state_t *a, const ub_motion_state_t *b) {
    double dn = a->north_m - b->north_m, de = a->east_m - b->east_m;
    return sqrt(dn * dn + de * de);
}

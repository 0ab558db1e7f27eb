/*
 * The flight model (ub_motion.h): the default orbit is uavbus_node's historic
 * circle, waypoint legs run at constant speed and loop or hold, the text
 * form parses and refuses bad input with a message naming the key.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "ub/ub_motion.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#define NEAR(a, b, tol) assert_true(fabs((a) - (b)) <= (tol))

static void test_default_orbit(void **state) {
    (void)state;
    ub_motion_t m;
    ub_motion_default(&m);
    ub_motion_state_t s;
    ub_motion_sample(&m, 0.0, &s);
    /* Due north of the centre, heading east, 10 m/s, clockwise: a right turn of v/r = 0.05 rad/s. */
    NEAR(s.north_m, 200.0, 1e-9);
    NEAR(s.east_m, 0.0, 1e-9);
    NEAR(s.vel_ned[1], 10.0, 1e-9);
    NEAR(s.heading_rad, M_PI / 2, 1e-9);
    NEAR(s.rates[2], 0.05, 1e-12);
    NEAR(s.specific_force[1], 0.5, 1e-12);
    NEAR(s.specific_force[2], -9.80665, 1e-12);
    NEAR(s.lat_deg, 32.3738 + (200.0 / 6378137.0) * 180.0 / M_PI, 1e-12);
    NEAR(s.alt_msl_m, 120.0, 1e-12);
    /* A quarter turn later: east of the centre, heading south. */
    ub_motion_sample(&m, (M_PI / 2) / 0.05, &s);
    NEAR(s.north_m, 0.0, 1e-6);
    NEAR(s.east_m, 200.0, 1e-6);
    NEAR(s.vel_ned[0], -10.0, 1e-6);
    /* The same sample every time: a pure function of time. */
    ub_motion_state_t again;
    ub_motion_sample(&m, (M_PI / 2) / 0.05, &again);
    assert_memory_equal(&s, &again, sizeof s);
}

static void test_waypoints_loop_and_hold(void **state) {
    (void)state;
    ub_motion_t m;
    char err[160];
    assert_int_equal(ub_motion_parse("waypoints:v=10,alt=30,pts=0/0;100/0;100/100", &m, err, sizeof err), 0);
    assert_int_equal(m.n_wp, 3);
    ub_motion_state_t s;
    ub_motion_sample(&m, 5.0, &s); /* halfway along the first leg, going north */
    NEAR(s.north_m, 50.0, 1e-9);
    NEAR(s.east_m, 0.0, 1e-9);
    NEAR(s.up_m, 30.0, 1e-9);
    NEAR(s.vel_ned[0], 10.0, 1e-9);
    NEAR(s.rates[2], 0.0, 0.0);
    ub_motion_sample(&m, 15.0, &s); /* second leg, going east */
    NEAR(s.north_m, 100.0, 1e-9);
    NEAR(s.east_m, 50.0, 1e-9);
    /* Loop: 100 + 100 + 141.42 m; after one lap it is back at the start. */
    double lap = (200.0 + sqrt(2.0) * 100.0) / 10.0;
    ub_motion_sample(&m, lap + 5.0, &s);
    NEAR(s.north_m, 50.0, 1e-6);
    /* Without loop it holds at the last point, standing still. */
    assert_int_equal(ub_motion_parse("waypoints:v=10,loop=0,pts=0/0/5;100/0/25", &m, err, sizeof err), 0);
    ub_motion_sample(&m, 100.0, &s);
    NEAR(s.north_m, 100.0, 1e-9);
    NEAR(s.up_m, 25.0, 1e-9);
    NEAR(s.vel_ned[0], 0.0, 0.0);
    ub_motion_sample(&m, 5.0, &s); /* climbing on the way: velocity down is negative */
    assert_true(s.vel_ned[2] < 0.0);
}

static void test_orbit_options_and_static(void **state) {
    (void)state;
    ub_motion_t m;
    char err[160];
    assert_int_equal(ub_motion_parse("orbit:r=100,v=20,n=500,e=-300,alt=50,phase=90,dir=ccw", &m, err, sizeof err), 0);
    ub_motion_state_t s;
    ub_motion_sample(&m, 0.0, &s);
    NEAR(s.north_m, 500.0, 1e-9); /* phase 90: east of the centre */
    NEAR(s.east_m, -200.0, 1e-9);
    NEAR(s.rates[2], -0.2, 1e-12); /* counter-clockwise: a left turn */
    assert_int_equal(ub_motion_parse("static:n=10,e=20,alt=2", &m, err, sizeof err), 0);
    ub_motion_sample(&m, 1000.0, &s);
    NEAR(s.north_m, 10.0, 0.0);
    NEAR(s.east_m, 20.0, 0.0);
    NEAR(ub_motion_distance(&s, &(ub_motion_state_t){.north_m = 13.0, .east_m = 24.0}), 5.0, 1e-12);
}

static void test_parse_errors(void **state) {
    (void)state;
    ub_motion_t m;
    ub_motion_default(&m);
    m.radius_m = 1234.0;
    const char *bad[] = {"spiral:r=1", "orbit:r=0", "orbit:r=abc", "orbit:rr=1", "orbit:dir=up", "waypoints:v=3",
                         "waypoints:pts=1/2", "waypoints:pts=1/2;x/3", "orbit:pts=0/0;1/1", "waypoints:v=0,pts=0/0;1/1",
                         "orbit:r", "orbit:loop=2", "orbit:r=inf", "orbit:r=", "waypoints:v=5,pts=1/2/3/4;5/6",
                         "waypoints:v=5,pts=0/0;1/1;2/2;3/3;4/4;5/5;6/6;7/7;8/8;9/9;10/10;11/11;12/12;13/13;14/14;15/15;16/16",
                         "orbit:r=1e999999", "static:n=1,e=2,q=3"};
    char err[160];
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        err[0] = '\0';
        assert_int_equal(ub_motion_parse(bad[i], &m, err, sizeof err), -1);
        assert_true(strncmp(err, "motion: '", 9) == 0);
    }
    NEAR(m.radius_m, 1234.0, 0.0); /* untouched on failure */
    assert_int_equal(ub_motion_parse(NULL, &m, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_motion_parse("orbit", NULL, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_motion_parse("spiral", &m, NULL, 0), -1); /* no room for a message: still refused */
    /* the origin keys, the loop flag and clockwise orbits */
    assert_int_equal(ub_motion_parse("orbit:r=50,v=5,dir=cw,lat0=33.5,lon0=-84.25,alt0=300", &m, err, sizeof err), 0);
    assert_true(m.clockwise);
    NEAR(m.lat0_deg, 33.5, 0.0);
    NEAR(m.lon0_deg, -84.25, 0.0);
    NEAR(m.alt0_m, 300.0, 0.0);
    assert_int_equal(ub_motion_parse("waypoints:v=5,loop=1,pts=0/0;0/0;10/0", &m, err, sizeof err), 0);
    assert_true(m.loop);
    ub_motion_state_t st;
    ub_motion_sample(&m, 1.0, &st); /* a zero-length leg first: no division by its length */
    assert_true(isfinite(st.north_m) && isfinite(st.east_m));
    assert_int_equal(ub_motion_parse("orbit", &m, err, sizeof err), 0);
    NEAR(m.radius_m, 200.0, 0.0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_orbit),
        cmocka_unit_test(test_waypoints_loop_and_hold),
        cmocka_unit_test(test_orbit_options_and_static),
        cmocka_unit_test(test_parse_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/*
 * The program shell (ub_app.h) without a node: the command line, the JSON it writes, the stdin commands.
 * The shell with a node and real ports is tested through its programs (programs_uavbus_node_smoke,
 * tests/system/test_program_protocol.py).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "ub_app.h"

static ub_app_t g_app; /* large: static, as in a program */
static char g_calls[256];
static char g_stdout[1 << 17];

static void usage(FILE *f) { fputs("usage: test\n", f); }

static bool option(ub_app_t *app, const char *opt, const char *val, int argi) {
    (void)app;
    if (strcmp(opt, "--flag") != 0 && strcmp(opt, "--opt") != 0) return false;
    size_t n = strlen(g_calls);
    snprintf(g_calls + n, sizeof g_calls - n, "%s=%s@%d;", opt, val ? val : "-", argi);
    return true;
}

static bool command(ub_app_t *app, const char *verb, char **save, uint64_t now_ms) {
    (void)app, (void)now_ms;
    if (strcmp(verb, "mine") != 0) return false;
    char *arg = strtok_r(NULL, " ", save);
    snprintf(g_calls, sizeof g_calls, "mine(%s)", arg ? arg : "");
    return true;
}

static void stats(ub_app_t *app, uint64_t now_ms, bool final) {
    (void)app, (void)now_ms;
    snprintf(g_calls, sizeof g_calls, "stats(%s)", final ? "final" : "now");
}

static const char *const k_flags[] = {"--flag", NULL};
static const ub_app_program_t k_prog = {.name = "test_prog", .usage = usage, .config_hint = "(hint)",
                                        .commands = "stats, quit, mine X", .flags = k_flags,
                                        .option = option, .command = command, .stats = stats};

/* What `fn` writes on stdout. */
static const char *captured(void (*fn)(void)) {
    fflush(stdout);
    FILE *tmp = tmpfile();
    assert_non_null(tmp);
    int saved = dup(STDOUT_FILENO);
    dup2(fileno(tmp), STDOUT_FILENO);
    fn();
    fflush(stdout);
    dup2(saved, STDOUT_FILENO);
    close(saved);
    rewind(tmp);
    size_t n = fread(g_stdout, 1, sizeof g_stdout - 1, tmp);
    g_stdout[n] = '\0';
    fclose(tmp);
    return g_stdout;
}

static void test_the_command_line_goes_to_the_shell_and_the_program(void **state) {
    (void)state;
    char *argv[] = {"prog", "--config", "c.json", "--flag", "--port", "a=udp:bind=127.0.0.1:0", "--opt", "v",
                    "--stats-ms", "5", "--node", "n", "--duration-ms", "7"};
    g_calls[0] = '\0';
    ub_app_parse(&g_app, &k_prog, (int)(sizeof argv / sizeof argv[0]), argv);
    assert_string_equal(g_app.config_path, "c.json");
    assert_string_equal(g_app.node_opt, "n");
    assert_int_equal(g_app.n_ports, 1);
    assert_string_equal(g_app.port_args[0], "a=udp:bind=127.0.0.1:0");
    assert_int_equal(g_app.port_argi[0], 5);
    assert_int_equal(g_app.stats_ms, 5);
    assert_true(g_app.has_duration);
    assert_int_equal(g_app.duration_ms, 7);
    assert_string_equal(g_calls, "--flag=-@3;--opt=v@7;");
}

static void write_strings(void) {
    ub_app_out(&g_app, "{\"s\":");
    ub_app_str(&g_app, "q\"b\\c\n\x01\xc3\xa9\xff\xed\xa0\x80z", SIZE_MAX);
    ub_app_out(&g_app, ",\"cut\":");
    ub_app_str(&g_app, "abcdef", 3);
    ub_app_out(&g_app, "}");
    ub_app_flush(&g_app);
}

static void test_strings_are_valid_json_whatever_the_bytes(void **state) {
    (void)state;
    /* quote, backslash, control characters escaped; é kept; a stray byte and a surrogate become U+FFFD */
    assert_string_equal(captured(write_strings),
                        "{\"s\":\"q\\\"b\\\\c\\u000a\\u0001\xc3\xa9\\ufffd\\ufffd\\ufffd\\ufffdz\",\"cut\":\"abc\"}\n");
}

static void write_too_much(void) {
    for (int i = 0; i < 70000; i++) ub_app_out(&g_app, "x");
    ub_app_flush(&g_app);
    ub_app_out(&g_app, "{\"after\":1}");
    ub_app_flush(&g_app);
}

static void test_an_overlong_event_becomes_an_error_event_not_a_cut_line(void **state) {
    (void)state;
    assert_string_equal(captured(write_too_much),
                        "{\"event\":\"error\",\"message\":\"test_prog: an event was longer than 65536 bytes and was "
                        "not printed\"}\n{\"after\":1}\n");
}

static void run_commands(void) {
    char lines[][40] = {"  stats  ", "mine  x1", "frob a b", "", "quit"};
    for (size_t i = 0; i < sizeof lines / sizeof lines[0]; i++) {
        ub_app_command(&g_app, lines[i], 1);
        if (i == 0) assert_string_equal(g_calls, "stats(now)");
        if (i == 1) assert_string_equal(g_calls, "mine(x1)");
    }
}

static void test_stats_and_quit_are_the_shells_the_rest_the_programs(void **state) {
    (void)state;
    g_app.stop = false;
    assert_string_equal(captured(run_commands),
                        "{\"event\":\"error\",\"message\":\"unknown command 'frob' (expected: stats, quit, mine X)\"}\n");
    assert_true(g_app.stop);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_the_command_line_goes_to_the_shell_and_the_program),
        cmocka_unit_test(test_strings_are_valid_json_whatever_the_bytes),
        cmocka_unit_test(test_an_overlong_event_becomes_an_error_event_not_a_cut_line),
        cmocka_unit_test(test_stats_and_quit_are_the_shells_the_rest_the_programs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

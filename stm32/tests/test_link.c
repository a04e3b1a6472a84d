#include "test_common.h"
#include "test_calib.h"

#include <stdio.h>
#include <string.h>

#include "link.h"
#include "link_helpers.h"

static char out[65536];
static size_t out_len;
static size_t n_applied;
static safe_reason_t last_reason;
static size_t n_safe;
static char last_detail[32];
static calib_t calib;
static player_t player;
static link_t link_;

static void capture(void *ctx, const char *text, size_t len)
{
    (void)ctx;
    if (out_len + len < sizeof out) {
        memcpy(out + out_len, text, len);
        out_len += len;
        out[out_len] = '\0';
    }
}

static bool apply(void *ctx, uint32_t row, const uint16_t codes[3])
{
    (void)ctx;
    (void)row;
    (void)codes;
    n_applied++;
    return true;
}

static void safe(void *ctx, safe_reason_t reason, uint32_t row, uint32_t applied, const char *d)
{
    (void)ctx;
    (void)row;
    (void)applied;
    last_reason = reason;
    n_safe++;
    strncpy(last_detail, d, sizeof last_detail - 1);
}

static const double k_table[2][3] = {{0.5, 0, 0}, {0, 0.5, 0}};

static int setup(void **state)
{
    (void)state;
    out_len = 0;
    out[0] = '\0';
    n_applied = 0;
    n_safe = 0;
    memset(last_detail, 0, sizeof last_detail);
    calib_init(&calib, &k_test_calib);
    const player_io_t io = {NULL, apply, safe};
    player_init(&player, &calib, &io);
    link_init(&link_, &player, capture, NULL, k_table, 2);
    return 0;
}

static void feed(const char *text)
{
    for (; *text != '\0'; ++text) {
        link_feed(&link_, (uint8_t)*text);
    }
}

static void feed_row(unsigned seq, const char *x)
{
    char line[128];
    format_row(line, sizeof line, seq, x, "0", "0");
    feed(line);
}

static void test_stream_credit_and_end(void **state)
{
    (void)state;
    feed("STREAM\r\n");
    assert_non_null(strstr(out, "OK STREAM queue=256 prefill=64\n"));
    assert_non_null(strstr(out, "CREDIT 256\n"));
    for (unsigned i = 0; i < 70; ++i) {
        feed_row(i, "1.5e-1");
    }
    assert_int_equal(player.received, 70);
    assert_int_equal(player.state, PLAYER_PLAYING);
    for (unsigned i = 0; i < LINK_CREDIT_BATCH; ++i) {
        player_tick(&player);
    }
    link_update_credit(&link_);
    assert_non_null(strstr(out, "CREDIT 272\n")); /* window grew by 16 rows */
    feed("END 70\n");
    assert_non_null(strstr(out, "OK END rows=70\n"));
    for (unsigned i = 0; i < 60; ++i) {
        player_tick(&player);
    }
    assert_int_equal(n_applied, 70);
    assert_int_equal(last_reason, SAFE_REASON_END);
}

static void test_checksum_failure(void **state)
{
    (void)state;
    char line[128];
    feed("STREAM\n");
    feed_row(0, "1");
    format_row(line, sizeof line, 1, "1", "0", "0");
    line[2] = '7'; /* corrupt a digit after the CRC was computed */
    feed(line);
    assert_int_equal(n_safe, 1);
    assert_int_equal(last_reason, SAFE_REASON_CHECKSUM);
    feed_row(2, "1"); /* ignored after the fault */
    assert_int_equal(n_safe, 1);
}

static void test_malformed_row_with_good_checksum(void **state)
{
    (void)state;
    char payload[] = "0,1,2";
    char line[64];
    snprintf(line, sizeof line, "%s*%04X\n", payload,
             crc16((const uint8_t *)payload, strlen(payload)));
    feed("STREAM\n");
    feed(line);
    assert_int_equal(last_reason, SAFE_REASON_MALFORMED);
    assert_string_equal(last_detail, "truncated");
}

static void test_missing_and_bad_checksum_field(void **state)
{
    (void)state;
    feed("STREAM\n0,1,2,3\n");
    assert_int_equal(last_reason, SAFE_REASON_MALFORMED);
    assert_string_equal(last_detail, "no-checksum");
    feed("STREAM\n0,1,2,3*12G4\n");
    assert_string_equal(last_detail, "bad-checksum-field");
}

static void test_long_line_while_streaming(void **state)
{
    (void)state;
    feed("STREAM\n");
    for (unsigned i = 0; i < 3 * CSV_MAX_LINE; ++i) {
        link_feed(&link_, '1');
    }
    feed("\n");
    assert_int_equal(last_reason, SAFE_REASON_MALFORMED);
    assert_string_equal(last_detail, "line-too-long");
}

static void test_out_of_order(void **state)
{
    (void)state;
    feed("STREAM\n");
    feed_row(0, "1");
    feed_row(0, "1");
    assert_int_equal(last_reason, SAFE_REASON_SEQUENCE);
}

static void test_idle_commands(void **state)
{
    (void)state;
    feed("PING\n");
    assert_non_null(strstr(out, "PONG\n"));
    feed("FOO\n");
    assert_non_null(strstr(out, "ERR unknown-command line=2\n"));
    assert_int_equal(n_safe, 0); /* already safe: only an ERR line */
    feed_row(0, "1");            /* rows while idle are ignored */
    assert_int_equal(player.received, 0);
    feed("PLAY\n");
    assert_non_null(strstr(out, "OK PLAY rows=2\n"));
    player_tick(&player);
    feed("STOP\n");
    assert_int_equal(last_reason, SAFE_REASON_HOST_STOP);
    assert_int_equal(n_applied, 1);
}

static void test_stream_currents_answer_and_rows(void **state)
{
    (void)state;
    feed("STREAM CURRENTS\n");
    assert_non_null(strstr(out, "OK STREAM queue=256 prefill=64 mode=currents\n"));
    assert_non_null(strstr(out, "CREDIT 256\n"));
    assert_int_equal(player.rows, PLAYER_ROWS_CURRENT_A);
    feed_row(0, "0.5");
    feed("END 1\n");
    assert_non_null(strstr(out, "OK END rows=1\n"));
    player_tick(&player);
    assert_int_equal(n_applied, 1);
    feed("STREAM\n"); /* a plain STREAM: field rows, the answer older hosts know */
    assert_non_null(strstr(out, "OK STREAM queue=256 prefill=64\nCREDIT 256\n"));
    assert_int_equal(player.rows, PLAYER_ROWS_FIELD_MT);
}

static void test_stream_unknown_mode_refused(void **state)
{
    (void)state;
    feed("STREAM AMPS\n");
    assert_non_null(strstr(out, "ERR unknown-stream-mode line=1\n"));
    assert_null(strstr(out, "OK STREAM"));
    assert_int_equal(player.state, PLAYER_SAFE);
    feed("STREAMCURRENTS\n");
    assert_non_null(strstr(out, "ERR unknown-command line=2\n"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_stream_credit_and_end, setup),
        cmocka_unit_test_setup(test_checksum_failure, setup),
        cmocka_unit_test_setup(test_malformed_row_with_good_checksum, setup),
        cmocka_unit_test_setup(test_missing_and_bad_checksum_field, setup),
        cmocka_unit_test_setup(test_long_line_while_streaming, setup),
        cmocka_unit_test_setup(test_out_of_order, setup),
        cmocka_unit_test_setup(test_idle_commands, setup),
        cmocka_unit_test_setup(test_stream_currents_answer_and_rows, setup),
        cmocka_unit_test_setup(test_stream_unknown_mode_refused, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

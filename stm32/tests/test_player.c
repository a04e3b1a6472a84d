#include "test_common.h"
#include "test_calib.h"

#include <string.h>

#include "player.h"

#define MAX_APPLIED 1024u

typedef struct {
    uint32_t rows[MAX_APPLIED];
    uint16_t codes[MAX_APPLIED][3];
    size_t n;
    size_t n_safe;
    safe_reason_t reason;
    uint32_t row;
    uint32_t applied;
    char detail[32];
    bool fail_apply;
} record_t;

static record_t rec;
static calib_t calib;
static player_t player;

static bool apply(void *ctx, uint32_t row, const uint16_t codes[3])
{
    (void)ctx;
    if (rec.fail_apply) {
        return false;
    }
    rec.rows[rec.n] = row;
    memcpy(rec.codes[rec.n], codes, sizeof rec.codes[0]);
    rec.n++;
    return true;
}

static void safe(void *ctx, safe_reason_t reason, uint32_t row, uint32_t applied, const char *d)
{
    (void)ctx;
    rec.n_safe++;
    rec.reason = reason;
    rec.row = row;
    rec.applied = applied;
    strncpy(rec.detail, d, sizeof rec.detail - 1);
}

static int setup(void **state)
{
    (void)state;
    memset(&rec, 0, sizeof rec);
    assert_int_equal(calib_init(&calib, &k_test_calib), CALIB_OK);
    const player_io_t io = {NULL, apply, safe};
    player_init(&player, &calib, &io);
    return 0;
}

static void push(uint32_t seq, double x)
{
    const double mT[3] = {x, 0, 0};
    player_push(&player, seq, mT);
}

static void test_boot_is_safe_and_ticks_do_nothing(void **state)
{
    (void)state;
    assert_int_equal(player.state, PLAYER_SAFE);
    assert_int_equal(player.reason, SAFE_REASON_BOOT);
    player_tick(&player);
    assert_int_equal(rec.n, 0);
}

static void test_stream_prefill_play_end(void **state)
{
    (void)state;
    player_start_stream(&player, PLAYER_ROWS_FIELD_MT);
    for (uint32_t i = 0; i < PLAYER_PREFILL_ROWS - 1; ++i) {
        push(i, 1.0);
    }
    player_tick(&player); /* still prefilling: no output, no underrun */
    assert_int_equal(rec.n, 0);
    assert_int_equal(player.state, PLAYER_PREFILL);
    push(PLAYER_PREFILL_ROWS - 1, 1.0);
    assert_int_equal(player.state, PLAYER_PLAYING);
    player_end(&player, PLAYER_PREFILL_ROWS);
    for (uint32_t i = 0; i < PLAYER_PREFILL_ROWS; ++i) {
        player_tick(&player);
    }
    assert_int_equal(rec.n, PLAYER_PREFILL_ROWS);
    assert_int_equal(rec.rows[5], 5);
    assert_int_equal(rec.codes[0][0], 32768 + 6553);
    assert_int_equal(rec.n_safe, 0);
    player_tick(&player); /* the last row held for its 10 ms, then mid-scale */
    assert_int_equal(rec.n_safe, 1);
    assert_int_equal(rec.reason, SAFE_REASON_END);
    assert_int_equal(rec.applied, PLAYER_PREFILL_ROWS);
    assert_int_equal(player.state, PLAYER_SAFE);
}

static void test_short_stream_plays_on_end(void **state)
{
    (void)state;
    player_start_stream(&player, PLAYER_ROWS_FIELD_MT);
    push(0, 1.0);
    push(1, 2.0);
    player_end(&player, 2);
    player_tick(&player);
    player_tick(&player);
    player_tick(&player);
    assert_int_equal(rec.n, 2);
    assert_int_equal(rec.reason, SAFE_REASON_END);
}

static void test_underrun(void **state)
{
    (void)state;
    player_start_stream(&player, PLAYER_ROWS_FIELD_MT);
    for (uint32_t i = 0; i < PLAYER_PREFILL_ROWS; ++i) {
        push(i, 0.5);
    }
    for (uint32_t i = 0; i <= PLAYER_PREFILL_ROWS; ++i) {
        player_tick(&player);
    }
    assert_int_equal(rec.reason, SAFE_REASON_UNDERRUN);
    assert_int_equal(rec.row, PLAYER_PREFILL_ROWS);
    assert_string_equal(rec.detail, "queue-empty");
}

static void test_out_of_order_and_rows_after_fault(void **state)
{
    (void)state;
    player_start_stream(&player, PLAYER_ROWS_FIELD_MT);
    push(0, 1.0);
    push(2, 1.0);
    assert_int_equal(rec.n_safe, 1);
    assert_int_equal(rec.reason, SAFE_REASON_SEQUENCE);
    assert_int_equal(rec.row, 1); /* the row that was expected */
    push(1, 1.0);                 /* in flight after the fault: ignored */
    player_tick(&player);
    assert_int_equal(rec.n_safe, 1);
    assert_int_equal(rec.n, 0);
}

static void test_overflow_when_credit_ignored(void **state)
{
    (void)state;
    player_start_stream(&player, PLAYER_ROWS_FIELD_MT);
    for (uint32_t i = 0; i < PLAYER_QUEUE_ROWS; ++i) {
        push(i, 0.1);
    }
    assert_int_equal(rec.n_safe, 0);
    push(PLAYER_QUEUE_ROWS, 0.1);
    assert_int_equal(rec.reason, SAFE_REASON_OVERFLOW);
}

static void test_end_count_mismatch(void **state)
{
    (void)state;
    player_start_stream(&player, PLAYER_ROWS_FIELD_MT);
    push(0, 1.0);
    player_end(&player, 5);
    assert_int_equal(rec.reason, SAFE_REASON_SEQUENCE);
    assert_string_equal(rec.detail, "end-count");
}

static void test_table_playback(void **state)
{
    (void)state;
    static const double table[3][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 0, 0}};
    player_start_table(&player, table, 3);
    for (int i = 0; i < 4; ++i) {
        player_tick(&player);
    }
    assert_int_equal(rec.n, 3);
    assert_int_equal(rec.codes[1][0], 32768 - 6553);
    assert_int_equal(rec.reason, SAFE_REASON_END);
}

static void test_dac_fault(void **state)
{
    (void)state;
    static const double table[1][3] = {{1, 0, 0}};
    rec.fail_apply = true;
    player_start_table(&player, table, 1);
    player_tick(&player);
    assert_int_equal(rec.reason, SAFE_REASON_DAC_FAULT);
}

static void test_invalid_calibration_refuses(void **state)
{
    (void)state;
    calib.valid = false;
    player_start_stream(&player, PLAYER_ROWS_FIELD_MT);
    assert_int_equal(player.state, PLAYER_SAFE);
    assert_int_equal(rec.reason, SAFE_REASON_CALIBRATION);
}

static void test_reason_names(void **state)
{
    (void)state;
    assert_string_equal(safe_reason_name(SAFE_REASON_CHECKSUM), "checksum");
    assert_string_equal(safe_reason_name(SAFE_REASON_WATCHDOG), "watchdog-reset");
    assert_string_equal(safe_reason_name(SAFE_REASON_COUNT), "unknown");
    for (int r = 0; r < SAFE_REASON_COUNT; ++r) {
        assert_non_null(safe_reason_name((safe_reason_t)r));
    }
}

static void test_current_stream_plays_amperes(void **state)
{
    (void)state;
    player_start_stream(&player, PLAYER_ROWS_CURRENT_A);
    push(0, 0.5); /* 0.5 A = 0.5 V -> 6553 (as a field, 0.5 mT would be 0.25 A -> 3277) */
    player_end(&player, 1);
    player_tick(&player);
    assert_int_equal(rec.n, 1);
    assert_int_equal(rec.codes[0][0], 32768 + 6553);
    player_start_stream(&player, PLAYER_ROWS_FIELD_MT); /* the next plain stream is a field again */
    push(0, 0.5);
    player_end(&player, 1);
    player_tick(&player);
    assert_int_equal(rec.codes[1][0], 32768 + 3277);
}

static void test_table_after_current_stream_is_a_field(void **state)
{
    (void)state;
    static const double table[1][3] = {{1, 0, 0}};
    player_start_stream(&player, PLAYER_ROWS_CURRENT_A);
    player_fault(&player, SAFE_REASON_HOST_STOP, 0, "");
    player_start_table(&player, table, 1);
    player_tick(&player);
    assert_int_equal(rec.codes[0][0], 32768 + 6553); /* 1 mT = 0.5 A, not 1 A */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_boot_is_safe_and_ticks_do_nothing, setup),
        cmocka_unit_test_setup(test_stream_prefill_play_end, setup),
        cmocka_unit_test_setup(test_short_stream_plays_on_end, setup),
        cmocka_unit_test_setup(test_underrun, setup),
        cmocka_unit_test_setup(test_out_of_order_and_rows_after_fault, setup),
        cmocka_unit_test_setup(test_overflow_when_credit_ignored, setup),
        cmocka_unit_test_setup(test_end_count_mismatch, setup),
        cmocka_unit_test_setup(test_table_playback, setup),
        cmocka_unit_test_setup(test_dac_fault, setup),
        cmocka_unit_test_setup(test_invalid_calibration_refuses, setup),
        cmocka_unit_test_setup(test_reason_names, setup),
        cmocka_unit_test_setup(test_current_stream_plays_amperes, setup),
        cmocka_unit_test_setup(test_table_after_current_stream_is_a_field, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

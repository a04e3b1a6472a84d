/* Every safe-state reason, driven through the whole application on the fake board, must end
 * with the same physical sequence: CLR, mid-scale written to x, y and z (chip 1 A and B, chip 2
 * A; chip 2 B is not wired), then one LDAC, and nothing after it. When SPI fails, the sequence
 * is CLR alone and the report says so ("clr-only"). Checking the SAFE text alone would let a
 * reason that forgets the DAC writes pass. */
#include "test_common.h"
#include "test_calib.h"

#include <stdio.h>
#include <string.h>

#include "app.h"
#include "dac8563.h"
#include "fake_board.h"
#include "link_helpers.h"
#include "player.h"

static const double k_table[2][3] = {{1, -1, 0.5}, {0.5, 0.5, -0.5}};
static const board_info_t k_normal = {true, false, false, 84000000u};

/* The safe sequence's frames: write input register, mid-scale, per axis (chip, frame). */
static const struct {
    unsigned chip;
    uint32_t frame;
} k_midscale[DAC_BANK_AXES] = {{0u, 0x008000u}, {0u, 0x018000u}, {1u, 0x008000u}};
#define SAFE_SEQUENCE_EVENTS (2u + DAC_BANK_AXES)

static void boot_with(board_info_t info, const calib_params_t *params)
{
    fake_reset();
    app_config_t cfg = {"test", params, k_table, 2};
    app_init(&cfg, &info);
}

static void boot(void) { boot_with(k_normal, &k_test_calib); }

/* Feed everything queued on the fake UART, a poll at a time (256 bytes each). */
static void poll_all(void)
{
    while (fake.rx_pos < fake.rx_len) {
        app_poll();
    }
    app_poll();
}

static void send_rows(unsigned first, unsigned count, double x)
{
    char line[128];
    char value[32];
    snprintf(value, sizeof value, "%.3f", x);
    for (unsigned i = first; i < first + count; ++i) {
        format_row(line, sizeof line, i, value, "0", "-0.25");
        fake_rx_text(line);
    }
}

static void stream_playing(unsigned rows)
{
    fake_rx_text("STREAM\n");
    send_rows(0, rows, 1.0);
    poll_all();
    fake.ticks_pending = 2; /* two rows out: the coils carry current */
    app_poll();
    assert_int_equal(fake_uart_count("DAC 1 "), 1);
}

/* The events end with CLR, mid-scale on x, y, z and LDAC; the DAC report and the SAFE line name
 * @p reason; further ticks and rows change nothing. */
static void assert_ends_safe(const char *reason)
{
    assert_true(fake.n_events >= SAFE_SEQUENCE_EVENTS);
    size_t i = fake.n_events - SAFE_SEQUENCE_EVENTS;
    assert_int_equal(fake.events[i++].kind, FAKE_EV_CLR);
    for (unsigned axis = 0; axis < DAC_BANK_AXES; ++axis, ++i) {
        assert_int_equal(fake.events[i].kind, FAKE_EV_SPI);
        assert_int_equal(fake.events[i].chip, k_midscale[axis].chip);
        assert_int_equal(fake.events[i].frame, k_midscale[axis].frame);
    }
    assert_int_equal(fake.events[i].kind, FAKE_EV_LDAC);

    char prefix[48];
    snprintf(prefix, sizeof prefix, "SAFE %s ", reason);
    assert_int_equal(fake_uart_count("SAFE "), 1);
    const char *safe = fake_uart_find(prefix, 0);
    if (safe == NULL) {
        fail_msg("no '%s' line in:\n%s", prefix, fake.uart);
    }
    const char *dac_safe = fake_uart_find("DAC safe 32768 32768 32768", 0);
    assert_non_null(dac_safe);
    assert_true(dac_safe < safe); /* the outputs are at 0 A before the host hears why */
    assert_null(strstr(safe, "clr-only"));

    size_t events = fake.n_events;
    send_rows(0, 3, 2.0); /* rows still in flight after the fault */
    fake.ticks_pending = 5;
    poll_all();
    assert_int_equal(fake.n_events, events);
}

/* SPI is down: only the CLR pulse reaches the chips, no LDAC, and the report says clr-only. */
static void assert_ends_clr_only(const char *reason, size_t events_before)
{
    assert_true(fake.n_events > events_before);
    assert_int_equal(fake.events[fake.n_events - 1].kind, FAKE_EV_CLR);
    for (size_t i = events_before; i < fake.n_events - 1; ++i) {
        assert_int_not_equal(fake.events[i].kind, FAKE_EV_LDAC);
        assert_int_not_equal(fake.events[i].kind, FAKE_EV_SPI);
    }
    char prefix[48];
    snprintf(prefix, sizeof prefix, "SAFE %s ", reason);
    const char *safe = fake_uart_find(prefix, 0);
    if (safe == NULL) {
        fail_msg("no '%s' line in:\n%s", prefix, fake.uart);
    }
    size_t len = strcspn(safe, "\n");
    const char *tag = strstr(safe, " dac=spi-timeout-clr-only");
    assert_true(tag != NULL && tag < safe + len);
    assert_int_equal(fake_uart_count("DAC safe"), 0); /* no mid-scale write was confirmed */
}

static void test_boot_initialises_at_midscale(void **state)
{
    (void)state;
    boot();
    /* boot is not reported (nothing played yet) but leaves the same sequence */
    size_t i = fake.n_events - SAFE_SEQUENCE_EVENTS;
    assert_int_equal(fake.events[i].kind, FAKE_EV_CLR);
    assert_int_equal(fake.events[i + 1].frame, 0x008000u);
    assert_int_equal(fake.events[i + 2].frame, 0x018000u);
    assert_int_equal(fake.events[i + 3].chip, 1u);
    assert_int_equal(fake.events[i + 3].frame, 0x008000u);
    assert_int_equal(fake.events[i + 4].kind, FAKE_EV_LDAC);
    assert_int_equal(fake_uart_count("SAFE "), 0);
}

static void test_end_of_stream(void **state)
{
    (void)state;
    boot();
    stream_playing(70);
    fake_rx_text("END 70\n");
    poll_all();
    fake.ticks_pending = 69; /* the 68 rows left, then the end */
    app_poll();
    assert_non_null(fake_uart_find("DAC 69 ", 0));
    assert_ends_safe("end");
}

static void test_end_of_table(void **state)
{
    (void)state;
    boot();
    fake_rx_text("PLAY\n");
    poll_all();
    fake.ticks_pending = 3;
    app_poll();
    assert_int_equal(fake_uart_count("DAC 1 "), 1);
    assert_ends_safe("end");
}

static void test_malformed_row(void **state)
{
    (void)state;
    boot();
    stream_playing(70);
    fake_rx_text("70,1,0,0\n"); /* no checksum */
    poll_all();
    assert_ends_safe("malformed");
}

static void test_sequence(void **state)
{
    (void)state;
    boot();
    stream_playing(70);
    send_rows(71, 1, 1.0); /* row 70 skipped */
    poll_all();
    assert_ends_safe("sequence");
}

static void test_checksum(void **state)
{
    (void)state;
    boot();
    stream_playing(70);
    char line[128];
    format_row(line, sizeof line, 70, "1.000", "0", "-0.25");
    line[3] = '9'; /* a digit changed after the checksum was computed */
    fake_rx_text(line);
    poll_all();
    assert_ends_safe("checksum");
}

static void test_underrun(void **state)
{
    (void)state;
    boot();
    stream_playing(PLAYER_PREFILL_ROWS);
    fake.ticks_pending = PLAYER_PREFILL_ROWS; /* two more than queued are left */
    app_poll();
    assert_ends_safe("underrun");
}

static void test_overflow(void **state)
{
    (void)state;
    boot();
    fake_rx_text("STREAM\n");
    send_rows(0, PLAYER_QUEUE_ROWS + 1, 1.0); /* past the credit, no tick in between */
    poll_all();
    assert_ends_safe("overflow");
}

static void test_watchdog_reset(void **state)
{
    (void)state;
    board_info_t info = k_normal;
    info.watchdog_reset = true;
    boot_with(info, &k_test_calib);
    assert_ends_safe("watchdog-reset");
}

static void test_host_stop(void **state)
{
    (void)state;
    boot();
    stream_playing(70);
    fake_rx_text("STOP\n");
    poll_all();
    assert_ends_safe("host-stop");
}

static void test_calibration(void **state)
{
    (void)state;
    calib_params_t bad = k_test_calib;
    bad.actuation_T_per_A[2][2] = 0;
    boot_with(k_normal, &bad);
    assert_ends_safe("calibration");
}

static void test_uart_lost(void **state)
{
    (void)state;
    boot();
    stream_playing(70);
    fake.lost = 1;
    app_poll();
    assert_ends_safe("uart-lost");
}

static void test_dac_fault_while_playing_is_clr_only(void **state)
{
    (void)state;
    boot();
    stream_playing(70);
    size_t before = fake.n_events;
    fake.spi_fails = true;
    fake.ticks_pending = 1;
    app_poll();
    assert_ends_clr_only("dac-fault", before);
    assert_non_null(fake_uart_find("SAFE dac-fault row=2 applied=2 detail=spi-timeout dac=", 0));
}

static void test_dac_fault_at_boot_is_clr_only(void **state)
{
    (void)state;
    fake_reset();
    fake.spi_fails = true;
    app_config_t cfg = {"test", &k_test_calib, k_table, 2};
    app_init(&cfg, &k_normal);
    assert_ends_clr_only("dac-fault", 0);
    assert_int_equal(fake.n_events, 2); /* dac_bank_init's CLR, then the fault's */
}

/* Whatever the reason, a dead SPI bus degrades the safe state to CLR alone, and says so. */
static void test_any_reason_with_spi_down_is_clr_only(void **state)
{
    (void)state;
    boot();
    stream_playing(70);
    size_t before = fake.n_events;
    fake.spi_fails = true;
    fake_rx_text("STOP\n");
    poll_all();
    assert_ends_clr_only("host-stop", before);
}

/* Every reason except boot has a test above: a new reason must add one. */
static void test_every_reason_is_covered(void **state)
{
    (void)state;
    static const char *const covered[] = {"end", "malformed", "sequence", "checksum", "underrun",
                                          "overflow", "watchdog-reset", "host-stop", "calibration",
                                          "dac-fault", "uart-lost"};
    assert_int_equal(SAFE_REASON_COUNT, 1 + sizeof covered / sizeof covered[0]);
    for (int r = SAFE_REASON_BOOT + 1; r < SAFE_REASON_COUNT; ++r) {
        bool found = false;
        for (size_t k = 0; k < sizeof covered / sizeof covered[0]; ++k) {
            found = found || strcmp(covered[k], safe_reason_name((safe_reason_t)r)) == 0;
        }
        if (!found) {
            fail_msg("safe reason '%s' has no test", safe_reason_name((safe_reason_t)r));
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_boot_initialises_at_midscale),
        cmocka_unit_test(test_end_of_stream),
        cmocka_unit_test(test_end_of_table),
        cmocka_unit_test(test_malformed_row),
        cmocka_unit_test(test_sequence),
        cmocka_unit_test(test_checksum),
        cmocka_unit_test(test_underrun),
        cmocka_unit_test(test_overflow),
        cmocka_unit_test(test_watchdog_reset),
        cmocka_unit_test(test_host_stop),
        cmocka_unit_test(test_calibration),
        cmocka_unit_test(test_uart_lost),
        cmocka_unit_test(test_dac_fault_while_playing_is_clr_only),
        cmocka_unit_test(test_dac_fault_at_boot_is_clr_only),
        cmocka_unit_test(test_any_reason_with_spi_down_is_clr_only),
        cmocka_unit_test(test_every_reason_is_covered),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

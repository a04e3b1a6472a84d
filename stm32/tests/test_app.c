/* The whole application over the fake board: what QEMU runs, minus the registers. */
#include "test_common.h"
#include "test_calib.h"

#include <stdio.h>
#include <string.h>

#include "app.h"
#include "dac8563.h"
#include "fake_board.h"
#include "link_helpers.h"

static const double k_table[1][3] = {{1, -1, 0}};

static void boot(board_info_t info, const calib_params_t *params)
{
    fake_reset();
    fake_flash_blank();
    app_config_t cfg = {"test", params, k_table, 1};
    app_init(&cfg, &info);
}

/* The UART line starting with @p prefix equals @p expected (without its LF). */
static void assert_line(const char *prefix, const char *expected)
{
    const char *line = fake_uart_find(prefix, 0);
    assert_non_null(line);
    size_t n = strcspn(line, "\n");
    if (n != strlen(expected) || strncmp(line, expected, n) != 0) {
        fail_msg("line '%.*s' != '%s'", (int)n, line, expected);
    }
}

static const board_info_t k_normal = {true, false, false, 84000000u};

static void test_boot_banner_and_midscale(void **state)
{
    (void)state;
    boot(k_normal, &k_test_calib);
    assert_non_null(fake_uart_find("MSR-FW 1.0 board=stm32f407 clock=pll calibration=test", 0));
    assert_non_null(fake_uart_find("READY", 0));
    assert_int_equal(fake_uart_count("SAFE"), 0);
    /* last DAC action of the init: LDAC after mid-scale writes */
    assert_int_equal(fake.events[fake.n_events - 1].kind, FAKE_EV_LDAC);
    assert_int_equal(fake.events[fake.n_events - 2].frame, 0x008000);
}

static void test_stream_reports_codes_and_ends_safe(void **state)
{
    (void)state;
    boot(k_normal, &k_test_calib);
    char line[128];
    fake_rx_text("STREAM\n");
    for (unsigned i = 0; i < 3; ++i) {
        format_row(line, sizeof line, i, i == 1 ? "1" : "0.5", "-1", "2e-1");
        fake_rx_text(line);
    }
    fake_rx_text("END 3\n");
    app_poll();
    size_t before = fake.n_events;
    fake.ticks_pending = 5;
    app_poll();
    assert_line("DAC 0 ", "DAC 0 36045 26215 34079");
    assert_line("DAC 1 ", "DAC 1 39321 26215 34079");
    assert_non_null(fake_uart_find("DAC safe 32768 32768 32768", 0));
    assert_non_null(fake_uart_find("SAFE end row=3 applied=3", 0));
    /* the physical last action is mid-scale + LDAC */
    assert_int_equal(fake.events[fake.n_events - 1].kind, FAKE_EV_LDAC);
    assert_int_equal(fake.events[fake.n_events - 2].frame, 0x008000);
    assert_true(fake.n_events > before);
    assert_true(fake.watchdog_kicks >= 2);
}

static void test_corrupted_row_reports_reason(void **state)
{
    (void)state;
    boot(k_normal, &k_test_calib);
    char line[128];
    fake_rx_text("STREAM\n");
    format_row(line, sizeof line, 0, "1", "0", "0");
    fake_rx_text(line);
    format_row(line, sizeof line, 1, "1", "0", "0");
    line[3] = '9';
    fake_rx_text(line);
    app_poll();
    assert_non_null(fake_uart_find("SAFE checksum row=1 applied=0 detail=crc-mismatch", 0));
    assert_int_equal(fake.events[fake.n_events - 1].kind, FAKE_EV_LDAC);
}

static void test_watchdog_reset_reported(void **state)
{
    (void)state;
    board_info_t info = k_normal;
    info.watchdog_reset = true;
    boot(info, &k_test_calib);
    assert_non_null(fake_uart_find("SAFE watchdog-reset", 0));
}

static void test_uart_loss_while_streaming(void **state)
{
    (void)state;
    boot(k_normal, &k_test_calib);
    fake_rx_text("STREAM\n");
    app_poll();
    fake.lost = 3;
    app_poll();
    assert_non_null(fake_uart_find("SAFE uart-lost", 0));
}

static void test_bad_calibration_and_dac_fault_at_boot(void **state)
{
    (void)state;
    calib_params_t bad = k_test_calib;
    bad.actuation_T_per_A[1][1] = 0;
    boot(k_normal, &bad);
    assert_non_null(fake_uart_find("SAFE calibration row=0 applied=0 detail=singular", 0));
    fake_rx_text("STREAM\n");
    app_poll();
    assert_int_equal(fake_uart_count("OK STREAM"), 0);

    fake_reset();
    fake.spi_fails = true;
    app_config_t cfg = {"test", &k_test_calib, k_table, 1};
    app_init(&cfg, &k_normal);
    assert_non_null(fake_uart_find("SAFE dac-fault", 0));
}

static void test_status_upload_refusal_and_reset(void **state)
{
    (void)state;
    boot(k_normal, &k_test_calib);
    /* k_test_calib named "test": hash computed by the host (protocol.calibration_hash) */
    assert_line("MSR-FW", "MSR-FW 1.0 board=stm32f407 clock=pll calibration=test hash=c3b045e6 "
                          "source=compiled table_rows=1 tick_hz=100");
    fake_rx_text("STATUS\n");
    app_poll();
    assert_line("STATUS", "STATUS state=safe calibration=test hash=c3b045e6 source=compiled");
    fake_rx_text("CAL COMMIT 00000000\n");
    app_poll();
    assert_line("ERR cal-refused", "ERR cal-refused reason=no-begin");
    fake_rx_text("RESET\n");
    app_poll();
    assert_line("OK RESET", "OK RESET");
    assert_int_equal(fake_flash.resets, 1);
    assert_line("SAFE", "SAFE host-stop row=0 applied=0 detail=reset");
}

static void test_flash_table(void **state)
{
    (void)state;
    boot(k_normal, &k_test_calib);
    fake_rx_text("PLAY\n");
    app_poll();
    fake.ticks_pending = 2;
    app_poll();
    assert_non_null(fake_uart_find("DAC 0 39321 26215 32768", 0));
    assert_non_null(fake_uart_find("SAFE end row=1 applied=1", 0));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_boot_banner_and_midscale),
        cmocka_unit_test(test_stream_reports_codes_and_ends_safe),
        cmocka_unit_test(test_corrupted_row_reports_reason),
        cmocka_unit_test(test_watchdog_reset_reported),
        cmocka_unit_test(test_uart_loss_while_streaming),
        cmocka_unit_test(test_bad_calibration_and_dac_fault_at_boot),
        cmocka_unit_test(test_flash_table),
        cmocka_unit_test(test_status_upload_refusal_and_reset),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

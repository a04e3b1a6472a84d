#include "app.h"

#include "calib_active.h"
#include "dac8563.h"
#include "link.h"
#include "msg.h"
#include "player.h"
#include "scheduler.h"

static calib_t g_calib;
static calib_active_t g_active;
static player_t g_player;
static link_t g_link;
static uint32_t g_uart_lost;

static void send_line(msg_t *msg)
{
    msg_end(msg);
    board_uart_write(msg->text, msg->len);
}

static void uart_send(void *ctx, const char *text, size_t len)
{
    (void)ctx;
    board_uart_write(text, len);
}

static void report_codes(const char *row_label, uint32_t row, const uint16_t codes[CALIB_AXES])
{
#if APP_REPORT_DAC_CODES
    msg_t msg;
    msg_begin(&msg, "DAC ");
    if (row_label != 0) {
        msg_str(&msg, row_label);
    } else {
        msg_u32(&msg, row);
    }
    for (unsigned axis = 0; axis < CALIB_AXES; ++axis) {
        msg_str(&msg, " ");
        msg_u32(&msg, codes[axis]);
    }
    send_line(&msg);
#else
    (void)row_label;
    (void)row;
    (void)codes;
#endif
}

static bool apply_codes(void *ctx, uint32_t row, const uint16_t codes[CALIB_AXES])
{
    (void)ctx;
    bool ok = dac_bank_write(codes);
    if (ok) {
        report_codes(0, row, codes);
    }
    return ok;
}

static void go_safe(void *ctx, safe_reason_t reason, uint32_t row, uint32_t applied,
                    const char *detail)
{
    static const uint16_t mid[CALIB_AXES] = {DAC8563_MIDSCALE, DAC8563_MIDSCALE,
                                            DAC8563_MIDSCALE};
    (void)ctx;
    bool ok = dac_bank_safe();
    if (ok) {
        report_codes("safe", 0, mid);
    }
    msg_t msg;
    msg_begin(&msg, "SAFE ");
    msg_str(&msg, safe_reason_name(reason));
    msg_kv_u32(&msg, "row", row);
    msg_kv_u32(&msg, "applied", applied);
    if (detail != 0 && detail[0] != '\0') {
        msg_kv_str(&msg, "detail", detail);
    }
    if (!ok) {
        msg_kv_str(&msg, "dac", "spi-timeout-clr-only");
    }
    send_line(&msg);
}

static void compiled_calibration(const app_config_t *config, calib_named_t *out)
{
    out->params = *config->calibration;
    unsigned i = 0;
    for (; i + 1u < CALIB_NAME_BYTES && config->calibration_name[i] != '\0'; ++i) {
        out->name[i] = config->calibration_name[i];
    }
    for (; i < CALIB_NAME_BYTES; ++i) {
        out->name[i] = '\0';
    }
}

void app_init(const app_config_t *config, const board_info_t *info)
{
    static const player_io_t io = {0, apply_codes, go_safe};
    calib_named_t compiled;
    compiled_calibration(config, &compiled);
    calib_status_t cst = calib_active_init(&g_active, &g_calib, &compiled);

    msg_t msg;
    msg_begin(&msg, "MSR-FW " APP_FIRMWARE_VERSION " board=stm32f407");
    msg_kv_str(&msg, "clock", info->emulated ? "emulated" : (info->pll_locked ? "pll" : "hsi"));
    msg_kv_str(&msg, "calibration", g_active.current.name);
    msg_kv_hex32(&msg, "hash", g_active.hash);
    msg_kv_str(&msg, "source", calib_source_name(g_active.source));
    msg_kv_u32(&msg, "table_rows", config->table_rows);
    msg_kv_u32(&msg, "tick_hz", SCHED_TICK_HZ);
    send_line(&msg);

    player_init(&g_player, &g_calib, &io);
    link_init(&g_link, &g_player, uart_send, 0, config->table, config->table_rows);
    link_set_calibration(&g_link, &g_active);
    g_uart_lost = board_uart_lost();

    if (!dac_bank_init()) {
        player_fault(&g_player, SAFE_REASON_DAC_FAULT, 0, "init");
    }
    if (cst != CALIB_OK) {
        player_fault(&g_player, SAFE_REASON_CALIBRATION, 0, calib_status_name(cst));
    }
    if (info->watchdog_reset) {
        player_fault(&g_player, SAFE_REASON_WATCHDOG, 0, "");
    }
    if (!board_tick_start(SCHED_TICK_HZ)) {
        msg_begin(&msg, "ERR tick-timer");
        msg_kv_u32(&msg, "clock_hz", board_timer_clock_hz());
        send_line(&msg);
    }
    board_watchdog_start();
    msg_begin(&msg, "READY");
    send_line(&msg);
}

void app_poll(void)
{
    uint8_t byte;
    for (uint32_t n = 0; n < APP_BYTES_PER_POLL && board_uart_read(&byte); ++n) {
        link_feed(&g_link, byte);
    }
    uint32_t lost = board_uart_lost();
    if (lost != g_uart_lost) {
        g_uart_lost = lost;
        if (player_streaming(&g_player)) {
            player_fault(&g_player, SAFE_REASON_UART_LOST, g_player.received, "rx-overrun");
        }
    }
    for (uint32_t ticks = board_ticks_take(); ticks > 0u; --ticks) {
        player_tick(&g_player);
    }
    link_update_credit(&g_link);
    board_watchdog_kick();
}

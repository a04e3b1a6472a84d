#include "player.h"

static const char *const k_reason_names[SAFE_REASON_COUNT] = {
    [SAFE_REASON_BOOT] = "boot",
    [SAFE_REASON_END] = "end",
    [SAFE_REASON_MALFORMED] = "malformed",
    [SAFE_REASON_SEQUENCE] = "sequence",
    [SAFE_REASON_CHECKSUM] = "checksum",
    [SAFE_REASON_UNDERRUN] = "underrun",
    [SAFE_REASON_OVERFLOW] = "overflow",
    [SAFE_REASON_WATCHDOG] = "watchdog-reset",
    [SAFE_REASON_HOST_STOP] = "host-stop",
    [SAFE_REASON_CALIBRATION] = "calibration",
    [SAFE_REASON_DAC_FAULT] = "dac-fault",
    [SAFE_REASON_UART_LOST] = "uart-lost",
};

const char *safe_reason_name(safe_reason_t reason)
{
    if ((unsigned)reason >= (unsigned)SAFE_REASON_COUNT) {
        return "unknown";
    }
    return k_reason_names[reason];
}

void player_init(player_t *player, calib_t *calib, const player_io_t *io)
{
    player->state = PLAYER_SAFE;
    player->reason = SAFE_REASON_BOOT;
    player->calib = calib;
    player->io = *io;
    player->from_table = false;
    player->rows = PLAYER_ROWS_FIELD_MT;
    player->table = 0;
    player->table_rows = 0;
    player->queue_head = 0;
    player->queue_count = 0;
    player->received = 0;
    player->applied = 0;
    player->end_received = false;
}

static void begin(player_t *player)
{
    player->queue_head = 0;
    player->queue_count = 0;
    player->received = 0;
    player->applied = 0;
    player->end_received = false;
    calib_reset(player->calib);
}

void player_start_stream(player_t *player, player_rows_t rows)
{
    begin(player);
    player->from_table = false;
    player->rows = rows;
    if (!player->calib->valid) {
        player_fault(player, SAFE_REASON_CALIBRATION, 0, "invalid");
        return;
    }
    player->state = PLAYER_PREFILL;
}

void player_start_table(player_t *player, const double (*table)[CALIB_AXES], uint32_t rows)
{
    begin(player);
    player->from_table = true;
    player->rows = PLAYER_ROWS_FIELD_MT;
    player->table = table;
    player->table_rows = rows;
    if (!player->calib->valid) {
        player_fault(player, SAFE_REASON_CALIBRATION, 0, "invalid");
        return;
    }
    player->state = PLAYER_PLAYING;
}

bool player_streaming(const player_t *player)
{
    return player->state != PLAYER_SAFE && !player->from_table;
}

uint32_t player_free_rows(const player_t *player)
{
    return PLAYER_QUEUE_ROWS - player->queue_count;
}

void player_fault(player_t *player, safe_reason_t reason, uint32_t row, const char *detail)
{
    player->state = PLAYER_SAFE;
    player->reason = reason;
    player->queue_count = 0;
    calib_reset(player->calib);
    player->io.safe(player->io.ctx, reason, row, player->applied, detail);
}

void player_push(player_t *player, uint32_t seq, const double values[CALIB_AXES])
{
    if (!player_streaming(player)) {
        return; /* rows still in flight after a fault are dropped */
    }
    if (player->end_received) {
        player_fault(player, SAFE_REASON_SEQUENCE, seq, "row-after-end");
        return;
    }
    if (seq != player->received) {
        player_fault(player, SAFE_REASON_SEQUENCE, player->received, "out-of-order");
        return;
    }
    if (player->queue_count >= PLAYER_QUEUE_ROWS) {
        player_fault(player, SAFE_REASON_OVERFLOW, seq, "queue-full");
        return;
    }
    uint32_t slot = (player->queue_head + player->queue_count) % PLAYER_QUEUE_ROWS;
    for (unsigned axis = 0; axis < CALIB_AXES; ++axis) {
        player->queue[slot][axis] = values[axis];
    }
    player->queue_count++;
    player->received++;
    if (player->state == PLAYER_PREFILL && player->queue_count >= PLAYER_PREFILL_ROWS) {
        player->state = PLAYER_PLAYING;
    }
}

void player_end(player_t *player, uint32_t total_rows)
{
    if (!player_streaming(player)) {
        return;
    }
    if (total_rows != player->received) {
        player_fault(player, SAFE_REASON_SEQUENCE, player->received, "end-count");
        return;
    }
    player->end_received = true;
    player->state = PLAYER_PLAYING;
}

/** The codes of one row, in the unit of the rows being played. */
static void row_codes(player_t *player, const double row[CALIB_AXES], uint16_t codes[CALIB_AXES])
{
    if (player->rows == PLAYER_ROWS_CURRENT_A) {
        calib_currents_to_codes(player->calib, row, codes, 0);
    } else {
        calib_field_to_codes(player->calib, row, codes, 0);
    }
}

void player_tick(player_t *player)
{
    if (player->state != PLAYER_PLAYING) {
        return;
    }
    const double *row = 0;
    if (player->from_table) {
        if (player->applied < player->table_rows) {
            row = player->table[player->applied];
        }
    } else if (player->queue_count > 0u) {
        row = player->queue[player->queue_head];
        player->queue_head = (player->queue_head + 1u) % PLAYER_QUEUE_ROWS;
        player->queue_count--;
    }
    if (row == 0) {
        if (player->from_table || player->end_received) {
            player_fault(player, SAFE_REASON_END, player->applied, "");
        } else {
            player_fault(player, SAFE_REASON_UNDERRUN, player->applied, "queue-empty");
        }
        return;
    }
    uint16_t codes[CALIB_AXES];
    row_codes(player, row, codes);
    if (!player->io.apply(player->io.ctx, player->applied, codes)) {
        player_fault(player, SAFE_REASON_DAC_FAULT, player->applied, "spi-timeout");
        return;
    }
    player->applied++;
}

#include "link.h"

#include "board.h"
#include "crc16.h"
#include "msg.h"
#include "text_parse.h"

static void send_msg(link_t *link, msg_t *msg)
{
    msg_end(msg);
    link->send(link->ctx, msg->text, msg->len);
}

void link_init(link_t *link, player_t *player, link_send_fn send, void *ctx,
               const double (*table)[CALIB_AXES], uint32_t table_rows)
{
    csv_line_reader_init(&link->reader);
    link->player = player;
    link->send = send;
    link->ctx = ctx;
    link->credit_sent = 0;
    link->table = table;
    link->table_rows = table_rows;
    link->active = 0;
    cal_upload_init(&link->upload);
}

void link_set_calibration(link_t *link, calib_active_t *active)
{
    link->active = active;
}

static const char *state_name(player_state_t state)
{
    switch (state) {
    case PLAYER_SAFE:
        return "safe";
    case PLAYER_PREFILL:
        return "prefill";
    case PLAYER_PLAYING:
        return "playing";
    }
    return "unknown";
}

/** STATUS, CAL ... and RESET; false when @p text is none of them. */
static bool handle_calibration_command(link_t *link, const char *text, size_t len, size_t word)
{
    msg_t msg;
    if (text_is(text, len, "STATUS") && link->active != 0) {
        msg_begin(&msg, "STATUS");
        msg_kv_str(&msg, "state", state_name(link->player->state));
        msg_kv_str(&msg, "calibration", link->active->current.name);
        msg_kv_hex32(&msg, "hash", link->active->hash);
        msg_kv_str(&msg, "source", calib_source_name(link->active->source));
        send_msg(link, &msg);
    } else if (text_is(text, word, "CAL") && link->active != 0) {
        cal_upload_line(&link->upload, link->active, link->player->state == PLAYER_SAFE, text,
                        len, &msg);
        send_msg(link, &msg);
    } else if (text_is(text, len, "RESET")) {
        player_fault(link->player, SAFE_REASON_HOST_STOP, link->player->applied, "reset");
        msg_begin(&msg, "OK RESET");
        send_msg(link, &msg);
        board_system_reset();
    } else {
        return false;
    }
    return true;
}

static void send_credit(link_t *link, uint32_t credit)
{
    msg_t msg;
    msg_begin(&msg, "CREDIT ");
    msg_u32(&msg, credit);
    send_msg(link, &msg);
    link->credit_sent = credit;
}

void link_update_credit(link_t *link)
{
    const player_t *p = link->player;
    if (!player_streaming(p) || p->end_received) {
        return;
    }
    uint32_t credit = p->received + player_free_rows(p);
    if (credit >= link->credit_sent + LINK_CREDIT_BATCH) {
        send_credit(link, credit);
    }
}

/** Malformed input: fatal while streaming, an ERR line otherwise. */
static void reject(link_t *link, uint32_t line_no, const char *reason)
{
    if (player_streaming(link->player)) {
        /* row = the sequence number that was expected where the bad line arrived */
        player_fault(link->player, SAFE_REASON_MALFORMED, link->player->received, reason);
        return;
    }
    msg_t msg;
    msg_begin(&msg, "ERR ");
    msg_str(&msg, reason);
    msg_kv_u32(&msg, "line", line_no);
    send_msg(link, &msg);
}

static void handle_row(link_t *link, const char *text, size_t len, uint32_t line_no)
{
    if (!player_streaming(link->player)) {
        return; /* leftovers after a fault or STOP: outputs stay at mid-scale */
    }
    size_t star = len;
    for (size_t i = 0; i < len; ++i) {
        if (text[i] == LINK_CHECKSUM_SEPARATOR) {
            star = i;
        }
    }
    uint16_t sent_crc;
    if (star == len) {
        reject(link, line_no, "no-checksum");
        return;
    }
    uint32_t crc_field;
    if (len - star - 1u != LINK_CHECKSUM_HEX_DIGITS ||
        !parse_hex_u32(text + star + 1, len - star - 1u, &crc_field)) {
        reject(link, line_no, "bad-checksum-field");
        return;
    }
    sent_crc = (uint16_t)crc_field;
    if (crc16((const uint8_t *)text, star) != sent_crc) {
        player_fault(link->player, SAFE_REASON_CHECKSUM, link->player->received, "crc-mismatch");
        return;
    }
    csv_row_t row;
    csv_status_t st = csv_parse_row(text, star, CSV_COLUMNS_INDEXED, &row);
    if (st != CSV_OK) {
        reject(link, line_no, csv_status_reason(st));
        return;
    }
    player_push(link->player, row.index, row.mag_mT);
    link_update_credit(link);
}

/** STREAM [CURRENTS]: start a session of field rows (no argument) or of coil-current rows; any
 *  other argument is refused (ERR unknown-stream-mode). The answer of a field stream is the one
 *  older hosts know; a currents stream's adds mode=currents, which such a host never asks for. */
static void handle_stream(link_t *link, const char *arg, size_t arg_len, uint32_t line_no)
{
    player_rows_t rows;
    if (arg_len == 0u) {
        rows = PLAYER_ROWS_FIELD_MT;
    } else if (text_is(arg, arg_len, LINK_STREAM_CURRENTS)) {
        rows = PLAYER_ROWS_CURRENT_A;
    } else {
        reject(link, line_no, "unknown-stream-mode");
        return;
    }
    player_start_stream(link->player, rows);
    if (!player_streaming(link->player)) {
        return; /* refused: the player reported SAFE */
    }
    msg_t msg;
    msg_begin(&msg, "OK " LINK_STREAM_COMMAND);
    msg_kv_u32(&msg, "queue", PLAYER_QUEUE_ROWS);
    msg_kv_u32(&msg, "prefill", PLAYER_PREFILL_ROWS);
    if (rows == PLAYER_ROWS_CURRENT_A) {
        msg_kv_str(&msg, "mode", LINK_MODE_CURRENTS);
    }
    send_msg(link, &msg);
    send_credit(link, player_free_rows(link->player));
}

static void handle_command(link_t *link, const char *text, size_t len, uint32_t line_no)
{
    size_t word = 0;
    while (word < len && text[word] != ' ') {
        ++word;
    }
    const char *arg = word < len ? text + word + 1 : text + len;
    size_t arg_len = word < len ? len - word - 1 : 0;
    msg_t msg;
    if (text_is(text, word, LINK_STREAM_COMMAND)) {
        handle_stream(link, arg, arg_len, line_no);
    } else if (text_is(text, word, "END")) {
        uint32_t rows;
        if (!parse_u32(arg, arg_len, &rows)) {
            reject(link, line_no, "bad-end");
        } else if (player_streaming(link->player)) {
            player_end(link->player, rows);
            if (player_streaming(link->player)) {
                msg_begin(&msg, "OK END");
                msg_kv_u32(&msg, "rows", rows);
                send_msg(link, &msg);
            }
        }
    } else if (text_is(text, len, "PLAY")) {
        player_start_table(link->player, link->table, link->table_rows);
        if (link->player->state != PLAYER_SAFE) {
            msg_begin(&msg, "OK PLAY");
            msg_kv_u32(&msg, "rows", link->table_rows);
            send_msg(link, &msg);
        }
    } else if (text_is(text, len, "STOP")) {
        player_fault(link->player, SAFE_REASON_HOST_STOP, link->player->applied, "");
    } else if (text_is(text, len, "PING")) {
        msg_begin(&msg, "PONG");
        send_msg(link, &msg);
    } else if (!handle_calibration_command(link, text, len, word)) {
        reject(link, line_no, "unknown-command");
    }
}

void link_feed(link_t *link, uint8_t byte)
{
    csv_line_t line;
    csv_line_event_t ev = csv_line_push(&link->reader, byte, &line);
    if (ev == CSV_LINE_NONE) {
        return;
    }
    if (ev == CSV_LINE_ERROR) {
        reject(link, line.line_no, csv_status_reason(line.status));
        return;
    }
    if (line.len == 0) {
        return;
    }
    char first = line.text[0];
    if ((first >= '0' && first <= '9') || first == ' ' || first == '-' || first == '+' ||
        first == '.' || first == ',') {
        handle_row(link, line.text, line.len, line.line_no);
    } else {
        handle_command(link, line.text, line.len, line.line_no);
    }
}

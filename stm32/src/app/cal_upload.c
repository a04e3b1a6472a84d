#include "cal_upload.h"

#include "crc16.h"
#include "crc32.h"
#include "text_parse.h"

#define CAL_WORDS_MAX 4u
#define HEX_DIGITS_PER_BYTE 2u
#define HEX_DIGIT_BITS 4u
#define CHECKSUM_SEPARATOR '*'
#define CRC16_HEX_DIGITS 4u
#define CRC32_HEX_DIGITS 8u

typedef struct {
    const char *text[CAL_WORDS_MAX];
    size_t len[CAL_WORDS_MAX];
    unsigned count;
} words_t;

static void split(const char *line, size_t len, words_t *w)
{
    w->count = 0;
    size_t i = 0;
    while (i < len && w->count < CAL_WORDS_MAX) {
        while (i < len && line[i] == ' ') {
            ++i;
        }
        size_t start = i;
        while (i < len && line[i] != ' ') {
            ++i;
        }
        if (i > start) {
            w->text[w->count] = line + start;
            w->len[w->count] = i - start;
            ++w->count;
        }
    }
}

static void refuse(cal_upload_t *upload, msg_t *reply, const char *reason)
{
    upload->open = false;
    msg_begin(reply, "ERR cal-refused");
    msg_kv_str(reply, "reason", reason);
}

void cal_upload_init(cal_upload_t *upload)
{
    upload->received = 0;
    upload->open = false;
}

static void data_line(cal_upload_t *upload, const char *line, size_t len, msg_t *reply)
{
    size_t star = len;
    for (size_t i = 0; i < len; ++i) {
        if (line[i] == CHECKSUM_SEPARATOR) {
            star = i;
        }
    }
    uint32_t sent_crc;
    if (star == len || len - star - 1u != CRC16_HEX_DIGITS ||
        !parse_hex_u32(line + star + 1, CRC16_HEX_DIGITS, &sent_crc) ||
        crc16((const uint8_t *)line, star) != sent_crc) {
        refuse(upload, reply, "checksum");
        return;
    }
    words_t w;
    split(line, star, &w);
    uint32_t offset;
    if (w.count != CAL_WORDS_MAX || !parse_u32(w.text[2], w.len[2], &offset) ||
        offset != upload->received) {
        refuse(upload, reply, "bad-offset");
        return;
    }
    size_t bytes = w.len[3] / HEX_DIGITS_PER_BYTE;
    if (w.len[3] % HEX_DIGITS_PER_BYTE != 0u || bytes == 0u || bytes > CAL_UPLOAD_CHUNK_BYTES ||
        offset + bytes > CALIB_RECORD_BYTES) {
        refuse(upload, reply, "bad-hex");
        return;
    }
    for (size_t i = 0; i < bytes; ++i) {
        int hi = parse_hex_digit(w.text[3][HEX_DIGITS_PER_BYTE * i]);
        int lo = parse_hex_digit(w.text[3][HEX_DIGITS_PER_BYTE * i + 1u]);
        if (hi < 0 || lo < 0) {
            refuse(upload, reply, "bad-hex");
            return;
        }
        upload->record[offset + i] = (uint8_t)(((unsigned)hi << HEX_DIGIT_BITS) | (unsigned)lo);
    }
    upload->received = offset + (uint32_t)bytes;
    msg_begin(reply, "OK CAL-DATA");
    msg_kv_u32(reply, "next", upload->received);
}

static void commit_line(cal_upload_t *upload, calib_active_t *active, const words_t *w,
                        msg_t *reply)
{
    uint32_t hash;
    if (w->count != 3u || w->len[2] != CRC32_HEX_DIGITS ||
        !parse_hex_u32(w->text[2], w->len[2], &hash)) {
        refuse(upload, reply, "bad-hash");
        return;
    }
    if (upload->received != CALIB_RECORD_BYTES) {
        refuse(upload, reply, "incomplete");
        return;
    }
    if (crc32(upload->record, CALIB_RECORD_BYTES) != hash) {
        refuse(upload, reply, "hash-mismatch");
        return;
    }
    calib_named_t candidate;
    calib_record_decode(upload->record, &candidate);
    calib_commit_t result = calib_active_commit(active, &candidate);
    if (result.check != CALREC_OK) {
        refuse(upload, reply, calrec_status_name(result.check));
        return;
    }
    if (result.store != CALIB_STORE_OK) {
        refuse(upload, reply, calib_store_status_name(result.store));
        return;
    }
    upload->open = false;
    msg_begin(reply, "OK CAL-COMMIT");
    msg_kv_str(reply, "name", active->current.name);
    msg_kv_hex32(reply, "hash", active->hash);
    msg_kv_u32(reply, "slot", active->slot);
}

void cal_upload_line(cal_upload_t *upload, calib_active_t *active, bool outputs_safe,
                     const char *line, size_t len, msg_t *reply)
{
    words_t w;
    split(line, len, &w);
    if (!outputs_safe) {
        refuse(upload, reply, "busy");
    } else if (w.count == 2u && text_is(w.text[1], w.len[1], "BEGIN")) {
        upload->open = true;
        upload->received = 0;
        msg_begin(reply, "OK CAL-BEGIN");
        msg_kv_u32(reply, "bytes", CALIB_RECORD_BYTES);
    } else if (!upload->open) {
        refuse(upload, reply, "no-begin");
    } else if (w.count >= 2u && text_is(w.text[1], w.len[1], "DATA")) {
        data_line(upload, line, len, reply);
    } else if (w.count >= 2u && text_is(w.text[1], w.len[1], "COMMIT")) {
        commit_line(upload, active, &w, reply);
    } else {
        refuse(upload, reply, "unknown");
    }
}

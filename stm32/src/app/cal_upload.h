/**
 * @file cal_upload.h
 * The calibration upload over the link (lines after "CAL "):
 *
 *   CAL BEGIN                          -> OK CAL-BEGIN bytes=216
 *   CAL DATA <offset> <hex>*<CRC16>    -> OK CAL-DATA next=<offset + bytes>   (in order, <= 48 bytes)
 *   CAL COMMIT <crc32 of the record>   -> OK CAL-COMMIT name=<n> hash=<h> slot=<s>
 *
 * Every refusal is "ERR cal-refused reason=<r>" and leaves the active calibration as it was:
 * reasons of the transfer (busy: outputs not at mid-scale, no-begin, bad-offset, bad-hex,
 * checksum: a DATA line's CRC-16, incomplete, hash-mismatch: the record's CRC-32), of the
 * content (calib_record.h: not-finite, not-positive, singular, ill-conditioned, over-rating,
 * tick-rate, bad-name) and of storage (flash-erase, flash-program, flash-verify).
 */
#ifndef MSR_CAL_UPLOAD_H
#define MSR_CAL_UPLOAD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "calib_active.h"
#include "calib_record.h"
#include "msg.h"

/** Record bytes per DATA line. */
#define CAL_UPLOAD_CHUNK_BYTES 48u

typedef struct {
    uint8_t record[CALIB_RECORD_BYTES];
    uint32_t received;
    bool open;
} cal_upload_t;

void cal_upload_init(cal_upload_t *upload);

/** Handle one whole "CAL ..." line; @p outputs_safe: outputs are at mid-scale (no playback).
 * The answer line is built in @p reply. */
void cal_upload_line(cal_upload_t *upload, calib_active_t *active, bool outputs_safe,
                     const char *line, size_t len, msg_t *reply);

#endif

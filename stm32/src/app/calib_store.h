/**
 * @file calib_store.h
 * Two flash slots holding the last accepted calibration, safe against power loss.
 *
 * Slot layout: magic "MSRC" (4 bytes), sequence number (u32), record length (u32), CRC-32 of the
 * record (u32), then the record (calib_record.h). A write goes to the slot NOT holding the newest
 * valid calibration: erase, program the record, then the sequence, length and CRC, and the magic
 * last, then read everything back. Power lost at any point leaves that slot without its magic or
 * with a CRC mismatch, so loading falls back to the other slot, which was never touched. Loading
 * takes the valid slot (magic, length, CRC and calib_record_check) with the highest sequence.
 */
#ifndef MSR_CALIB_STORE_H
#define MSR_CALIB_STORE_H

#include <stdbool.h>
#include <stdint.h>

#include "calib_record.h"

#define CALIB_STORE_MAGIC 0x4352534Du /* "MSRC" little-endian */
#define CALIB_STORE_HEADER_BYTES 16u
#define CALIB_STORE_SLOT_BYTES (CALIB_STORE_HEADER_BYTES + CALIB_RECORD_BYTES)
#define CALIB_STORE_SLOTS 2u
#define CALIB_STORE_NO_SLOT 0xFFu

/** Outcome of calib_store_save(). */
typedef enum {
    CALIB_STORE_OK = 0,
    CALIB_STORE_ERASE_FAILED,
    CALIB_STORE_PROGRAM_FAILED,
    CALIB_STORE_VERIFY_FAILED,
} calib_store_status_t;

const char *calib_store_status_name(calib_store_status_t status);

/** The newest valid stored calibration: true and @p out / @p slot / @p seq set, or false. */
bool calib_store_load(calib_named_t *out, unsigned *slot, uint32_t *seq);

/** Store @p cal (already checked) in the slot not holding the newest valid one; @p slot_written
 * receives that slot. The other slot is not touched. */
calib_store_status_t calib_store_save(const calib_named_t *cal, unsigned *slot_written);

#endif

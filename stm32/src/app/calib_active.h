/**
 * @file calib_active.h
 * Which calibration the board plays with: the newest valid one stored in flash, else the one
 * compiled into the firmware (the fallback). An uploaded calibration replaces it only after it
 * passed calib_record_check() and was stored; a refused one leaves the active one unchanged.
 */
#ifndef MSR_CALIB_ACTIVE_H
#define MSR_CALIB_ACTIVE_H

#include <stdbool.h>
#include <stdint.h>

#include "calib_record.h"
#include "calib_store.h"
#include "calibration.h"

typedef enum {
    CALIB_SOURCE_COMPILED = 0,
    CALIB_SOURCE_FLASH,
} calib_source_t;

typedef struct {
    calib_t *calib;              /**< the conversion the player uses */
    calib_named_t current;       /**< the active calibration */
    calib_source_t source;
    uint32_t hash;               /**< CRC-32 of the active record */
    unsigned slot;               /**< flash slot of the active one (CALIB_STORE_NO_SLOT if compiled) */
} calib_active_t;

/** Outcome of calib_active_commit(): a refusal reason or a storage failure, or OK. */
typedef struct {
    calrec_status_t check;
    calib_store_status_t store;
} calib_commit_t;

/** Load the stored calibration, or fall back to @p compiled; returns calib_init()'s status. */
calib_status_t calib_active_init(calib_active_t *active, calib_t *calib,
                                 const calib_named_t *compiled);

/** Check, store and activate @p candidate (outputs must be at mid-scale: the caller checks). */
calib_commit_t calib_active_commit(calib_active_t *active, const calib_named_t *candidate);

/** Token of the source: "compiled" or "flash". */
const char *calib_source_name(calib_source_t source);

#endif

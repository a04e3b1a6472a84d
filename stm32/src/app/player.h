/**
 * @file player.h
 * Playback of rows at the tick rate, from the streaming queue or from the flash table, and the
 * safe state: every fault, the end of the waveform and an underrun end at mid-scale (0 A) with
 * a reason that is reported to the host.
 *
 * States: SAFE (outputs at mid-scale) -> PREFILL (stream: collecting rows) -> PLAYING -> SAFE.
 *
 * A stream's rows are either a field (mT, through the calibration's inverse matrix) or the three
 * outputs' coil currents (A, straight to the current and slew limits), chosen when the stream
 * starts; the flash table is always a field.
 */
#ifndef MSR_PLAYER_H
#define MSR_PLAYER_H

#include <stdbool.h>
#include <stdint.h>

#include "calibration.h"

/** Rows buffered in RAM for streaming (three doubles: 24 bytes each). */
#define PLAYER_QUEUE_ROWS 256u
/** Rows collected before playback starts (0.64 s of margin against host jitter). */
#define PLAYER_PREFILL_ROWS 64u

/** What the three values of a row are. */
typedef enum {
    PLAYER_ROWS_FIELD_MT = 0,   /**< field x, y, z in mT (calib_field_to_codes) */
    PLAYER_ROWS_CURRENT_A,      /**< coil current of outputs 0, 1, 2 in A (calib_currents_to_codes) */
} player_rows_t;

typedef enum {
    PLAYER_SAFE = 0,
    PLAYER_PREFILL,
    PLAYER_PLAYING,
} player_state_t;

typedef enum {
    SAFE_REASON_BOOT = 0,       /**< power-on, nothing played yet */
    SAFE_REASON_END,            /**< last row played */
    SAFE_REASON_MALFORMED,      /**< a row that does not parse */
    SAFE_REASON_SEQUENCE,       /**< a row out of order, or END with a wrong row count */
    SAFE_REASON_CHECKSUM,       /**< CRC mismatch */
    SAFE_REASON_UNDERRUN,       /**< no row ready at a tick */
    SAFE_REASON_OVERFLOW,       /**< host sent beyond its credit */
    SAFE_REASON_WATCHDOG,       /**< the last reset came from the watchdog */
    SAFE_REASON_HOST_STOP,      /**< STOP command */
    SAFE_REASON_CALIBRATION,    /**< calibration constants invalid */
    SAFE_REASON_DAC_FAULT,      /**< SPI time-out while writing the DACs */
    SAFE_REASON_UART_LOST,      /**< received bytes were lost */
    SAFE_REASON_COUNT
} safe_reason_t;

/** Report token of a reason, e.g. "checksum". */
const char *safe_reason_name(safe_reason_t reason);

/** Where codes go; the firmware writes DACs and reports, the tests record. */
typedef struct {
    void *ctx;
    /** Output one row's codes; false on a DAC fault. */
    bool (*apply)(void *ctx, uint32_t row, const uint16_t codes[CALIB_AXES]);
    /** Outputs to mid-scale now, and report why (@p detail may be ""). */
    void (*safe)(void *ctx, safe_reason_t reason, uint32_t row, uint32_t applied,
                 const char *detail);
} player_io_t;

typedef struct {
    player_state_t state;
    safe_reason_t reason;
    calib_t *calib;
    player_io_t io;
    bool from_table;
    player_rows_t rows;     /**< unit of the rows being played */
    const double (*table)[CALIB_AXES];
    uint32_t table_rows;
    double queue[PLAYER_QUEUE_ROWS][CALIB_AXES];
    uint32_t queue_head;
    uint32_t queue_count;
    uint32_t received;      /**< rows accepted = next expected sequence number */
    uint32_t applied;       /**< rows output */
    bool end_received;
} player_t;

void player_init(player_t *player, calib_t *calib, const player_io_t *io);
/** Start a streaming session (sequence numbers from 0) whose rows are @p rows. */
void player_start_stream(player_t *player, player_rows_t rows);
/** Play @p rows rows of a table in flash (a field in mT). */
void player_start_table(player_t *player, const double (*table)[CALIB_AXES], uint32_t rows);
/** Queue a streamed row (in the stream's unit); a wrong @p seq or a full queue ends in the safe state. */
void player_push(player_t *player, uint32_t seq, const double values[CALIB_AXES]);
/** The host has sent all @p total_rows rows: play what is queued, then END. */
void player_end(player_t *player, uint32_t total_rows);
/** Go to the safe state now. */
void player_fault(player_t *player, safe_reason_t reason, uint32_t row, const char *detail);
/** One 10 ms tick. */
void player_tick(player_t *player);
bool player_streaming(const player_t *player);
uint32_t player_free_rows(const player_t *player);

#endif

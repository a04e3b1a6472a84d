/**
 * @file calib_record.h
 * A calibration as bytes (uploaded over the link, stored in flash) and the checks an uploaded or
 * stored calibration must pass before it is used.
 *
 * Record (CALIB_RECORD_BYTES = 216, little-endian IEEE doubles): actuation matrix row-major [T/A],
 * transconductance [A/V] x3, input offset [V] x3, DAC half span [V], current limit [A] x3, slew
 * limit [A/s] x3, tick rate [Hz], then the name in 32 bytes, NUL-padded. The host writes the same
 * bytes (elastica_magnetic.hardware.protocol.calibration_record); its hash is the CRC-32 of the
 * record, so host and board agree on which calibration is active.
 */
#ifndef MSR_CALIB_RECORD_H
#define MSR_CALIB_RECORD_H

#include <stdbool.h>
#include <stdint.h>

#include "calibration.h"

#define CALIB_RECORD_DOUBLES 23u
#define CALIB_DOUBLE_BYTES 8u
#define CALIB_NAME_BYTES 32u
#define CALIB_RECORD_BYTES (CALIB_RECORD_DOUBLES * CALIB_DOUBLE_BYTES + CALIB_NAME_BYTES)

typedef struct {
    calib_params_t params;
    char name[CALIB_NAME_BYTES]; /**< NUL-terminated, letters, digits, '_', '.', '-' */
} calib_named_t;

/** Why an uploaded or stored calibration is refused (reported as reason=<name>). */
typedef enum {
    CALREC_OK = 0,
    CALREC_NOT_FINITE,      /**< a NaN or infinity */
    CALREC_NOT_POSITIVE,    /**< a zero gain, or a limit or span <= 0 */
    CALREC_SINGULAR,        /**< matrix not invertible */
    CALREC_ILL_CONDITIONED, /**< condition number above HW_MAX_MATRIX_CONDITION */
    CALREC_OVER_RATING,     /**< a limit, gain, offset or span beyond hw_ratings.h */
    CALREC_TICK_RATE,       /**< tick_hz differs from the firmware's */
    CALREC_BAD_NAME,        /**< empty, unterminated or with other characters */
} calrec_status_t;

/** Token of a status, e.g. "ill-conditioned". */
const char *calrec_status_name(calrec_status_t status);

void calib_record_encode(const calib_named_t *cal, uint8_t out[CALIB_RECORD_BYTES]);
/** Decode without checking (see calib_record_check). */
void calib_record_decode(const uint8_t in[CALIB_RECORD_BYTES], calib_named_t *cal);
/** CRC-32 of the encoded record. */
uint32_t calib_record_hash(const calib_named_t *cal);

/** Every check of an uploaded calibration: finite, invertible, well conditioned, within the
 * hardware ratings, tick rate equal to the firmware's, a valid name. */
calrec_status_t calib_record_check(const calib_named_t *cal);

/** 1-norm condition number of a 3x3 matrix (infinite when singular). */
double calib_condition_1norm(const double m[CALIB_AXES][CALIB_AXES]);

#endif

/**
 * @file calibration.h
 * Field (mT) -> coil currents (A) -> amplifier input voltages (V) -> DAC codes.
 *
 * Per 10 ms tick and axis i (the host's elastica_magnetic.hardware.calibration.DacCodeModel
 * performs the same IEEE double operations in the same order, so both sides agree exactly):
 *
 *   b_i    = mag_mT_i * CALIB_TESLA_PER_MILLITESLA                              [T]
 *   I_i    = inv(A)_i0*b_0 + inv(A)_i1*b_1 + inv(A)_i2*b_2                     [A]
 *   I_i    = clamp(I_i, -current_limit_A_i, +current_limit_A_i)
 *   I_i    = clamp(I_i, I_prev_i - slew_A_per_s_i*dt, I_prev_i + slew_A_per_s_i*dt)
 *   V_i    = I_i / transconductance_A_per_V_i + input_offset_V_i             [V from 2.5 V]
 *   code_i = clamp(CALIB_DAC_MIDSCALE + round_half_away(V_i / dac_half_span_V * 32767), 0, 65535)
 *
 * A coil-current row (calib_currents_to_codes) gives I_i directly, in A, and starts at the
 * current limit: the same operations from there on.
 *
 * A is the measured actuation matrix (tesla per ampere, field = A @ current). Its inverse is
 * computed once from the adjugate. Mid-scale (0 V from the 2.5 V reference, 0 A) is the safe state.
 */
#ifndef MSR_CALIBRATION_H
#define MSR_CALIBRATION_H

#include <stdbool.h>
#include <stdint.h>

#define CALIB_AXES 3u
/** Unit conversion of the CSV's millitesla. */
#define CALIB_TESLA_PER_MILLITESLA 1e-3
/** DAC8563 code at mid-scale: the safe state, 0 V at the amplifier input, 0 A. */
#define CALIB_DAC_MIDSCALE 32768u
/** Codes from mid-scale to full scale (code = mid-scale + round(V / half_span * this)). */
#define CALIB_DAC_HALF_RANGE 32767.0
#define CALIB_DAC_CODE_MIN 0u
#define CALIB_DAC_CODE_MAX 65535u
/** A determinant smaller than this times the product of the row norms is singular. */
#define CALIB_MIN_RELATIVE_DET 1e-9

/** The calibration file's content (SI units), see stm32/calibration/default.json. */
typedef struct {
    double actuation_T_per_A[CALIB_AXES][CALIB_AXES]; /**< field = A @ current */
    double transconductance_A_per_V[CALIB_AXES];       /**< coil current per input volt */
    double input_offset_V[CALIB_AXES];                 /**< amplifier input for 0 A */
    double dac_half_span_V;                            /**< mid-scale to full scale, 2.5 V */
    double current_limit_A[CALIB_AXES];                /**< |I| never exceeds this */
    double slew_limit_A_per_s[CALIB_AXES];             /**< |dI/dt| never exceeds this */
    double tick_hz;                                    /**< update rate, 100 Hz */
} calib_params_t;

typedef enum {
    CALIB_OK = 0,
    CALIB_ERR_NOT_FINITE,
    CALIB_ERR_SINGULAR,
    CALIB_ERR_NOT_POSITIVE,
} calib_status_t;

/** Per-row flags: which axes were limited. Bit i = axis i. */
typedef struct {
    uint8_t current_limited;
    uint8_t slew_limited;
    uint8_t code_clamped;
} calib_flags_t;

typedef struct {
    calib_params_t params;
    double inverse_A_per_T[CALIB_AXES][CALIB_AXES];
    double max_step_A[CALIB_AXES];   /**< slew_limit * (1 / tick_hz) */
    double last_current_A[CALIB_AXES];
    bool valid;
} calib_t;

/** Validate @p params and precompute; an invalid calibration keeps outputs at mid-scale. */
calib_status_t calib_init(calib_t *calib, const calib_params_t *params);

/** Short name of a status, e.g. "singular". */
const char *calib_status_name(calib_status_t status);

/** Forget the slew history: the next row slews from 0 A (after mid-scale). */
void calib_reset(calib_t *calib);

/** One tick: field in mT -> three DAC codes (mid-scale for an invalid calibration or a
 *  non-finite field, the slew history then unchanged). */
void calib_field_to_codes(calib_t *calib, const double mag_mT[CALIB_AXES],
                          uint16_t codes[CALIB_AXES], calib_flags_t *flags);

/**
 * One tick of a coil-current row: the currents (A) of the three outputs -> three DAC codes,
 * through the same tail as calib_field_to_codes without the matrix (output i: current limit,
 * slew limit, V = I / transconductance + offset, code). The actuation matrix is not used: output
 * i drives whatever coil is wired to it. Mid-scale for an invalid calibration or a non-finite
 * current (the slew history then unchanged), as for a field.
 */
void calib_currents_to_codes(calib_t *calib, const double current_A[CALIB_AXES],
                             uint16_t codes[CALIB_AXES], calib_flags_t *flags);

/** Amplifier input voltage (relative to mid-scale) -> DAC code, rounded and clamped. */
uint16_t calib_volts_to_code(double volts, double half_span_V);

/** Round half away from zero (identical to the host's implementation). */
double calib_round_half_away(double x);

/** Inverse of a 3x3 matrix by the adjugate; false when singular. */
bool calib_invert3(const double m[CALIB_AXES][CALIB_AXES], double inv[CALIB_AXES][CALIB_AXES]);

#endif

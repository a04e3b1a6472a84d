#include "calibration.h"

#include <float.h>

static bool is_finite(double x) { return x == x && x <= DBL_MAX && x >= -DBL_MAX; }
static double absd(double x) { return x < 0.0 ? -x : x; }

/** 2^52: from here on every double is an integer. */
#define CALIB_EXACT_INTEGER_LIMIT 4503599627370496.0

double calib_round_half_away(double x)
{
    /* Doubles of magnitude 2^52 and above are integers already (and NaN stays NaN). */
    if (!(absd(x) < CALIB_EXACT_INTEGER_LIMIT)) {
        return x;
    }
    if (x >= 0.0) {
        double t = (double)(int64_t)x;
        return (x - t >= 0.5) ? t + 1.0 : t;
    }
    double t = (double)(int64_t)(-x);
    return (-x - t >= 0.5) ? -(t + 1.0) : -t;
}

uint16_t calib_volts_to_code(double volts, double half_span_V)
{
    double scaled = volts / half_span_V * CALIB_DAC_HALF_RANGE;
    if (!is_finite(scaled)) {
        return (uint16_t)CALIB_DAC_MIDSCALE;
    }
    /* Clamp before rounding so huge values cannot overflow the integer conversion. */
    if (scaled > (double)CALIB_DAC_CODE_MAX) {
        scaled = (double)CALIB_DAC_CODE_MAX;
    } else if (scaled < -(double)CALIB_DAC_CODE_MAX) {
        scaled = -(double)CALIB_DAC_CODE_MAX;
    }
    double code = (double)CALIB_DAC_MIDSCALE + calib_round_half_away(scaled);
    if (code < (double)CALIB_DAC_CODE_MIN) {
        code = (double)CALIB_DAC_CODE_MIN;
    } else if (code > (double)CALIB_DAC_CODE_MAX) {
        code = (double)CALIB_DAC_CODE_MAX;
    }
    return (uint16_t)code;
}

bool calib_invert3(const double m[CALIB_AXES][CALIB_AXES], double inv[CALIB_AXES][CALIB_AXES])
{
    double c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    double c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    double c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    double det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    double scale = 1.0;
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        double row = absd(m[i][0]) + absd(m[i][1]) + absd(m[i][2]);
        scale *= row;
    }
    if (!is_finite(det) || !(absd(det) > CALIB_MIN_RELATIVE_DET * scale)) {
        return false;
    }
    inv[0][0] = c00 / det;
    inv[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / det;
    inv[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / det;
    inv[1][0] = c01 / det;
    inv[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / det;
    inv[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / det;
    inv[2][0] = c02 / det;
    inv[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / det;
    inv[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det;
    return true;
}

const char *calib_status_name(calib_status_t status)
{
    switch (status) {
    case CALIB_OK:
        return "ok";
    case CALIB_ERR_NOT_FINITE:
        return "not-finite";
    case CALIB_ERR_SINGULAR:
        return "singular";
    case CALIB_ERR_NOT_POSITIVE:
        return "not-positive";
    }
    return "unknown";
}

calib_status_t calib_init(calib_t *calib, const calib_params_t *params)
{
    calib->params = *params;
    calib->valid = false;
    calib_reset(calib);
    const calib_params_t *p = params;
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        for (unsigned j = 0; j < CALIB_AXES; ++j) {
            if (!is_finite(p->actuation_T_per_A[i][j])) {
                return CALIB_ERR_NOT_FINITE;
            }
        }
        if (!is_finite(p->transconductance_A_per_V[i]) || !is_finite(p->input_offset_V[i]) ||
            !is_finite(p->current_limit_A[i]) || !is_finite(p->slew_limit_A_per_s[i])) {
            return CALIB_ERR_NOT_FINITE;
        }
        if (!(p->transconductance_A_per_V[i] != 0.0) || !(p->current_limit_A[i] > 0.0) ||
            !(p->slew_limit_A_per_s[i] > 0.0)) {
            return CALIB_ERR_NOT_POSITIVE;
        }
    }
    if (!is_finite(p->dac_half_span_V) || !is_finite(p->tick_hz)) {
        return CALIB_ERR_NOT_FINITE;
    }
    if (!(p->dac_half_span_V > 0.0) || !(p->tick_hz > 0.0)) {
        return CALIB_ERR_NOT_POSITIVE;
    }
    if (!calib_invert3(p->actuation_T_per_A, calib->inverse_A_per_T)) {
        return CALIB_ERR_SINGULAR;
    }
    double dt = 1.0 / p->tick_hz;
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        calib->max_step_A[i] = p->slew_limit_A_per_s[i] * dt;
    }
    calib->valid = true;
    return CALIB_OK;
}

void calib_reset(calib_t *calib)
{
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        calib->last_current_A[i] = 0.0;
    }
}

/** Every output at mid-scale (the safe codes) and no limit flag: an invalid calibration or input. */
static void safe_codes(uint16_t codes[CALIB_AXES], calib_flags_t *flags)
{
    const calib_flags_t none = {0, 0, 0};
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        codes[i] = (uint16_t)CALIB_DAC_MIDSCALE;
    }
    if (flags != 0) {
        *flags = none;
    }
}

/** @p current clamped to +-@p limit; sets @p bit in @p flag when it was. */
static double clamp_current(double current, double limit, uint8_t bit, uint8_t *flag)
{
    if (current > limit) {
        *flag |= bit;
        return limit;
    }
    if (current < -limit) {
        *flag |= bit;
        return -limit;
    }
    return current;
}

/** @p current moved at most @p step from @p last; sets @p bit in @p flag when it was limited. */
static double slew_current(double current, double last, double step, uint8_t bit, uint8_t *flag)
{
    if (current - last > step) {
        *flag |= bit;
        return last + step;
    }
    if (current - last < -step) {
        *flag |= bit;
        return last - step;
    }
    return current;
}

/**
 * The common tail of both paths: requested currents (A) -> current limit -> slew limit ->
 * V = I / g + offset -> code, per axis, in exactly this order (the host's twin repeats it).
 * Updates the slew history. @p current_A must be finite and @p calib valid.
 */
static void currents_to_codes(calib_t *calib, const double current_A[CALIB_AXES],
                              uint16_t codes[CALIB_AXES], calib_flags_t *flags)
{
    calib_flags_t f = {0, 0, 0};
    const calib_params_t *p = &calib->params;
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        uint8_t bit = (uint8_t)(1u << i);
        double current = clamp_current(current_A[i], p->current_limit_A[i], bit, &f.current_limited);
        current = slew_current(current, calib->last_current_A[i], calib->max_step_A[i], bit,
                               &f.slew_limited);
        calib->last_current_A[i] = current;
        double volts = current / p->transconductance_A_per_V[i] + p->input_offset_V[i];
        double scaled = volts / p->dac_half_span_V * CALIB_DAC_HALF_RANGE;
        if (!(scaled < CALIB_DAC_HALF_RANGE + 0.5) || !(scaled > -(CALIB_DAC_HALF_RANGE + 1.5))) {
            f.code_clamped |= bit;
        }
        codes[i] = calib_volts_to_code(volts, p->dac_half_span_V);
    }
    if (flags != 0) {
        *flags = f;
    }
}

void calib_field_to_codes(calib_t *calib, const double mag_mT[CALIB_AXES],
                          uint16_t codes[CALIB_AXES], calib_flags_t *flags)
{
    double b[CALIB_AXES];
    bool finite = true;
    for (unsigned j = 0; j < CALIB_AXES; ++j) {
        b[j] = mag_mT[j] * CALIB_TESLA_PER_MILLITESLA;
        finite = finite && is_finite(b[j]);
    }
    if (!calib->valid || !finite) {
        safe_codes(codes, flags);
        return;
    }
    double current[CALIB_AXES];
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        const double *row = calib->inverse_A_per_T[i];
        current[i] = row[0] * b[0] + row[1] * b[1] + row[2] * b[2];
    }
    currents_to_codes(calib, current, codes, flags);
}

void calib_currents_to_codes(calib_t *calib, const double current_A[CALIB_AXES],
                             uint16_t codes[CALIB_AXES], calib_flags_t *flags)
{
    bool finite = true;
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        finite = finite && is_finite(current_A[i]);
    }
    if (!calib->valid || !finite) {
        safe_codes(codes, flags);
        return;
    }
    currents_to_codes(calib, current_A, codes, flags);
}

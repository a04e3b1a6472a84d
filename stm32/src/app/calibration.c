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

void calib_field_to_codes(calib_t *calib, const double mag_mT[CALIB_AXES],
                          uint16_t codes[CALIB_AXES], calib_flags_t *flags)
{
    calib_flags_t f = {0, 0, 0};
    double b[CALIB_AXES];
    bool finite = true;
    for (unsigned j = 0; j < CALIB_AXES; ++j) {
        b[j] = mag_mT[j] * CALIB_TESLA_PER_MILLITESLA;
        finite = finite && is_finite(b[j]);
    }
    if (!calib->valid || !finite) {
        for (unsigned i = 0; i < CALIB_AXES; ++i) {
            codes[i] = (uint16_t)CALIB_DAC_MIDSCALE;
        }
        if (flags != 0) {
            *flags = f;
        }
        return;
    }
    const calib_params_t *p = &calib->params;
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        const double *row = calib->inverse_A_per_T[i];
        double current = row[0] * b[0] + row[1] * b[1] + row[2] * b[2];
        double limit = p->current_limit_A[i];
        if (current > limit) {
            current = limit;
            f.current_limited |= (uint8_t)(1u << i);
        } else if (current < -limit) {
            current = -limit;
            f.current_limited |= (uint8_t)(1u << i);
        }
        double last = calib->last_current_A[i];
        double step = calib->max_step_A[i];
        if (current - last > step) {
            current = last + step;
            f.slew_limited |= (uint8_t)(1u << i);
        } else if (current - last < -step) {
            current = last - step;
            f.slew_limited |= (uint8_t)(1u << i);
        }
        calib->last_current_A[i] = current;
        double volts = current / p->transconductance_A_per_V[i] + p->input_offset_V[i];
        double scaled = volts / p->dac_half_span_V * CALIB_DAC_HALF_RANGE;
        if (!(scaled < CALIB_DAC_HALF_RANGE + 0.5) || !(scaled > -(CALIB_DAC_HALF_RANGE + 1.5))) {
            f.code_clamped |= (uint8_t)(1u << i);
        }
        codes[i] = calib_volts_to_code(volts, p->dac_half_span_V);
    }
    if (flags != 0) {
        *flags = f;
    }
}

#include "calib_record.h"

#include <float.h>
#include <string.h>

#include "crc32.h"
#include "hw_ratings.h"

#define BITS_PER_BYTE 8u

static bool finite(double x) { return x == x && x <= DBL_MAX && x >= -DBL_MAX; }
static double absd(double x) { return x < 0.0 ? -x : x; }

static void put_double(uint8_t *out, double value)
{
    uint64_t bits;
    memcpy(&bits, &value, sizeof bits);
    for (unsigned i = 0; i < CALIB_DOUBLE_BYTES; ++i) {
        out[i] = (uint8_t)(bits >> (BITS_PER_BYTE * i));
    }
}

static double get_double(const uint8_t *in)
{
    uint64_t bits = 0;
    for (unsigned i = 0; i < CALIB_DOUBLE_BYTES; ++i) {
        bits |= (uint64_t)in[i] << (BITS_PER_BYTE * i);
    }
    double value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

/** The record's doubles in order, as pointers into @p p. */
static void fields(calib_params_t *p, double *out[CALIB_RECORD_DOUBLES])
{
    unsigned k = 0;
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        for (unsigned j = 0; j < CALIB_AXES; ++j) {
            out[k++] = &p->actuation_T_per_A[i][j];
        }
    }
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        out[k++] = &p->transconductance_A_per_V[i];
    }
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        out[k++] = &p->input_offset_V[i];
    }
    out[k++] = &p->dac_half_span_V;
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        out[k++] = &p->current_limit_A[i];
    }
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        out[k++] = &p->slew_limit_A_per_s[i];
    }
    out[k] = &p->tick_hz;
}

void calib_record_encode(const calib_named_t *cal, uint8_t out[CALIB_RECORD_BYTES])
{
    calib_params_t copy = cal->params;
    double *f[CALIB_RECORD_DOUBLES];
    fields(&copy, f);
    for (unsigned k = 0; k < CALIB_RECORD_DOUBLES; ++k) {
        put_double(out + k * CALIB_DOUBLE_BYTES, *f[k]);
    }
    uint8_t *name = out + CALIB_RECORD_DOUBLES * CALIB_DOUBLE_BYTES;
    memset(name, 0, CALIB_NAME_BYTES);
    for (unsigned i = 0; i + 1u < CALIB_NAME_BYTES && cal->name[i] != '\0'; ++i) {
        name[i] = (uint8_t)cal->name[i];
    }
}

void calib_record_decode(const uint8_t in[CALIB_RECORD_BYTES], calib_named_t *cal)
{
    double *f[CALIB_RECORD_DOUBLES];
    fields(&cal->params, f);
    for (unsigned k = 0; k < CALIB_RECORD_DOUBLES; ++k) {
        *f[k] = get_double(in + k * CALIB_DOUBLE_BYTES);
    }
    memcpy(cal->name, in + CALIB_RECORD_DOUBLES * CALIB_DOUBLE_BYTES, CALIB_NAME_BYTES);
}

uint32_t calib_record_hash(const calib_named_t *cal)
{
    uint8_t bytes[CALIB_RECORD_BYTES];
    calib_record_encode(cal, bytes);
    return crc32(bytes, sizeof bytes);
}

const char *calrec_status_name(calrec_status_t status)
{
    switch (status) {
    case CALREC_OK:
        return "ok";
    case CALREC_NOT_FINITE:
        return "not-finite";
    case CALREC_NOT_POSITIVE:
        return "not-positive";
    case CALREC_SINGULAR:
        return "singular";
    case CALREC_ILL_CONDITIONED:
        return "ill-conditioned";
    case CALREC_OVER_RATING:
        return "over-rating";
    case CALREC_TICK_RATE:
        return "tick-rate";
    case CALREC_BAD_NAME:
        return "bad-name";
    }
    return "unknown";
}

static double norm1(const double m[CALIB_AXES][CALIB_AXES])
{
    double best = 0.0;
    for (unsigned j = 0; j < CALIB_AXES; ++j) {
        double col = absd(m[0][j]) + absd(m[1][j]) + absd(m[2][j]);
        best = col > best ? col : best;
    }
    return best;
}

double calib_condition_1norm(const double m[CALIB_AXES][CALIB_AXES])
{
    double inv[CALIB_AXES][CALIB_AXES];
    if (!calib_invert3(m, inv)) {
        return DBL_MAX;
    }
    return norm1(m) * norm1((const double(*)[CALIB_AXES])inv);
}

static bool name_ok(const char name[CALIB_NAME_BYTES])
{
    unsigned n = 0;
    while (n < CALIB_NAME_BYTES && name[n] != '\0') {
        char c = name[n];
        bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                  c == '_' || c == '.' || c == '-';
        if (!ok) {
            return false;
        }
        ++n;
    }
    for (unsigned i = n; i < CALIB_NAME_BYTES; ++i) { /* NUL-padded to the end */
        if (name[i] != '\0') {
            return false;
        }
    }
    return n > 0u && n < CALIB_NAME_BYTES;
}

static bool within(double x, double low, double high) { return x >= low && x <= high; }

calrec_status_t calib_record_check(const calib_named_t *cal)
{
    calib_params_t p = cal->params;
    double *f[CALIB_RECORD_DOUBLES];
    fields(&p, f);
    for (unsigned k = 0; k < CALIB_RECORD_DOUBLES; ++k) {
        if (!finite(*f[k])) {
            return CALREC_NOT_FINITE;
        }
    }
    if (!name_ok(cal->name)) {
        return CALREC_BAD_NAME;
    }
    if (!(p.tick_hz == HW_TICK_HZ)) {
        return CALREC_TICK_RATE;
    }
    if (!(p.dac_half_span_V > 0.0)) {
        return CALREC_NOT_POSITIVE;
    }
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        if (!(p.transconductance_A_per_V[i] != 0.0) || !(p.current_limit_A[i] > 0.0) ||
            !(p.slew_limit_A_per_s[i] > 0.0)) {
            return CALREC_NOT_POSITIVE;
        }
    }
    for (unsigned i = 0; i < CALIB_AXES; ++i) {
        if (!within(absd(p.transconductance_A_per_V[i]), HW_MIN_TRANSCONDUCTANCE_A_PER_V,
                    HW_MAX_TRANSCONDUCTANCE_A_PER_V) ||
            !(absd(p.input_offset_V[i]) <= HW_MAX_ABS_OFFSET_V) ||
            !(p.current_limit_A[i] <= HW_MAX_CURRENT_A) ||
            !(p.slew_limit_A_per_s[i] <= HW_MAX_SLEW_A_PER_S)) {
            return CALREC_OVER_RATING;
        }
    }
    if (!(p.dac_half_span_V <= HW_MAX_DAC_HALF_SPAN_V)) {
        return CALREC_OVER_RATING;
    }
    double inv[CALIB_AXES][CALIB_AXES];
    const double(*matrix)[CALIB_AXES] = cal->params.actuation_T_per_A;
    if (!calib_invert3(matrix, inv)) {
        return CALREC_SINGULAR;
    }
    if (!(calib_condition_1norm(matrix) <= HW_MAX_MATRIX_CONDITION)) {
        return CALREC_ILL_CONDITIONED;
    }
    return CALREC_OK;
}

/* The calibration the host tests share: three identical, decoupled coils of 2 mT per ampere, a
 * 1 A/V driver without offset, a +-2.5 V DAC half span, 2 A and 1000 A/s limits, 100 Hz ticks.
 * So 1 mT is 0.5 A is 0.5 V, and the 2 A limit is 4 mT. */
#ifndef MSR_TEST_CALIB_H
#define MSR_TEST_CALIB_H
#include "calibration.h"

static const calib_params_t k_test_calib = {
    .actuation_T_per_A = {{2e-3, 0, 0}, {0, 2e-3, 0}, {0, 0, 2e-3}},
    .transconductance_A_per_V = {1, 1, 1},
    .input_offset_V = {0, 0, 0},
    .dac_half_span_V = 2.5,
    .current_limit_A = {2, 2, 2},
    .slew_limit_A_per_s = {1000, 1000, 1000},
    .tick_hz = 100,
};
#endif

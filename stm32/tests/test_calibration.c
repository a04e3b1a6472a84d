#include "test_common.h"

#include <math.h>

#include "calibration.h"

/* Hand-computed reference: diagonal coils of 2 mT/A, 1 A/V amplifiers, 2.5 V half span. */
static calib_params_t base_params(void)
{
    calib_params_t p = {
        .actuation_T_per_A = {{2e-3, 0, 0}, {0, 2e-3, 0}, {0, 0, 2e-3}},
        .transconductance_A_per_V = {1.0, 1.0, 1.0},
        .input_offset_V = {0, 0, 0},
        .dac_half_span_V = 2.5,
        .current_limit_A = {2.0, 2.0, 2.0},
        .slew_limit_A_per_s = {1000.0, 1000.0, 1000.0},
        .tick_hz = 100.0,
    };
    return p;
}

static void codes_for(calib_t *c, double x, double y, double z, uint16_t out[3], calib_flags_t *f)
{
    const double mT[3] = {x, y, z};
    calib_field_to_codes(c, mT, out, f);
}

static void test_zero_field_is_midscale(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    codes_for(&c, 0, 0, 0, codes, NULL);
    for (int i = 0; i < 3; ++i) {
        assert_int_equal(codes[i], CALIB_DAC_MIDSCALE);
    }
}

static void test_hand_values(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    /* 1 mT / 2 mT/A = 0.5 A = 0.5 V; 0.5 / 2.5 * 32767 = 6553.4 -> 6553. */
    /* -1 mT -> -6553.4 -> -6553 ; 0.4 mT -> 0.2 V -> 2621.36 -> 2621 */
    codes_for(&c, 1.0, -1.0, 0.4, codes, NULL);
    assert_int_equal(codes[0], 32768 + 6553);
    assert_int_equal(codes[1], 32768 - 6553);
    assert_int_equal(codes[2], 32768 + 2621);
}

static void test_offset_and_transconductance(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    p.input_offset_V[0] = 0.01;            /* V = 0.5 + 0.01 = 0.51 -> 6684.468 -> 6684 */
    p.transconductance_A_per_V[1] = 2.0;   /* 0.5 A / 2 A/V = 0.25 V -> 3276.7 -> 3277 */
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    codes_for(&c, 1.0, 1.0, 0.0, codes, NULL);
    assert_int_equal(codes[0], 32768 + 6684);
    assert_int_equal(codes[1], 32768 + 3277);
    assert_int_equal(codes[2], 32768);
}

static void test_coupled_matrix_inverse(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    /* A = [[2,1,0],[0,2,0],[0,0,4]] mT/A; inv = [[0.5,-0.25,0],[0,0.5,0],[0,0,0.25]] A/mT */
    const double a[3][3] = {{2e-3, 1e-3, 0}, {0, 2e-3, 0}, {0, 0, 4e-3}};
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            p.actuation_T_per_A[i][j] = a[i][j];
        }
    }
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    assert_true(fabs(c.inverse_A_per_T[0][1] - (-250.0)) < 1e-9);
    assert_true(fabs(c.inverse_A_per_T[2][2] - 250.0) < 1e-9);
    uint16_t codes[3];
    /* B = (1,1,1) mT -> I = (0.25, 0.5, 0.25) A -> 3276.7, 6553.4, 3276.7 */
    codes_for(&c, 1.0, 1.0, 1.0, codes, NULL);
    assert_int_equal(codes[0], 32768 + 3277);
    assert_int_equal(codes[1], 32768 + 6553);
    assert_int_equal(codes[2], 32768 + 3277);
}

static void test_invert_general(void **state)
{
    (void)state;
    const double m[3][3] = {{2.1, 0.3, -0.2}, {0.1, 1.9, 0.4}, {-0.3, 0.2, 1.7}};
    double inv[3][3];
    assert_true(calib_invert3(m, inv));
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            double s = m[i][0] * inv[0][j] + m[i][1] * inv[1][j] + m[i][2] * inv[2][j];
            assert_true(fabs(s - (i == j ? 1.0 : 0.0)) < 1e-12);
        }
    }
}

static void test_current_limit(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    p.current_limit_A[0] = 1.0;
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    calib_flags_t f;
    /* 10 mT asks for 5 A; limited to 1 A = 1 V -> 13106.8 -> 13107 */
    codes_for(&c, 10.0, 0, 0, codes, &f);
    assert_int_equal(codes[0], 32768 + 13107);
    assert_int_equal(f.current_limited, 0x1);
    codes_for(&c, -10.0, 0, 0, codes, &f); /* slew 10 A/tick allows the full swing */
    assert_int_equal(codes[0], 32768 - 13107);
    assert_int_equal(f.current_limited, 0x1);
}

static void test_code_clamp(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    p.dac_half_span_V = 0.5; /* 2 A = 2 V is far beyond full scale */
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    calib_flags_t f;
    codes_for(&c, 4.0, -4.0, 0.0, codes, &f);
    assert_int_equal(codes[0], CALIB_DAC_CODE_MAX);
    assert_int_equal(codes[1], CALIB_DAC_CODE_MIN);
    assert_int_equal(f.code_clamped, 0x3);
    assert_int_equal(calib_volts_to_code(1e300, 2.5), CALIB_DAC_CODE_MAX);
    assert_int_equal(calib_volts_to_code(-1e300, 2.5), CALIB_DAC_CODE_MIN);
    assert_int_equal(calib_volts_to_code(NAN, 2.5), CALIB_DAC_MIDSCALE);
}

static void test_slew_limit(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    p.slew_limit_A_per_s[2] = 10.0; /* 0.1 A per 10 ms tick */
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    calib_flags_t f;
    /* target 1 mT = 0.5 A on z: 0.1, 0.2, 0.3, 0.4, 0.5 A -> k * 1310.68 rounded */
    const uint16_t expected[5] = {32768 + 1311, 32768 + 2621, 32768 + 3932, 32768 + 5243,
                                  32768 + 6553};
    for (int k = 0; k < 5; ++k) {
        codes_for(&c, 0, 0, 1.0, codes, &f);
        assert_int_equal(codes[2], expected[k]);
        assert_int_equal(f.slew_limited, k < 4 ? 0x4 : 0x0);
    }
    /* back to zero field: slews down too */
    codes_for(&c, 0, 0, 0, codes, &f);
    assert_int_equal(codes[2], 32768 + 5243);
    calib_reset(&c); /* after the safe state the slew starts again from 0 A */
    codes_for(&c, 0, 0, 1.0, codes, &f);
    assert_int_equal(codes[2], 32768 + 1311);
}

static void test_round_half_away(void **state)
{
    (void)state;
    assert_true(calib_round_half_away(2.5) == 3.0);
    assert_true(calib_round_half_away(-2.5) == -3.0);
    assert_true(calib_round_half_away(2.4999) == 2.0);
    assert_true(calib_round_half_away(-0.5) == -1.0);
    assert_true(calib_round_half_away(-0.49) == 0.0);
    assert_true(calib_round_half_away(1e300) == 1e300);
}

static void test_invalid_calibrations(void **state)
{
    (void)state;
    calib_t c;
    uint16_t codes[3];
    calib_params_t p = base_params();
    p.actuation_T_per_A[2][0] = 0;
    p.actuation_T_per_A[2][2] = 0; /* singular: z coil produces no field */
    assert_int_equal(calib_init(&c, &p), CALIB_ERR_SINGULAR);
    codes_for(&c, 1.0, 1.0, 1.0, codes, NULL);
    assert_int_equal(codes[0], CALIB_DAC_MIDSCALE); /* invalid -> safe mid-scale */
    p = base_params();
    p.current_limit_A[1] = 0.0;
    assert_int_equal(calib_init(&c, &p), CALIB_ERR_NOT_POSITIVE);
    p = base_params();
    p.input_offset_V[0] = NAN;
    assert_int_equal(calib_init(&c, &p), CALIB_ERR_NOT_FINITE);
    p = base_params();
    p.transconductance_A_per_V[0] = 0.0;
    assert_int_equal(calib_init(&c, &p), CALIB_ERR_NOT_POSITIVE);
    assert_string_equal(calib_status_name(CALIB_ERR_SINGULAR), "singular");
}

static void test_non_finite_field_is_midscale(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    codes_for(&c, INFINITY, 1.0, 1.0, codes, NULL);
    assert_int_equal(codes[1], CALIB_DAC_MIDSCALE);
}

/* ---- coil-current rows: the tail of the field path without the matrix ---- */

static void currents_for(calib_t *c, double x, double y, double z, uint16_t out[3],
                         calib_flags_t *f)
{
    const double amps[3] = {x, y, z};
    calib_currents_to_codes(c, amps, out, f);
}

static void test_current_row_hand_values(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    p.input_offset_V[0] = 0.01;          /* 0.5 A / 1 A/V + 0.01 V = 0.51 V -> 6684.468 -> 6684 */
    p.transconductance_A_per_V[1] = 2.0; /* -0.5 A / 2 A/V = -0.25 V -> -3276.7 -> -3277 */
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    calib_flags_t f;
    currents_for(&c, 0.5, -0.5, 0.2, codes, &f); /* 0.2 V -> 2621.36 -> 2621 */
    assert_int_equal(codes[0], 32768 + 6684);
    assert_int_equal(codes[1], 32768 - 3277);
    assert_int_equal(codes[2], 32768 + 2621);
    assert_int_equal(f.current_limited | f.slew_limited | f.code_clamped, 0);
    currents_for(&c, 0, 0, 0, codes, NULL); /* 0 A: the offset's code, not mid-scale */
    assert_int_equal(codes[0], 32768 + 131);  /* 0.01 V -> 131.068 */
    assert_int_equal(codes[1], 32768);
}

static void test_current_row_ignores_the_matrix(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    p.actuation_T_per_A[0][1] = 1e-3; /* a coupled matrix changes field rows, not current rows */
    p.actuation_T_per_A[2][0] = -5e-4;
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    currents_for(&c, 0.5, 0, 0, codes, NULL);
    assert_int_equal(codes[0], 32768 + 6553);
    assert_int_equal(codes[1], 32768);
    assert_int_equal(codes[2], 32768);
}

static void test_current_row_clamps_at_the_current_limit(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    p.current_limit_A[0] = 1.0;
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    calib_flags_t f;
    currents_for(&c, 5.0, 1.0, 0, codes, &f); /* x: 1 A = 1 V -> 13106.8 -> 13107; y at its limit */
    assert_int_equal(codes[0], 32768 + 13107);
    assert_int_equal(codes[1], 32768 + 13107);
    assert_int_equal(f.current_limited, 0x1);
    currents_for(&c, -5.0, 0, 0, codes, &f); /* slew 10 A/tick allows the full swing */
    assert_int_equal(codes[0], 32768 - 13107);
    assert_int_equal(f.current_limited, 0x1);
}

static void test_current_row_slews_at_the_slew_limit(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    p.slew_limit_A_per_s[2] = 10.0; /* 0.1 A per 10 ms tick */
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    calib_flags_t f;
    /* 0.5 A asked on z: 0.1, 0.2, 0.3, 0.4, 0.5 A -> k * 1310.68 rounded */
    const uint16_t expected[5] = {32768 + 1311, 32768 + 2621, 32768 + 3932, 32768 + 5243,
                                  32768 + 6553};
    for (int k = 0; k < 5; ++k) {
        currents_for(&c, 0, 0, 0.5, codes, &f);
        assert_int_equal(codes[2], expected[k]);
        assert_int_equal(f.slew_limited, k < 4 ? 0x4 : 0x0);
    }
    currents_for(&c, 0, 0, -0.5, codes, &f); /* down again, 0.1 A per tick */
    assert_int_equal(codes[2], 32768 + 5243);
    assert_int_equal(f.slew_limited, 0x4);
}

static void test_current_row_code_clamp(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    p.dac_half_span_V = 0.5; /* 2 A = 2 V is far beyond full scale */
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    calib_flags_t f;
    currents_for(&c, 2.0, -2.0, 0.0, codes, &f);
    assert_int_equal(codes[0], CALIB_DAC_CODE_MAX);
    assert_int_equal(codes[1], CALIB_DAC_CODE_MIN);
    assert_int_equal(f.code_clamped, 0x3);
}

static void test_non_finite_current_is_midscale(void **state)
{
    (void)state;
    calib_params_t p = base_params();
    p.slew_limit_A_per_s[0] = 10.0;
    calib_t c;
    assert_int_equal(calib_init(&c, &p), CALIB_OK);
    uint16_t codes[3];
    calib_flags_t f = {7, 7, 7};
    currents_for(&c, 0.5, 0, 0, codes, NULL); /* 0.1 A after one tick */
    const double bad[3] = {NAN, INFINITY, -INFINITY};
    for (int k = 0; k < 3; ++k) {
        double amps[3] = {0.1, 0.1, 0.1};
        amps[k] = bad[k];
        calib_currents_to_codes(&c, amps, codes, &f);
        for (int i = 0; i < 3; ++i) {
            assert_int_equal(codes[i], CALIB_DAC_MIDSCALE);
        }
        assert_int_equal(f.current_limited | f.slew_limited | f.code_clamped, 0);
    }
    currents_for(&c, 0.5, 0, 0, codes, NULL); /* the slew history is left as it was: 0.2 A */
    assert_int_equal(codes[0], 32768 + 2621);
    c.valid = false; /* an invalid calibration: mid-scale whatever the current */
    currents_for(&c, 0.5, 0.5, 0.5, codes, NULL);
    assert_int_equal(codes[0], CALIB_DAC_MIDSCALE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_zero_field_is_midscale),
        cmocka_unit_test(test_hand_values),
        cmocka_unit_test(test_offset_and_transconductance),
        cmocka_unit_test(test_coupled_matrix_inverse),
        cmocka_unit_test(test_invert_general),
        cmocka_unit_test(test_current_limit),
        cmocka_unit_test(test_code_clamp),
        cmocka_unit_test(test_slew_limit),
        cmocka_unit_test(test_round_half_away),
        cmocka_unit_test(test_invalid_calibrations),
        cmocka_unit_test(test_non_finite_field_is_midscale),
        cmocka_unit_test(test_current_row_hand_values),
        cmocka_unit_test(test_current_row_ignores_the_matrix),
        cmocka_unit_test(test_current_row_clamps_at_the_current_limit),
        cmocka_unit_test(test_current_row_slews_at_the_slew_limit),
        cmocka_unit_test(test_current_row_code_clamp),
        cmocka_unit_test(test_non_finite_current_is_midscale),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

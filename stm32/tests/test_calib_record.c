/* Calibration record: CRC-32, encoding (identical to the host's), and every refusal reason. */
#include "test_common.h"
#include "test_calib.h"

#include <math.h>
#include <string.h>

#include "calib_record.h"
#include "crc32.h"

/* elastica_magnetic.hardware.protocol.calibration_hash of k_test_calib named "test". */
#define HOST_HASH_OF_TEST_CALIB 0xc3b045e6u

static calib_named_t named(void)
{
    calib_named_t c;
    memset(&c, 0, sizeof c);
    c.params = k_test_calib;
    strcpy(c.name, "test");
    return c;
}

static void test_crc32_check_value(void **state)
{
    (void)state;
    assert_int_equal(crc32((const uint8_t *)"123456789", 9), 0xCBF43926u);
}

static void test_roundtrip_and_host_hash(void **state)
{
    (void)state;
    calib_named_t c = named();
    uint8_t bytes[CALIB_RECORD_BYTES];
    calib_record_encode(&c, bytes);
    calib_named_t back;
    calib_record_decode(bytes, &back);
    assert_memory_equal(&back.params, &c.params, sizeof c.params);
    assert_string_equal(back.name, "test");
    assert_int_equal(calib_record_hash(&c), HOST_HASH_OF_TEST_CALIB);
    /* little-endian doubles: 2e-3 = 0x3F60624DD2F1A9FC */
    static const uint8_t first[8] = {0xFC, 0xA9, 0xF1, 0xD2, 0x4D, 0x62, 0x60, 0x3F};
    assert_memory_equal(bytes, first, sizeof first);
    assert_int_equal(calib_record_check(&c), CALREC_OK);
}

static void expect(calib_named_t c, calrec_status_t status, const char *name)
{
    assert_int_equal(calib_record_check(&c), status);
    assert_string_equal(calrec_status_name(status), name);
}

static void test_each_refusal_reason(void **state)
{
    (void)state;
    calib_named_t c = named();
    c.params.actuation_T_per_A[1][2] = NAN;
    expect(c, CALREC_NOT_FINITE, "not-finite");
    c = named();
    c.params.slew_limit_A_per_s[0] = 0.0;
    expect(c, CALREC_NOT_POSITIVE, "not-positive");
    c = named();
    c.params.actuation_T_per_A[2][2] = 0.0;
    expect(c, CALREC_SINGULAR, "singular");
    c = named(); /* x and y coils nearly parallel: condition number ~200 */
    c.params.actuation_T_per_A[0][1] = 1.98e-3;
    c.params.actuation_T_per_A[1][0] = 1.98e-3;
    expect(c, CALREC_ILL_CONDITIONED, "ill-conditioned");
    c = named();
    c.params.current_limit_A[2] = 2400.0; /* mA written as A */
    expect(c, CALREC_OVER_RATING, "over-rating");
    c = named();
    c.params.dac_half_span_V = 5.0;
    expect(c, CALREC_OVER_RATING, "over-rating");
    c = named();
    c.params.tick_hz = 1000.0;
    expect(c, CALREC_TICK_RATE, "tick-rate");
    c = named();
    c.name[0] = '\0';
    expect(c, CALREC_BAD_NAME, "bad-name");
    c = named();
    strcpy(c.name, "a b");
    expect(c, CALREC_BAD_NAME, "bad-name");
    c = named();
    memset(c.name, 'a', sizeof c.name); /* unterminated */
    expect(c, CALREC_BAD_NAME, "bad-name");
}

static void test_condition_number(void **state)
{
    (void)state;
    assert_true(fabs(calib_condition_1norm(k_test_calib.actuation_T_per_A) - 1.0) < 1e-12);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_crc32_check_value),
        cmocka_unit_test(test_roundtrip_and_host_hash),
        cmocka_unit_test(test_each_refusal_reason),
        cmocka_unit_test(test_condition_number),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

#include "test_common.h"

#include <string.h>

#include "crc16.h"

/* CRC-16/CCITT-FALSE check value from the CRC catalogue. */
#define CHECK_INPUT "123456789"
#define CHECK_VALUE 0x29B1u

static void test_check_value(void **state)
{
    (void)state;
    assert_int_equal(crc16((const uint8_t *)CHECK_INPUT, strlen(CHECK_INPUT)), CHECK_VALUE);
}

static void test_empty_is_init(void **state)
{
    (void)state;
    assert_int_equal(crc16((const uint8_t *)"", 0), CRC16_INIT);
}

static void test_chained_equals_whole(void **state)
{
    (void)state;
    const uint8_t *s = (const uint8_t *)"12,0.5,-1e-3,2";
    size_t n = strlen((const char *)s);
    uint16_t part = crc16_update(crc16_update(CRC16_INIT, s, 5), s + 5, n - 5);
    assert_int_equal(part, crc16(s, n));
}

static void test_single_bit_flip_detected(void **state)
{
    (void)state;
    uint8_t buf[] = "3,0.25,0.5,0.75";
    uint16_t good = crc16(buf, sizeof buf - 1);
    buf[4] ^= 0x01u;
    assert_int_not_equal(crc16(buf, sizeof buf - 1), good);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_check_value),
        cmocka_unit_test(test_empty_is_init),
        cmocka_unit_test(test_chained_equals_whole),
        cmocka_unit_test(test_single_bit_flip_detected),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

#include "test_common.h"

#include "dac8563.h"
#include "fake_board.h"

static int setup(void **state)
{
    (void)state;
    fake_reset();
    return 0;
}

/* Every command's frame, checked against the datasheet layout: DB21-19 cmd, DB18-16 addr. */
static void test_frames_per_command(void **state)
{
    (void)state;
    assert_int_equal(dac8563_frame(DAC8563_CMD_WRITE_INPUT, DAC8563_ADDR_A, 0x1234), 0x001234);
    assert_int_equal(dac8563_frame(DAC8563_CMD_WRITE_INPUT, DAC8563_ADDR_B, 0xFFFF), 0x01FFFF);
    assert_int_equal(dac8563_frame(DAC8563_CMD_SOFTWARE_LDAC, DAC8563_ADDR_BOTH, 0), 0x0F0000);
    assert_int_equal(dac8563_frame(DAC8563_CMD_WRITE_INPUT_UPDATE_ALL, DAC8563_ADDR_A, 0x8000),
                     0x108000);
    assert_int_equal(dac8563_frame(DAC8563_CMD_WRITE_UPDATE, DAC8563_ADDR_BOTH, 0x0001), 0x1F0001);
    assert_int_equal(dac8563_frame(DAC8563_CMD_POWER, DAC8563_ADDR_UNUSED,
                                   DAC8563_POWER_UP_A_AND_B), 0x200003);
    assert_int_equal(dac8563_frame(DAC8563_CMD_SOFTWARE_RESET, DAC8563_ADDR_UNUSED,
                                   DAC8563_RESET_ALL_REGISTERS), 0x280001);
    assert_int_equal(dac8563_frame(DAC8563_CMD_LDAC_REGISTER, DAC8563_ADDR_UNUSED,
                                   DAC8563_LDAC_PIN_CONTROLS_A_AND_B), 0x300000);
    assert_int_equal(dac8563_frame(DAC8563_CMD_INTERNAL_REFERENCE, DAC8563_ADDR_UNUSED,
                                   DAC8563_INTERNAL_REFERENCE_ON), 0x380001);
    assert_int_equal(dac8563_frame(DAC8563_CMD_WRITE_INPUT, DAC8563_ADDR_GAIN, 0), 0x020000);
    /* out-of-range fields are masked, never spill into neighbours */
    assert_int_equal(dac8563_frame(0xF, 0xF, 0x1FFFF), 0x3FFFFF);
}

static void test_frame_bytes_msb_first(void **state)
{
    (void)state;
    uint8_t b[3];
    dac8563_frame_bytes(0x38ABCD, b);
    assert_int_equal(b[0], 0x38);
    assert_int_equal(b[1], 0xAB);
    assert_int_equal(b[2], 0xCD);
}

static void expect_spi(size_t i, unsigned chip, uint32_t frame)
{
    assert_true(i < fake.n_events);
    assert_int_equal(fake.events[i].kind, FAKE_EV_SPI);
    assert_int_equal(fake.events[i].chip, chip);
    assert_int_equal(fake.events[i].frame, frame);
}

static void test_init_sequence(void **state)
{
    (void)state;
    assert_true(dac_bank_init());
    size_t i = 0;
    for (unsigned chip = 0; chip < 2; ++chip) {
        expect_spi(i++, chip, 0x280001); /* reset */
        expect_spi(i++, chip, 0x200003); /* power up A and B */
        expect_spi(i++, chip, 0x380001); /* internal reference on */
        expect_spi(i++, chip, 0x300000); /* both channels follow LDAC */
    }
    assert_int_equal(fake.events[i++].kind, FAKE_EV_CLR);
    expect_spi(i++, 0, 0x008000);
    expect_spi(i++, 0, 0x018000);
    expect_spi(i++, 1, 0x008000);
    assert_int_equal(fake.events[i++].kind, FAKE_EV_LDAC);
    assert_int_equal(fake.n_events, i);
}

static void test_write_updates_all_axes_together(void **state)
{
    (void)state;
    const uint16_t codes[3] = {0x1111, 0x2222, 0x3333};
    assert_true(dac_bank_write(codes));
    assert_int_equal(fake.n_events, 4);
    expect_spi(0, 0, 0x001111); /* x: chip 0, A */
    expect_spi(1, 0, 0x012222); /* y: chip 0, B */
    expect_spi(2, 1, 0x003333); /* z: chip 1, A */
    assert_int_equal(fake.events[3].kind, FAKE_EV_LDAC); /* one LDAC after all inputs */
}

static void test_spi_failure_never_pulses_ldac(void **state)
{
    (void)state;
    const uint16_t codes[3] = {1, 2, 3};
    fake.spi_fails = true;
    assert_false(dac_bank_write(codes));
    assert_int_equal(fake.n_events, 0);
    assert_false(dac_bank_safe());
    assert_int_equal(fake.n_events, 1);
    assert_int_equal(fake.events[0].kind, FAKE_EV_CLR); /* hardware clear still happens */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_frames_per_command, setup),
        cmocka_unit_test_setup(test_frame_bytes_msb_first, setup),
        cmocka_unit_test_setup(test_init_sequence, setup),
        cmocka_unit_test_setup(test_write_updates_all_axes_together, setup),
        cmocka_unit_test_setup(test_spi_failure_never_pulses_ldac, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

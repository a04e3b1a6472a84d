/* Two flash slots: newest valid one wins, and a power loss at any byte of a save leaves either
 * the previous or the new calibration loadable, never none and never a mix. */
#include "test_common.h"
#include "test_calib.h"

#include <string.h>

#include "calib_store.h"
#include "fake_board.h"

static calib_named_t named(const char *name, double gain)
{
    calib_named_t c;
    memset(&c, 0, sizeof c);
    c.params = k_test_calib;
    c.params.transconductance_A_per_V[0] = gain;
    strcpy(c.name, name);
    return c;
}

static int setup(void **state)
{
    (void)state;
    fake_flash_blank();
    return 0;
}

static void test_blank_flash_holds_none(void **state)
{
    (void)state;
    calib_named_t c;
    unsigned slot;
    uint32_t seq;
    assert_false(calib_store_load(&c, &slot, &seq));
}

static void test_saves_alternate_slots(void **state)
{
    (void)state;
    calib_named_t got;
    unsigned slot, written;
    uint32_t seq;
    const char *names[] = {"one", "two", "three"};
    for (unsigned k = 0; k < 3; ++k) {
        calib_named_t c = named(names[k], 1.0 + k);
        assert_int_equal(calib_store_save(&c, &written), CALIB_STORE_OK);
        assert_int_equal(written, k % 2u);
        assert_true(calib_store_load(&got, &slot, &seq));
        assert_string_equal(got.name, names[k]);
        assert_int_equal(slot, k % 2u);
        assert_int_equal(seq, k + 1u);
        assert_true(got.params.transconductance_A_per_V[0] == 1.0 + k);
    }
}

static void test_power_loss_at_every_byte(void **state)
{
    (void)state;
    for (uint32_t budget = 0; budget <= CALIB_STORE_SLOT_BYTES; ++budget) {
        fake_flash_blank();
        calib_named_t old = named("old", 1.5);
        calib_named_t fresh = named("fresh", 2.5);
        unsigned written, slot;
        uint32_t seq;
        assert_int_equal(calib_store_save(&old, &written), CALIB_STORE_OK);
        fake_flash.program_budget = budget;
        calib_store_status_t st = calib_store_save(&fresh, &written);
        calib_named_t got;
        assert_true(calib_store_load(&got, &slot, &seq));
        if (budget < CALIB_STORE_SLOT_BYTES) {
            assert_int_equal(st, CALIB_STORE_PROGRAM_FAILED);
            assert_string_equal(got.name, "old");
        } else {
            assert_int_equal(st, CALIB_STORE_OK);
            assert_string_equal(got.name, "fresh");
        }
    }
}

static void test_corrupted_slot_falls_back(void **state)
{
    (void)state;
    calib_named_t a = named("a", 1.5), b = named("b", 2.5), got;
    unsigned written, slot;
    uint32_t seq;
    assert_int_equal(calib_store_save(&a, &written), CALIB_STORE_OK);
    assert_int_equal(calib_store_save(&b, &written), CALIB_STORE_OK);
    fake_flash.slot[written][CALIB_STORE_HEADER_BYTES + 3] ^= 0x01u; /* a bit flips in b */
    assert_true(calib_store_load(&got, &slot, &seq));
    assert_string_equal(got.name, "a");
    fake_flash.erase_fails = true;
    assert_int_equal(calib_store_save(&b, &written), CALIB_STORE_ERASE_FAILED);
    assert_string_equal(calib_store_status_name(CALIB_STORE_ERASE_FAILED), "flash-erase");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_blank_flash_holds_none, setup),
        cmocka_unit_test_setup(test_saves_alternate_slots, setup),
        cmocka_unit_test_setup(test_power_loss_at_every_byte, setup),
        cmocka_unit_test_setup(test_corrupted_slot_falls_back, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

#include "test_common.h"

#include "ring.h"

static ring_t ring;

static void test_fifo_order_and_wrap(void **state)
{
    (void)state;
    ring_init(&ring);
    uint8_t b;
    assert_false(ring_get(&ring, &b));
    for (unsigned round = 0; round < 3; ++round) {
        for (unsigned i = 0; i < RING_SIZE / 2; ++i) {
            assert_true(ring_put(&ring, (uint8_t)(i + round)));
        }
        assert_int_equal(ring_count(&ring), RING_SIZE / 2);
        for (unsigned i = 0; i < RING_SIZE / 2; ++i) {
            assert_true(ring_get(&ring, &b));
            assert_int_equal(b, (uint8_t)(i + round));
        }
    }
    assert_int_equal(ring.dropped, 0);
}

static void test_full_drops_and_counts(void **state)
{
    (void)state;
    ring_init(&ring);
    for (unsigned i = 0; i < RING_SIZE - 1; ++i) {
        assert_true(ring_put(&ring, 0xAA));
    }
    assert_false(ring_put(&ring, 0xBB));
    assert_false(ring_put(&ring, 0xBB));
    assert_int_equal(ring.dropped, 2);
    assert_int_equal(ring_count(&ring), RING_SIZE - 1);
    uint8_t b;
    assert_true(ring_get(&ring, &b));
    assert_int_equal(b, 0xAA);
    assert_true(ring_put(&ring, 0xCC));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fifo_order_and_wrap),
        cmocka_unit_test(test_full_drops_and_counts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

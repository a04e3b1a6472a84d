#include "test_common.h"

#include "scheduler.h"

static void check(uint32_t clock, uint32_t psc, uint32_t arr)
{
    sched_timer_cfg_t cfg;
    assert_true(sched_timer_config(clock, SCHED_TICK_HZ, &cfg));
    assert_int_equal(cfg.prescaler, psc);
    assert_int_equal(cfg.reload, arr);
    assert_int_equal((uint64_t)(cfg.prescaler + 1) * (cfg.reload + 1) * SCHED_TICK_HZ, clock);
    assert_true(cfg.reload <= SCHED_RELOAD_MAX);
}

static void test_real_and_emulated_clocks(void **state)
{
    (void)state;
    check(84000000u, 13u, 59999u);    /* APB1 timers with the 168 MHz PLL */
    check(16000000u, 3u, 39999u);     /* HSI fallback */
    check(1000000000u, 159u, 62499u); /* QEMU -icount: timers count at 1 GHz */
}

static void test_impossible_rates(void **state)
{
    (void)state;
    sched_timer_cfg_t cfg;
    assert_false(sched_timer_config(1001u, SCHED_TICK_HZ, &cfg)); /* not a multiple */
    assert_false(sched_timer_config(84000000u, 0u, &cfg));
    assert_false(sched_timer_config(50u, SCHED_TICK_HZ, &cfg));
    /* a prime count above 65536 has no 16-bit factorisation */
    assert_false(sched_timer_config(65537u * 100u, SCHED_TICK_HZ, &cfg));
}

static void test_ticks_taken_once(void **state)
{
    (void)state;
    sched_ticks_t t;
    sched_ticks_init(&t);
    assert_int_equal(sched_ticks_take(&t), 0);
    sched_ticks_raise(&t);
    sched_ticks_raise(&t);
    assert_int_equal(sched_ticks_take(&t), 2);
    assert_int_equal(sched_ticks_take(&t), 0);
    t.raised = UINT32_MAX; /* wrap-around of the counter */
    t.taken = UINT32_MAX;
    sched_ticks_raise(&t);
    assert_int_equal(sched_ticks_take(&t), 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_real_and_emulated_clocks),
        cmocka_unit_test(test_impossible_rates),
        cmocka_unit_test(test_ticks_taken_once),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

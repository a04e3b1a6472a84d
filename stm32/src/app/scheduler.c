#include "scheduler.h"

bool sched_timer_config(uint32_t timer_clock_hz, uint32_t tick_hz, sched_timer_cfg_t *cfg)
{
    if (tick_hz == 0u || timer_clock_hz < tick_hz || timer_clock_hz % tick_hz != 0u) {
        return false;
    }
    uint32_t counts = timer_clock_hz / tick_hz;
    for (uint32_t psc = 0; psc <= SCHED_PRESCALER_MAX; ++psc) {
        uint32_t div = psc + 1u;
        if (counts % div == 0u && counts / div - 1u <= SCHED_RELOAD_MAX) {
            cfg->prescaler = psc;
            cfg->reload = counts / div - 1u;
            return true;
        }
    }
    return false;
}

void sched_ticks_init(sched_ticks_t *ticks)
{
    ticks->raised = 0;
    ticks->taken = 0;
}

void sched_ticks_raise(sched_ticks_t *ticks)
{
    ticks->raised = ticks->raised + 1u;
}

uint32_t sched_ticks_take(sched_ticks_t *ticks)
{
    uint32_t raised = ticks->raised; /* single aligned load: atomic on Cortex-M */
    uint32_t n = raised - ticks->taken;
    ticks->taken = raised;
    return n;
}

/**
 * @file scheduler.h
 * The 100 Hz tick: timer prescaler/reload arithmetic (pure, host-tested) and the tick count
 * handed from the timer interrupt to the main loop, which runs one tick function per tick.
 */
#ifndef MSR_SCHEDULER_H
#define MSR_SCHEDULER_H

#include <stdbool.h>
#include <stdint.h>

/** Field update rate of the paper's CSV: one row per 10 ms. */
#define SCHED_TICK_HZ 100u
/** The prescaler register is 16 bits wide on every STM32F4 timer. */
#define SCHED_PRESCALER_MAX 0xFFFFu
/** Keep the reload within 16 bits so any timer (TIM2..TIM5) works. */
#define SCHED_RELOAD_MAX 0xFFFFu

typedef struct {
    uint32_t prescaler;   /**< PSC register: counter clock = timer clock / (PSC + 1) */
    uint32_t reload;      /**< ARR register: update every ARR + 1 counts */
} sched_timer_cfg_t;

/**
 * Choose PSC and ARR so that timer_clock_hz / ((PSC+1)(ARR+1)) == tick_hz exactly, with the
 * smallest prescaler. False when no exact setting exists.
 */
bool sched_timer_config(uint32_t timer_clock_hz, uint32_t tick_hz, sched_timer_cfg_t *cfg);

/** Ticks raised by the interrupt and taken by the main loop. */
typedef struct {
    volatile uint32_t raised;
    uint32_t taken;
} sched_ticks_t;

void sched_ticks_init(sched_ticks_t *ticks);
/** Interrupt side: one timer update. */
void sched_ticks_raise(sched_ticks_t *ticks);
/** Main-loop side: ticks since the previous call. */
uint32_t sched_ticks_take(sched_ticks_t *ticks);

#endif

/**
 * @file startup_stm32f407.c
 * Vector table, reset handler (FPU on, .data copy, .bss zero, main) and fault handlers.
 * A fault drives the DACs to mid-scale through CLR, then waits for the watchdog reset.
 */
#include <stdint.h>

#include "board_stm32f4.h"
#include "stm32f4_regs.h"

extern uint32_t _estack;
extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss;

int main(void);
void Reset_Handler(void);
void Default_Handler(void);
void TIM2_IRQHandler(void);
void USART1_IRQHandler(void);

#define CORE_VECTORS 16u

void Reset_Handler(void)
{
    SCB_CPACR |= SCB_CPACR_CP10_CP11_FULL; /* FPU before any floating-point instruction */
    __asm volatile("dsb\n\tisb" ::: "memory");
    const uint32_t *src = &_sidata;
    for (uint32_t *dst = &_sdata; dst < &_edata;) {
        *dst++ = *src++;
    }
    for (uint32_t *dst = &_sbss; dst < &_ebss;) {
        *dst++ = 0u;
    }
    (void)main();
    for (;;) {
    }
}

void Default_Handler(void)
{
    board_fault_safe();
    for (;;) {
        /* no watchdog kick: the IWDG resets the chip, which reports "watchdog-reset" */
    }
}

typedef void (*vector_t)(void);

__attribute__((section(".isr_vector"), used))
const vector_t g_vectors[CORE_VECTORS + STM32F4_IRQ_COUNT] = {
    [0] = (vector_t)(uintptr_t)&_estack,
    [1] = Reset_Handler,
    [2] = Default_Handler,  /* NMI */
    [3] = Default_Handler,  /* HardFault */
    [4] = Default_Handler,  /* MemManage */
    [5] = Default_Handler,  /* BusFault */
    [6] = Default_Handler,  /* UsageFault */
    [11] = Default_Handler, /* SVCall */
    [12] = Default_Handler, /* DebugMon */
    [14] = Default_Handler, /* PendSV */
    [15] = Default_Handler, /* SysTick */
    [CORE_VECTORS + IRQ_TIM2] = TIM2_IRQHandler,
    [CORE_VECTORS + IRQ_USART1] = USART1_IRQHandler,
};

/**
 * @file board_stm32f4.h
 * Pin map and constants of the STM32F407 board layer (see docs/firmware.md for the wiring).
 */
#ifndef MSR_BOARD_STM32F4_H
#define MSR_BOARD_STM32F4_H

/* SPI1 (AF5): PA5 SCK, PA7 MOSI. MISO unused: the DAC8563 has no read-back. */
#define PIN_SPI1_SCK 5u
#define PIN_SPI1_MOSI 7u
/* DAC control lines, push-pull outputs idling high. */
#define PIN_SYNC_CHIP0 4u   /* PA4: SYNC of DAC8563 #1 (x, y) */
#define PIN_SYNC_CHIP1 12u  /* PB12: SYNC of DAC8563 #2 (z) */
#define PIN_LDAC 13u        /* PB13: shared LDAC */
#define PIN_CLR 14u         /* PB14: shared CLR */
/* USART1 (AF7): PA9 TX, PA10 RX. */
#define PIN_USART1_TX 9u
#define PIN_USART1_RX 10u

#define HOST_BAUD 115200u

/* Clock tree: 8 MHz crystal -> PLL 168 MHz SYSCLK, APB1 42 MHz (timers 84 MHz), APB2 84 MHz. */
#define HSE_HZ 8000000u
#define HSI_HZ 16000000u
#define PLL_M 8u
#define PLL_N 336u
#define PLL_P_DIV2 0u
#define PLL_Q 7u
#define SYSCLK_PLL_HZ 168000000u
#define APB1_TIMER_PLL_HZ 84000000u
#define APB2_PLL_HZ 84000000u
/** QEMU's STM32 timers count at 1 GHz under -icount (measured with QEMU 7.2). */
#define QEMU_TIMER_CLOCK_HZ 1000000000u
/** Polling iterations before a clock, SPI or UART wait gives up. */
#define CLOCK_START_TIMEOUT 200000u
#define SPI_TIMEOUT 10000u
#define UART_TX_TIMEOUT 100000u
/** Cycles the LDAC / CLR pulses stay low (datasheet minimum is tens of ns). */
#define PULSE_LOW_LOOPS 8u
/** IWDG: LSI 32 kHz / 32 = 1 kHz; reload 250 -> 250 ms without a kick resets the chip. */
#define IWDG_RELOAD_MS 250u
/** While a calibration slot is erased: the CPU stalls on flash reads for up to ~0.8 s (16 KB
 * sector, byte parallelism), so the watchdog period is widened for the erase only. */
#define IWDG_FLASH_ERASE_MS 2000u

/* Calibration slots: flash sectors 1 and 2 (16 KB each; linker/stm32f407.ld keeps code out). */
#define CALIB_SLOT_SECTOR_FIRST 1u
#define CALIB_SLOT0_ADDR 0x08004000u
#define CALIB_SLOT1_ADDR 0x08008000u
#define CALIB_SLOT_BYTES (CALIB_SLOT1_ADDR - CALIB_SLOT0_ADDR)
#define FLASH_ERASED_BYTE 0xFFu
#define FLASH_KICK_EVERY_POLLS 65536u
/* Polls of FLASH_SR.BSY: a 16 KB sector erase takes up to 500 ms (the watchdog is kicked). */
#define FLASH_TIMEOUT 100000000u
/* Under QEMU (no flash controller, no CCM RAM modelled): the slots are the last 2 KB of SRAM,
 * the EMU_SLOTS region of linker/stm32f407.ld, kept across a system reset. */
#define EMU_SLOT0_ADDR 0x2001F800u
#define EMU_SLOT_BYTES 0x400u

/** Fault path: CLR low (DACs to mid-scale) using registers only. */
void board_fault_safe(void);

#endif

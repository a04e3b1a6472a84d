/**
 * @file board.h
 * The one thin layer between the portable firmware logic and the hardware.
 *
 * src/board/board_stm32f4.c implements it with registers for the STM32F407 (and QEMU's
 * netduinoplus2); tests/fake_board.c implements it on the host for the unit tests.
 */
#ifndef MSR_BOARD_H
#define MSR_BOARD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/** What board_init() found. */
typedef struct {
    bool pll_locked;          /**< HSE + PLL started within their time-outs (168 MHz) */
    bool emulated;            /**< RCC reads as unmodelled (QEMU): HSI never reports ready */
    bool watchdog_reset;      /**< the last reset came from the independent watchdog */
    uint32_t timer_clock_hz;  /**< clock of the tick timer, see board_timer_clock_hz() */
} board_info_t;

/** Clocks (with time-outs), GPIO, SPI1, USART1 with RX interrupt, watchdog. */
void board_init(board_info_t *info);

/** Clock feeding the tick timer (84 MHz with the PLL, 16 MHz on HSI, 1 GHz under QEMU icount). */
uint32_t board_timer_clock_hz(void);

/** SYNC low on @p chip, clock out @p len bytes MSB first, wait until done, SYNC high. */
bool board_spi_write(unsigned chip, const uint8_t *data, size_t len);

/** Pulse the shared LDAC line low: every DAC register loads its input register. */
void board_ldac_pulse(void);

/** Pulse the shared CLR line low: the DAC8563s go to mid-scale. */
void board_clr_pulse(void);

/** Blocking write to the host UART (USART1). */
void board_uart_write(const char *text, size_t len);

/** Take one received byte from the interrupt-fed ring buffer; false when empty. */
bool board_uart_read(uint8_t *byte);

/** Bytes lost to ring-buffer overflow or UART overrun since boot. */
uint32_t board_uart_lost(void);

/** Start the periodic tick timer at @p tick_hz; false when the rate cannot be made exactly. */
bool board_tick_start(uint32_t tick_hz);

/** Number of ticks elapsed since the previous call (normally 0 or 1). */
uint32_t board_ticks_take(void);

/** Start the independent watchdog. */
void board_watchdog_start(void);

/** Reload the independent watchdog. */
void board_watchdog_kick(void);

/** Sleep until the next interrupt unless a byte or a tick is already waiting. */
void board_idle(void);

/* ------------------------------------------------------------------ calibration slots
 * Two non-volatile slots of at least CALIB_STORE_SLOT_BYTES (calib_store.h) each. On the F407
 * they are flash sectors 1 and 2; under QEMU, whose netduinoplus2 does not model the flash
 * controller, two areas at the top of SRAM that survive a system reset (not a power cycle). */

/** Erase slot @p slot (all bytes 0xFF); false on a time-out or error. */
bool board_calib_slot_erase(unsigned slot);

/** Program @p len bytes at @p offset of an erased slot; false on a time-out or error. */
bool board_calib_slot_program(unsigned slot, uint32_t offset, const uint8_t *data, size_t len);

/** The slot's bytes (memory-mapped), or NULL for a slot that does not exist. */
const uint8_t *board_calib_slot_read(unsigned slot);

/** Reset the microcontroller now (the RESET command): startup code, board_init, app_init. */
void board_system_reset(void);

#endif

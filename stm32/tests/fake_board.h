/* Host fake of board.h: records SPI frames, LDAC/CLR pulses and UART output in one event log. */
#ifndef MSR_FAKE_BOARD_H
#define MSR_FAKE_BOARD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "board.h"

#define FAKE_MAX_EVENTS 4096u
#define FAKE_UART_CAPACITY 65536u
#define FAKE_RX_CAPACITY 65536u

typedef enum { FAKE_EV_SPI, FAKE_EV_LDAC, FAKE_EV_CLR } fake_event_kind_t;

typedef struct {
    fake_event_kind_t kind;
    unsigned chip;
    uint32_t frame; /* 24-bit frame reassembled from the bytes sent */
} fake_event_t;

typedef struct {
    fake_event_t events[FAKE_MAX_EVENTS];
    size_t n_events;
    char uart[FAKE_UART_CAPACITY];
    size_t uart_len;
    uint8_t rx[FAKE_RX_CAPACITY];
    size_t rx_len, rx_pos;
    uint32_t ticks_pending;
    uint32_t lost;
    bool spi_fails;
    bool tick_start_ok;
    uint32_t watchdog_kicks;
} fake_board_t;

extern fake_board_t fake;

/** The calibration slots: kept across fake_reset() (like flash across a reset). */
#define FAKE_SLOT_BYTES 512u
#define FAKE_UNLIMITED 0xFFFFFFFFu
typedef struct {
    uint8_t slot[2][FAKE_SLOT_BYTES];
    uint32_t program_budget; /**< bytes programmable before a simulated power loss */
    bool erase_fails;
    uint32_t erases;
    uint32_t resets;         /**< board_system_reset() calls */
} fake_flash_t;

extern fake_flash_t fake_flash;

/** Blank slots (0xFF), unlimited budget. */
void fake_flash_blank(void);

void fake_reset(void);
void fake_rx_text(const char *text);
/** Count of UART lines starting with @p prefix. */
size_t fake_uart_count(const char *prefix);
/** Pointer to the n-th (0-based) UART line starting with @p prefix, or NULL. */
const char *fake_uart_find(const char *prefix, size_t nth);

#endif

#include "fake_board.h"

#include <string.h>

fake_board_t fake;

void fake_reset(void)
{
    memset(&fake, 0, sizeof fake);
    fake.tick_start_ok = true;
}

static void add_event(fake_event_kind_t kind, unsigned chip, uint32_t frame)
{
    if (fake.n_events < FAKE_MAX_EVENTS) {
        fake.events[fake.n_events].kind = kind;
        fake.events[fake.n_events].chip = chip;
        fake.events[fake.n_events].frame = frame;
        fake.n_events++;
    }
}

void board_init(board_info_t *info)
{
    info->pll_locked = true;
    info->emulated = false;
    info->watchdog_reset = false;
    info->timer_clock_hz = board_timer_clock_hz();
}

uint32_t board_timer_clock_hz(void) { return 84000000u; }

bool board_spi_write(unsigned chip, const uint8_t *data, size_t len)
{
    if (fake.spi_fails) {
        return false;
    }
    uint32_t frame = 0;
    for (size_t i = 0; i < len; ++i) {
        frame = (frame << 8) | data[i];
    }
    add_event(FAKE_EV_SPI, chip, frame);
    return true;
}

void board_ldac_pulse(void) { add_event(FAKE_EV_LDAC, 0, 0); }
void board_clr_pulse(void) { add_event(FAKE_EV_CLR, 0, 0); }

void board_uart_write(const char *text, size_t len)
{
    if (fake.uart_len + len < FAKE_UART_CAPACITY) {
        memcpy(fake.uart + fake.uart_len, text, len);
        fake.uart_len += len;
        fake.uart[fake.uart_len] = '\0';
    }
}

bool board_uart_read(uint8_t *byte)
{
    if (fake.rx_pos >= fake.rx_len) {
        return false;
    }
    *byte = fake.rx[fake.rx_pos++];
    return true;
}

uint32_t board_uart_lost(void) { return fake.lost; }
bool board_tick_start(uint32_t tick_hz) { (void)tick_hz; return fake.tick_start_ok; }

uint32_t board_ticks_take(void)
{
    uint32_t n = fake.ticks_pending;
    fake.ticks_pending = 0;
    return n;
}

void board_watchdog_start(void) {}
void board_watchdog_kick(void) { fake.watchdog_kicks++; }
void board_idle(void) {}

void fake_rx_text(const char *text)
{
    size_t n = strlen(text);
    if (fake.rx_len + n <= FAKE_RX_CAPACITY) {
        memcpy(fake.rx + fake.rx_len, text, n);
        fake.rx_len += n;
    }
}

const char *fake_uart_find(const char *prefix, size_t nth)
{
    size_t plen = strlen(prefix);
    const char *line = fake.uart;
    while (line < fake.uart + fake.uart_len) {
        if (strncmp(line, prefix, plen) == 0) {
            if (nth == 0) {
                return line;
            }
            --nth;
        }
        const char *nl = strchr(line, '\n');
        if (nl == NULL) {
            break;
        }
        line = nl + 1;
    }
    return NULL;
}

size_t fake_uart_count(const char *prefix)
{
    size_t n = 0;
    while (fake_uart_find(prefix, n) != NULL) {
        ++n;
    }
    return n;
}

fake_flash_t fake_flash;

void fake_flash_blank(void)
{
    memset(fake_flash.slot, 0xFF, sizeof fake_flash.slot);
    fake_flash.program_budget = FAKE_UNLIMITED;
    fake_flash.erase_fails = false;
    fake_flash.erases = 0;
    fake_flash.resets = 0;
}

bool board_calib_slot_erase(unsigned slot)
{
    if (slot >= 2u || fake_flash.erase_fails) {
        return false;
    }
    memset(fake_flash.slot[slot], 0xFF, FAKE_SLOT_BYTES);
    fake_flash.erases++;
    return true;
}

bool board_calib_slot_program(unsigned slot, uint32_t offset, const uint8_t *data, size_t len)
{
    if (slot >= 2u || offset + len > FAKE_SLOT_BYTES) {
        return false;
    }
    for (size_t i = 0; i < len; ++i) {
        if (fake_flash.program_budget == 0u) {
            return false; /* power lost: the rest of the bytes stay erased */
        }
        if (fake_flash.program_budget != FAKE_UNLIMITED) {
            fake_flash.program_budget--;
        }
        fake_flash.slot[slot][offset + i] &= data[i]; /* flash programs 1 -> 0 only */
    }
    return true;
}

const uint8_t *board_calib_slot_read(unsigned slot)
{
    return slot < 2u ? fake_flash.slot[slot] : NULL;
}

void board_system_reset(void) { fake_flash.resets++; }

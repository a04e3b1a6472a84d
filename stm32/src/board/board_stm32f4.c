/**
 * @file board_stm32f4.c
 * board.h on the STM32F407 (registers only). Also runs unchanged on QEMU's netduinoplus2, which
 * models USART1, SPI1 and TIM2 but not RCC or GPIO: every wait has a time-out, and an RCC that
 * never reports the always-on HSI as ready identifies the emulator (timers at 1 GHz there).
 */
#include "board.h"

#include "board_stm32f4.h"
#include "ring.h"
#include "scheduler.h"
#include "stm32f4_regs.h"

static ring_t g_rx;
static volatile uint32_t g_rx_overruns;
static sched_ticks_t g_ticks;
static uint32_t g_timer_clock_hz = HSI_HZ;
static uint32_t g_apb2_hz = HSI_HZ;
static bool g_emulated;

static bool wait_set(volatile uint32_t *reg, uint32_t mask, uint32_t timeout)
{
    for (uint32_t i = 0; i < timeout; ++i) {
        if ((*reg & mask) != 0u) {
            return true;
        }
    }
    return false;
}

static bool wait_clear(volatile uint32_t *reg, uint32_t mask, uint32_t timeout)
{
    for (uint32_t i = 0; i < timeout; ++i) {
        if ((*reg & mask) == 0u) {
            return true;
        }
    }
    return false;
}

static bool clock_start_pll(void)
{
    RCC_CR |= RCC_CR_HSEON;
    if (!wait_set(&RCC_CR, RCC_CR_HSERDY, CLOCK_START_TIMEOUT)) {
        RCC_CR &= ~RCC_CR_HSEON;
        return false;
    }
    RCC_PLLCFGR = (PLL_M << RCC_PLLCFGR_PLLM_SHIFT) | (PLL_N << RCC_PLLCFGR_PLLN_SHIFT) |
                  (PLL_P_DIV2 << RCC_PLLCFGR_PLLP_SHIFT) | RCC_PLLCFGR_PLLSRC_HSE |
                  (PLL_Q << RCC_PLLCFGR_PLLQ_SHIFT);
    RCC_CR |= RCC_CR_PLLON;
    if (!wait_set(&RCC_CR, RCC_CR_PLLRDY, CLOCK_START_TIMEOUT)) {
        RCC_CR &= ~RCC_CR_PLLON;
        return false;
    }
    FLASH_ACR = FLASH_ACR_LATENCY_5WS | FLASH_ACR_PRFTEN | FLASH_ACR_ICEN | FLASH_ACR_DCEN;
    RCC_CFGR = (RCC_CFGR_PPRE_DIV4 << RCC_CFGR_PPRE1_SHIFT) |
               (RCC_CFGR_PPRE_DIV2 << RCC_CFGR_PPRE2_SHIFT) | RCC_CFGR_SW_PLL;
    for (uint32_t i = 0; i < CLOCK_START_TIMEOUT; ++i) {
        if (((RCC_CFGR >> RCC_CFGR_SWS_SHIFT) & RCC_CFGR_SW_MASK) == RCC_CFGR_SW_PLL) {
            return true;
        }
    }
    RCC_CFGR = 0u; /* back to HSI with no prescalers */
    return false;
}

static void gpio_mode(uint32_t base, uint32_t pin, uint32_t mode)
{
    uint32_t shift = pin * GPIO_MODE_BITS;
    GPIO_MODER(base) = (GPIO_MODER(base) & ~(GPIO_MODE_MASK << shift)) | (mode << shift);
    GPIO_OSPEEDR(base) |= GPIO_SPEED_HIGH << shift;
}

static void gpio_af(uint32_t base, uint32_t pin, uint32_t af)
{
    gpio_mode(base, pin, GPIO_MODE_AF);
    volatile uint32_t *afr = pin < GPIO_PINS_PER_AFR ? &GPIO_AFRL(base) : &GPIO_AFRH(base);
    uint32_t shift = (pin % GPIO_PINS_PER_AFR) * GPIO_AF_BITS;
    *afr = (*afr & ~(GPIO_AF_MASK << shift)) | (af << shift);
}

static void gpio_high(uint32_t base, uint32_t pin) { GPIO_BSRR(base) = BIT(pin); }
static void gpio_low(uint32_t base, uint32_t pin) { GPIO_BSRR(base) = BIT(pin + GPIO_BSRR_RESET_SHIFT); }

static void short_delay(void)
{
    for (volatile uint32_t i = 0; i < PULSE_LOW_LOOPS; ++i) {
    }
}

static void nvic_enable(uint32_t irq)
{
    NVIC_ISER(irq / NVIC_IRQS_PER_ISER) = BIT(irq % NVIC_IRQS_PER_ISER);
}

void board_init(board_info_t *info)
{
    info->watchdog_reset = (RCC_CSR & RCC_CSR_IWDGRSTF) != 0u;
    RCC_CSR |= RCC_CSR_RMVF;
    info->emulated = !wait_set(&RCC_CR, RCC_CR_HSIRDY, CLOCK_START_TIMEOUT);
    g_emulated = info->emulated;
    info->pll_locked = !info->emulated && clock_start_pll();
    if (info->emulated) {
        g_timer_clock_hz = QEMU_TIMER_CLOCK_HZ;
    } else if (info->pll_locked) {
        g_timer_clock_hz = APB1_TIMER_PLL_HZ;
        g_apb2_hz = APB2_PLL_HZ;
    }
    info->timer_clock_hz = g_timer_clock_hz;

    RCC_AHB1ENR |= RCC_AHB1ENR_GPIOAEN | RCC_AHB1ENR_GPIOBEN;
    RCC_APB1ENR |= RCC_APB1ENR_TIM2EN;
    RCC_APB2ENR |= RCC_APB2ENR_USART1EN | RCC_APB2ENR_SPI1EN;

    /* DAC control lines idle high before they become outputs: no glitch on SYNC/LDAC/CLR. */
    gpio_high(GPIOA_BASE, PIN_SYNC_CHIP0);
    gpio_high(GPIOB_BASE, PIN_SYNC_CHIP1);
    gpio_high(GPIOB_BASE, PIN_LDAC);
    gpio_high(GPIOB_BASE, PIN_CLR);
    gpio_mode(GPIOA_BASE, PIN_SYNC_CHIP0, GPIO_MODE_OUTPUT);
    gpio_mode(GPIOB_BASE, PIN_SYNC_CHIP1, GPIO_MODE_OUTPUT);
    gpio_mode(GPIOB_BASE, PIN_LDAC, GPIO_MODE_OUTPUT);
    gpio_mode(GPIOB_BASE, PIN_CLR, GPIO_MODE_OUTPUT);
    gpio_af(GPIOA_BASE, PIN_SPI1_SCK, GPIO_AF5_SPI1);
    gpio_af(GPIOA_BASE, PIN_SPI1_MOSI, GPIO_AF5_SPI1);
    gpio_af(GPIOA_BASE, PIN_USART1_TX, GPIO_AF7_USART1);
    gpio_af(GPIOA_BASE, PIN_USART1_RX, GPIO_AF7_USART1);

    /* SPI1 master, mode 1 (CPOL 0, CPHA 1: DAC8563 latches on falling SCLK), software NSS,
     * 8-bit frames MSB first, SCLK = APB2 / 8 (10.5 MHz with the PLL; DAC8563 max 50 MHz). */
    const uint32_t spi_br_div8 = 2u;
    SPI1_CR1 = SPI_CR1_CPHA | SPI_CR1_MSTR | (spi_br_div8 << SPI_CR1_BR_SHIFT) | SPI_CR1_SSM |
               SPI_CR1_SSI;
    SPI1_CR1 |= SPI_CR1_SPE;

    ring_init(&g_rx);
    g_rx_overruns = 0;
    USART1_BRR = (g_apb2_hz + HOST_BAUD / 2u) / HOST_BAUD;
    USART1_CR1 = USART_CR1_UE | USART_CR1_TE | USART_CR1_RE | USART_CR1_RXNEIE;
    nvic_enable(IRQ_USART1);
    sched_ticks_init(&g_ticks);
}

uint32_t board_timer_clock_hz(void) { return g_timer_clock_hz; }

static void sync_set(unsigned chip, bool high)
{
    uint32_t base = chip == 0u ? GPIOA_BASE : GPIOB_BASE;
    uint32_t pin = chip == 0u ? PIN_SYNC_CHIP0 : PIN_SYNC_CHIP1;
    if (high) {
        gpio_high(base, pin);
    } else {
        gpio_low(base, pin);
    }
}

bool board_spi_write(unsigned chip, const uint8_t *data, size_t len)
{
    bool ok = true;
    sync_set(chip, false);
    for (size_t i = 0; i < len && ok; ++i) {
        ok = wait_set(&SPI1_SR, SPI_SR_TXE, SPI_TIMEOUT);
        if (ok) {
            SPI1_DR = data[i];
            /* RXNE marks the end of this byte's 8 clocks; reading DR clears it. */
            ok = wait_set(&SPI1_SR, SPI_SR_RXNE, SPI_TIMEOUT);
            (void)SPI1_DR;
        }
    }
    ok = wait_clear(&SPI1_SR, SPI_SR_BSY, SPI_TIMEOUT) && ok;
    sync_set(chip, true); /* SYNC high after the 24th edge */
    return ok;
}

void board_ldac_pulse(void)
{
    gpio_low(GPIOB_BASE, PIN_LDAC);
    short_delay();
    gpio_high(GPIOB_BASE, PIN_LDAC);
}

void board_clr_pulse(void)
{
    gpio_low(GPIOB_BASE, PIN_CLR);
    short_delay();
    gpio_high(GPIOB_BASE, PIN_CLR);
}

void board_fault_safe(void)
{
    board_clr_pulse();
}

void board_uart_write(const char *text, size_t len)
{
    for (size_t i = 0; i < len; ++i) {
        if (!wait_set(&USART1_SR, USART_SR_TXE, UART_TX_TIMEOUT)) {
            return;
        }
        USART1_DR = (uint8_t)text[i];
    }
}

/** Wait (bounded) until the last byte has left the UART. */
static void uart_drain(void)
{
    (void)wait_set(&USART1_SR, USART_SR_TC, UART_TX_TIMEOUT);
}

bool board_uart_read(uint8_t *byte)
{
    return ring_get(&g_rx, byte);
}

uint32_t board_uart_lost(void)
{
    return g_rx.dropped + g_rx_overruns;
}

void USART1_IRQHandler(void);
void USART1_IRQHandler(void)
{
    uint32_t sr = USART1_SR;
    if ((sr & (USART_SR_RXNE | USART_SR_ORE)) != 0u) {
        uint8_t byte = (uint8_t)(USART1_DR & USART_DR_MASK); /* SR then DR read clears ORE */
        if ((sr & USART_SR_ORE) != 0u) {
            g_rx_overruns = g_rx_overruns + 1u;
        }
        if ((sr & USART_SR_RXNE) != 0u) {
            (void)ring_put(&g_rx, byte);
        }
    }
}

bool board_tick_start(uint32_t tick_hz)
{
    sched_timer_cfg_t cfg;
    if (!sched_timer_config(g_timer_clock_hz, tick_hz, &cfg)) {
        return false;
    }
    if (g_emulated && (TIM2_CR1 & TIM_CR1_CEN) != 0u && TIM2_PSC == cfg.prescaler &&
        TIM2_ARR == cfg.reload) {
        /* Restarted by the emulated RESET: keep QEMU's timer running as programmed at boot
         * (its model adds the virtual time of programming to every period). */
        TIM2_SR = 0u;
        nvic_enable(IRQ_TIM2);
        return true;
    }
    TIM2_PSC = cfg.prescaler;
    TIM2_ARR = cfg.reload;
    TIM2_CR1 = TIM_CR1_URS;
    TIM2_EGR = TIM_EGR_UG; /* load PSC now; URS keeps this from raising an interrupt */
    TIM2_SR = 0u;
    TIM2_DIER = TIM_DIER_UIE;
    nvic_enable(IRQ_TIM2);
    TIM2_CR1 = TIM_CR1_URS | TIM_CR1_CEN;
    return true;
}

void TIM2_IRQHandler(void);
void TIM2_IRQHandler(void)
{
    if ((TIM2_SR & TIM_SR_UIF) != 0u) {
        TIM2_SR = ~TIM_SR_UIF; /* rc_w0: write 0 to clear */
        sched_ticks_raise(&g_ticks);
    }
}

uint32_t board_ticks_take(void)
{
    return sched_ticks_take(&g_ticks);
}

void board_watchdog_start(void)
{
    IWDG_KR = IWDG_KEY_START;
    IWDG_KR = IWDG_KEY_UNLOCK;
    IWDG_PR = IWDG_PR_DIV32;
    IWDG_RLR = IWDG_RELOAD_MS;
    IWDG_KR = IWDG_KEY_RELOAD;
}

void board_watchdog_kick(void)
{
    IWDG_KR = IWDG_KEY_RELOAD;
}

void board_idle(void)
{
    __asm volatile("cpsid i" ::: "memory");
    if (ring_count(&g_rx) == 0u && g_ticks.raised == g_ticks.taken) {
        __asm volatile("wfi" ::: "memory"); /* a pending interrupt still wakes it */
    }
    __asm volatile("cpsie i" ::: "memory");
}

/* ------------------------------------------------------------------ calibration slots */

static uint8_t *slot_base(unsigned slot)
{
    if (slot > 1u) {
        return 0;
    }
    if (g_emulated) {
        return (uint8_t *)(uintptr_t)(EMU_SLOT0_ADDR + slot * EMU_SLOT_BYTES);
    }
    return (uint8_t *)(uintptr_t)(slot == 0u ? CALIB_SLOT0_ADDR : CALIB_SLOT1_ADDR);
}

/** Reload the watchdog and give it a period of @p ms (1 kHz watchdog clock, at most 4095). */
static void watchdog_period(uint32_t ms)
{
    IWDG_KR = IWDG_KEY_RELOAD;
    IWDG_KR = IWDG_KEY_UNLOCK;
    IWDG_RLR = ms;
    IWDG_KR = IWDG_KEY_RELOAD;
}

static bool flash_wait_idle(void)
{
    for (uint32_t i = 0; i < FLASH_TIMEOUT; ++i) {
        if ((FLASH_SR & FLASH_SR_BSY) == 0u) {
            return (FLASH_SR & FLASH_SR_ERRORS) == 0u;
        }
        if ((i % FLASH_KICK_EVERY_POLLS) == 0u) {
            board_watchdog_kick();
        }
    }
    return false;
}

/** Drop the flash data cache (RM0090: reset it, while disabled, after an erase or program), so
 * reading a slot back sees the new bytes. */
static void flash_data_cache_reset(void)
{
    uint32_t acr = FLASH_ACR;
    FLASH_ACR = acr & ~FLASH_ACR_DCEN;
    FLASH_ACR = (acr & ~FLASH_ACR_DCEN) | FLASH_ACR_DCRST;
    FLASH_ACR = acr & ~FLASH_ACR_DCRST;
}

static bool flash_unlock(void)
{
    FLASH_SR = FLASH_SR_ERRORS; /* rc_w1: clear old errors */
    if ((FLASH_CR & FLASH_CR_LOCK) != 0u) {
        FLASH_KEYR = FLASH_KEY1;
        FLASH_KEYR = FLASH_KEY2;
    }
    return (FLASH_CR & FLASH_CR_LOCK) == 0u && flash_wait_idle();
}

bool board_calib_slot_erase(unsigned slot)
{
    uint8_t *base = slot_base(slot);
    if (base == 0) {
        return false;
    }
    if (g_emulated) {
        for (uint32_t i = 0; i < EMU_SLOT_BYTES; ++i) {
            base[i] = FLASH_ERASED_BYTE;
        }
        return true;
    }
    if (!flash_unlock()) {
        return false;
    }
    watchdog_period(IWDG_FLASH_ERASE_MS);
    FLASH_CR = FLASH_CR_SER | ((CALIB_SLOT_SECTOR_FIRST + slot) << FLASH_CR_SNB_SHIFT) |
               (FLASH_CR_PSIZE_X8 << FLASH_CR_PSIZE_SHIFT);
    FLASH_CR |= FLASH_CR_STRT;
    bool ok = flash_wait_idle();
    FLASH_CR = FLASH_CR_LOCK;
    watchdog_period(IWDG_RELOAD_MS);
    flash_data_cache_reset();
    return ok;
}

bool board_calib_slot_program(unsigned slot, uint32_t offset, const uint8_t *data, size_t len)
{
    uint8_t *base = slot_base(slot);
    if (base == 0 || offset + len > (g_emulated ? EMU_SLOT_BYTES : CALIB_SLOT_BYTES)) {
        return false;
    }
    if (g_emulated) {
        for (size_t i = 0; i < len; ++i) {
            base[offset + i] &= data[i]; /* like flash: bits only go from 1 to 0 */
        }
        return true;
    }
    if (!flash_unlock()) {
        return false;
    }
    FLASH_CR = FLASH_CR_PG | (FLASH_CR_PSIZE_X8 << FLASH_CR_PSIZE_SHIFT);
    bool ok = true;
    for (size_t i = 0; i < len && ok; ++i) {
        *(volatile uint8_t *)(base + offset + i) = data[i];
        ok = flash_wait_idle();
    }
    FLASH_CR = FLASH_CR_LOCK;
    flash_data_cache_reset();
    return ok;
}

const uint8_t *board_calib_slot_read(unsigned slot)
{
    return slot_base(slot);
}

void Reset_Handler(void);
extern uint32_t _estack;

/** Under QEMU: the reset path without SYSRESETREQ. QEMU's STM32 timer model adds the virtual
 * time at which it is programmed to every period, so a timer programmed again after a reset
 * ticks seconds apart. The emulated reset masks every interrupt, reloads the stack pointer and
 * runs Reset_Handler (startup code, board_init, app_init) with TIM2 left running as programmed
 * at boot (board_tick_start keeps it): everything of a reset but the peripherals' own. */
static void emulated_reset(void)
{
    __asm volatile("cpsid i" ::: "memory");
    USART1_CR1 = 0u;
    for (uint32_t i = 0; i < NVIC_ISER_WORDS; ++i) {
        NVIC_ICER(i) = NVIC_ALL_IRQS;
        NVIC_ICPR(i) = NVIC_ALL_IRQS;
    }
    __asm volatile("msr msp, %0\n\tcpsie i\n\tbx %1"
                   :
                   : "r"(&_estack), "r"(Reset_Handler)
                   : "memory");
}

void board_system_reset(void)
{
    uart_drain(); /* "OK RESET" reaches the host */
    if (g_emulated) {
        emulated_reset();
    }
    __asm volatile("dsb" ::: "memory");
    SCB_AIRCR = SCB_AIRCR_VECTKEY | SCB_AIRCR_SYSRESETREQ;
    __asm volatile("dsb" ::: "memory");
    for (;;) {
    }
}

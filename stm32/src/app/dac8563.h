/**
 * @file dac8563.h
 * TI DAC8563 (dual 16-bit DAC, SPI) frame encoding and the three-axis DAC bank.
 *
 * Frame: 24 bits, MSB first: DB21-19 command, DB18-16 address, DB15-0 data (DB23-22 don't care).
 * Facts from secondary sources (not the datasheet) live in one named constant each so they
 * are easy to correct on the bench.
 *
 * Bank wiring: axis x = chip 0 channel A, y = chip 0 channel B, z = chip 1 channel A; every chip
 * has its own SYNC, LDAC is shared, so one LDAC pulse updates all axes together.
 */
#ifndef MSR_DAC8563_H
#define MSR_DAC8563_H

#include <stdbool.h>
#include <stdint.h>

/* Commands (DB21-19). */
#define DAC8563_CMD_WRITE_INPUT 0x0u            /**< write input register n */
#define DAC8563_CMD_SOFTWARE_LDAC 0x1u          /**< software LDAC, update DAC register n */
#define DAC8563_CMD_WRITE_INPUT_UPDATE_ALL 0x2u /**< write input n, update all */
#define DAC8563_CMD_WRITE_UPDATE 0x3u           /**< write input n and update DAC n */
#define DAC8563_CMD_POWER 0x4u                  /**< power up / down */
#define DAC8563_CMD_SOFTWARE_RESET 0x5u         /**< software reset */
#define DAC8563_CMD_LDAC_REGISTER 0x6u          /**< which channels follow the LDAC pin */
#define DAC8563_CMD_INTERNAL_REFERENCE 0x7u     /**< internal reference on / off */

/* Addresses (DB18-16). */
#define DAC8563_ADDR_A 0x0u
#define DAC8563_ADDR_B 0x1u
#define DAC8563_ADDR_GAIN 0x2u /**< with DAC8563_CMD_WRITE_INPUT: gain register */
#define DAC8563_ADDR_BOTH 0x7u
/** Address bits of the reset / power / LDAC / reference commands: don't care, 000 as in the
 *  datasheet's example frames (e.g. 0x380001 enables the internal reference). */
#define DAC8563_ADDR_UNUSED 0x0u

/* Field positions and widths. */
#define DAC8563_CMD_SHIFT 19u
#define DAC8563_ADDR_SHIFT 16u
#define DAC8563_CMD_MASK 0x7u
#define DAC8563_ADDR_MASK 0x7u
#define DAC8563_DATA_MASK 0xFFFFu
#define DAC8563_FRAME_BYTES 3u

/* Data words of the init sequence. */
/** Software reset DB0 = 1: reset all registers, power-on-reset update (secondary source). */
#define DAC8563_RESET_ALL_REGISTERS 0x0001u
/** Power command: DB5-4 = 00 normal operation, DB1-0 = 11 selects DAC B and DAC A. */
#define DAC8563_POWER_UP_A_AND_B 0x0003u
/** Internal reference command DB0 = 1: reference on, gain 2 -> 0..5 V (secondary source). */
#define DAC8563_INTERNAL_REFERENCE_ON 0x0001u
/** LDAC register DB1-0 = 00: both channels update on the LDAC pin, not on their own. */
#define DAC8563_LDAC_PIN_CONTROLS_A_AND_B 0x0000u
/** Mid-scale code: 2.5 V with the internal reference, the amplifier's 0 A input. */
#define DAC8563_MIDSCALE 0x8000u

#define DAC_BANK_AXES 3u
#define DAC_BANK_CHIPS 2u

/** Build a 24-bit frame. */
uint32_t dac8563_frame(uint32_t command, uint32_t address, uint32_t data);

/** Split a frame into the three bytes sent MSB first. */
void dac8563_frame_bytes(uint32_t frame, uint8_t bytes[DAC8563_FRAME_BYTES]);

/** Chip and channel address of an axis. */
typedef struct {
    uint8_t chip;
    uint8_t address;
} dac_bank_channel_t;

extern const dac_bank_channel_t dac_bank_map[DAC_BANK_AXES];

/** Reset, power up, enable the internal reference, hand both channels to LDAC, go mid-scale. */
bool dac_bank_init(void);

/** Write the three input registers, then one LDAC pulse updates all outputs together. */
bool dac_bank_write(const uint16_t codes[DAC_BANK_AXES]);

/** Safe state: CLR pulse, mid-scale into every register, LDAC pulse. */
bool dac_bank_safe(void);

#endif

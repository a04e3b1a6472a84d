/**
 * @file crc16.h
 * CRC-16/CCITT-FALSE (polynomial 0x1021, initial value 0xFFFF, no reflection, no final XOR).
 * Protects each streamed row; the host computes the same value (elastica_magnetic.hardware.protocol).
 */
#ifndef MSR_CRC16_H
#define MSR_CRC16_H

#include <stddef.h>
#include <stdint.h>

/** Generator polynomial x^16 + x^12 + x^5 + 1. */
#define CRC16_POLY 0x1021u
/** Register value before the first byte. */
#define CRC16_INIT 0xFFFFu

/** Continue a CRC over @p len bytes (start with CRC16_INIT). */
uint16_t crc16_update(uint16_t crc, const uint8_t *data, size_t len);

/** CRC of a whole buffer. */
uint16_t crc16(const uint8_t *data, size_t len);

#endif

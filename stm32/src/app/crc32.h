/**
 * @file crc32.h
 * CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320, initial and final XOR 0xFFFFFFFF): the
 * hash of a calibration record, identical to Python's zlib.crc32. Check value: "123456789" ->
 * 0xCBF43926.
 */
#ifndef MSR_CRC32_H
#define MSR_CRC32_H

#include <stddef.h>
#include <stdint.h>

uint32_t crc32(const uint8_t *data, size_t len);

#endif

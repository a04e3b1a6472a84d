#include "crc32.h"

#define CRC32_POLY_REFLECTED 0xEDB88320u
#define CRC32_INIT 0xFFFFFFFFu
#define BITS_PER_BYTE 8u

uint32_t crc32(const uint8_t *data, size_t len)
{
    uint32_t crc = CRC32_INIT;
    for (size_t i = 0; i < len; ++i) {
        crc ^= data[i];
        for (unsigned b = 0; b < BITS_PER_BYTE; ++b) {
            crc = (crc & 1u) != 0u ? (crc >> 1) ^ CRC32_POLY_REFLECTED : crc >> 1;
        }
    }
    return crc ^ CRC32_INIT;
}

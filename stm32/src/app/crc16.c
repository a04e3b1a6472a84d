#include "crc16.h"

#define CRC16_TOP_BIT 0x8000u
#define BITS_PER_BYTE 8u
#define BYTE_SHIFT_TO_TOP 8u

uint16_t crc16_update(uint16_t crc, const uint8_t *data, size_t len)
{
    for (size_t i = 0; i < len; ++i) {
        crc = (uint16_t)(crc ^ ((uint16_t)data[i] << BYTE_SHIFT_TO_TOP));
        for (unsigned bit = 0; bit < BITS_PER_BYTE; ++bit) {
            if (crc & CRC16_TOP_BIT) {
                crc = (uint16_t)((crc << 1) ^ CRC16_POLY);
            } else {
                crc = (uint16_t)(crc << 1);
            }
        }
    }
    return crc;
}

uint16_t crc16(const uint8_t *data, size_t len)
{
    return crc16_update(CRC16_INIT, data, len);
}

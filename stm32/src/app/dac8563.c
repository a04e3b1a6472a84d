#include "dac8563.h"

#include "board.h"

#define BYTE_MASK 0xFFu
#define SHIFT_HIGH_BYTE 16u
#define SHIFT_MID_BYTE 8u

const dac_bank_channel_t dac_bank_map[DAC_BANK_AXES] = {
    {0u, DAC8563_ADDR_A}, /* x */
    {0u, DAC8563_ADDR_B}, /* y */
    {1u, DAC8563_ADDR_A}, /* z */
};

uint32_t dac8563_frame(uint32_t command, uint32_t address, uint32_t data)
{
    return ((command & DAC8563_CMD_MASK) << DAC8563_CMD_SHIFT) |
           ((address & DAC8563_ADDR_MASK) << DAC8563_ADDR_SHIFT) | (data & DAC8563_DATA_MASK);
}

void dac8563_frame_bytes(uint32_t frame, uint8_t bytes[DAC8563_FRAME_BYTES])
{
    bytes[0] = (uint8_t)((frame >> SHIFT_HIGH_BYTE) & BYTE_MASK);
    bytes[1] = (uint8_t)((frame >> SHIFT_MID_BYTE) & BYTE_MASK);
    bytes[2] = (uint8_t)(frame & BYTE_MASK);
}

static bool send(unsigned chip, uint32_t command, uint32_t address, uint32_t data)
{
    uint8_t bytes[DAC8563_FRAME_BYTES];
    dac8563_frame_bytes(dac8563_frame(command, address, data), bytes);
    return board_spi_write(chip, bytes, DAC8563_FRAME_BYTES);
}

static bool write_inputs(const uint16_t codes[DAC_BANK_AXES])
{
    bool ok = true;
    for (unsigned axis = 0; axis < DAC_BANK_AXES; ++axis) {
        const dac_bank_channel_t *ch = &dac_bank_map[axis];
        ok = send(ch->chip, DAC8563_CMD_WRITE_INPUT, ch->address, codes[axis]) && ok;
    }
    return ok;
}

bool dac_bank_init(void)
{
    bool ok = true;
    for (unsigned chip = 0; chip < DAC_BANK_CHIPS; ++chip) {
        ok = send(chip, DAC8563_CMD_SOFTWARE_RESET, DAC8563_ADDR_UNUSED,
                  DAC8563_RESET_ALL_REGISTERS) && ok;
        ok = send(chip, DAC8563_CMD_POWER, DAC8563_ADDR_UNUSED, DAC8563_POWER_UP_A_AND_B) && ok;
        ok = send(chip, DAC8563_CMD_INTERNAL_REFERENCE, DAC8563_ADDR_UNUSED,
                  DAC8563_INTERNAL_REFERENCE_ON) && ok;
        ok = send(chip, DAC8563_CMD_LDAC_REGISTER, DAC8563_ADDR_UNUSED,
                  DAC8563_LDAC_PIN_CONTROLS_A_AND_B) && ok;
    }
    return dac_bank_safe() && ok;
}

bool dac_bank_write(const uint16_t codes[DAC_BANK_AXES])
{
    bool ok = write_inputs(codes);
    if (ok) {
        board_ldac_pulse(); /* a failed frame never reaches the outputs */
    }
    return ok;
}

bool dac_bank_safe(void)
{
    static const uint16_t mid[DAC_BANK_AXES] = {DAC8563_MIDSCALE, DAC8563_MIDSCALE,
                                               DAC8563_MIDSCALE};
    board_clr_pulse(); /* hardware path to mid-scale, independent of SPI */
    return dac_bank_write(mid);
}

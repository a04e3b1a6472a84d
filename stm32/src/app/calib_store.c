#include "calib_store.h"

#include "board.h"
#include "crc32.h"

#define BITS_PER_BYTE 8u
#define U32_BYTES 4u
#define OFFSET_MAGIC 0u
#define OFFSET_SEQ 4u
#define OFFSET_LEN 8u
#define OFFSET_CRC 12u

static uint32_t get_u32(const uint8_t *p)
{
    uint32_t v = 0;
    for (unsigned i = 0; i < U32_BYTES; ++i) {
        v |= (uint32_t)p[i] << (BITS_PER_BYTE * i);
    }
    return v;
}

static void put_u32(uint8_t *p, uint32_t v)
{
    for (unsigned i = 0; i < U32_BYTES; ++i) {
        p[i] = (uint8_t)(v >> (BITS_PER_BYTE * i));
    }
}

const char *calib_store_status_name(calib_store_status_t status)
{
    switch (status) {
    case CALIB_STORE_OK:
        return "ok";
    case CALIB_STORE_ERASE_FAILED:
        return "flash-erase";
    case CALIB_STORE_PROGRAM_FAILED:
        return "flash-program";
    case CALIB_STORE_VERIFY_FAILED:
        return "flash-verify";
    }
    return "unknown";
}

/** A slot's content when valid (magic, length, CRC, checks pass). */
static bool slot_valid(unsigned slot, calib_named_t *out, uint32_t *seq)
{
    const uint8_t *s = board_calib_slot_read(slot);
    if (s == 0 || get_u32(s + OFFSET_MAGIC) != CALIB_STORE_MAGIC ||
        get_u32(s + OFFSET_LEN) != CALIB_RECORD_BYTES) {
        return false;
    }
    const uint8_t *record = s + CALIB_STORE_HEADER_BYTES;
    if (crc32(record, CALIB_RECORD_BYTES) != get_u32(s + OFFSET_CRC)) {
        return false;
    }
    calib_record_decode(record, out);
    *seq = get_u32(s + OFFSET_SEQ);
    return calib_record_check(out) == CALREC_OK;
}

bool calib_store_load(calib_named_t *out, unsigned *slot, uint32_t *seq)
{
    bool found = false;
    for (unsigned i = 0; i < CALIB_STORE_SLOTS; ++i) {
        calib_named_t cal;
        uint32_t s;
        if (slot_valid(i, &cal, &s) && (!found || s > *seq)) {
            *out = cal;
            *slot = i;
            *seq = s;
            found = true;
        }
    }
    return found;
}

calib_store_status_t calib_store_save(const calib_named_t *cal, unsigned *slot_written)
{
    calib_named_t current;
    unsigned newest = CALIB_STORE_NO_SLOT;
    uint32_t seq = 0;
    bool any = calib_store_load(&current, &newest, &seq);
    unsigned target = (any && newest == 0u) ? 1u : 0u;
    uint8_t image[CALIB_STORE_SLOT_BYTES];
    put_u32(image + OFFSET_MAGIC, CALIB_STORE_MAGIC);
    put_u32(image + OFFSET_SEQ, any ? seq + 1u : 1u);
    put_u32(image + OFFSET_LEN, CALIB_RECORD_BYTES);
    calib_record_encode(cal, image + CALIB_STORE_HEADER_BYTES);
    put_u32(image + OFFSET_CRC, crc32(image + CALIB_STORE_HEADER_BYTES, CALIB_RECORD_BYTES));
    *slot_written = target;
    if (!board_calib_slot_erase(target)) {
        return CALIB_STORE_ERASE_FAILED;
    }
    /* record, then sequence/length/CRC, then the magic that makes the slot valid */
    if (!board_calib_slot_program(target, CALIB_STORE_HEADER_BYTES,
                                  image + CALIB_STORE_HEADER_BYTES, CALIB_RECORD_BYTES) ||
        !board_calib_slot_program(target, OFFSET_SEQ, image + OFFSET_SEQ,
                                  CALIB_STORE_HEADER_BYTES - OFFSET_SEQ) ||
        !board_calib_slot_program(target, OFFSET_MAGIC, image + OFFSET_MAGIC, U32_BYTES)) {
        return CALIB_STORE_PROGRAM_FAILED;
    }
    const uint8_t *back = board_calib_slot_read(target);
    for (unsigned i = 0; i < CALIB_STORE_SLOT_BYTES; ++i) {
        if (back == 0 || back[i] != image[i]) {
            return CALIB_STORE_VERIFY_FAILED;
        }
    }
    return CALIB_STORE_OK;
}

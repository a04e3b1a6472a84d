#include "text_parse.h"

#define HEX_DIGIT_BITS 4u
#define HEX_LETTER_OFFSET 10
#define DECIMAL_BASE 10u
#define U32_HEX_DIGITS 8u

int parse_hex_digit(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + HEX_LETTER_OFFSET;
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + HEX_LETTER_OFFSET;
    }
    return -1;
}

bool parse_hex_u32(const char *text, size_t len, uint32_t *value)
{
    if (len == 0 || len > U32_HEX_DIGITS) {
        return false;
    }
    uint32_t v = 0;
    for (size_t i = 0; i < len; ++i) {
        int d = parse_hex_digit(text[i]);
        if (d < 0) {
            return false;
        }
        v = (v << HEX_DIGIT_BITS) | (uint32_t)d;
    }
    *value = v;
    return true;
}

bool parse_u32(const char *text, size_t len, uint32_t *value)
{
    if (len == 0) {
        return false;
    }
    uint32_t v = 0;
    for (size_t i = 0; i < len; ++i) {
        if (text[i] < '0' || text[i] > '9') {
            return false;
        }
        uint32_t d = (uint32_t)(text[i] - '0');
        if (v > (UINT32_MAX - d) / DECIMAL_BASE) {
            return false;
        }
        v = v * DECIMAL_BASE + d;
    }
    *value = v;
    return true;
}

bool text_is(const char *text, size_t len, const char *word)
{
    size_t i = 0;
    for (; i < len && word[i] != '\0'; ++i) {
        if (text[i] != word[i]) {
            return false;
        }
    }
    return i == len && word[i] == '\0';
}

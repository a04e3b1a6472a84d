#include "msg.h"

#define DECIMAL_BASE 10u
#define U32_MAX_DIGITS 10u
#define U32_HEX_DIGITS 8u
#define HEX_DIGIT_BITS 4u
#define HEX_DIGIT_MASK 0xFu

static void put(msg_t *msg, char c)
{
    if (msg->len + 1u < MSG_MAX_LINE) { /* keep one byte for the LF */
        msg->text[msg->len++] = c;
    }
}

void msg_begin(msg_t *msg, const char *tag)
{
    msg->len = 0;
    msg_str(msg, tag);
}

void msg_str(msg_t *msg, const char *text)
{
    for (; *text != '\0'; ++text) {
        put(msg, *text);
    }
}

void msg_u32(msg_t *msg, uint32_t value)
{
    char digits[U32_MAX_DIGITS];
    unsigned n = 0;
    do {
        digits[n++] = (char)('0' + value % DECIMAL_BASE);
        value /= DECIMAL_BASE;
    } while (value != 0u);
    while (n > 0u) {
        put(msg, digits[--n]);
    }
}

void msg_kv_u32(msg_t *msg, const char *key, uint32_t value)
{
    put(msg, ' ');
    msg_str(msg, key);
    put(msg, '=');
    msg_u32(msg, value);
}

void msg_kv_str(msg_t *msg, const char *key, const char *value)
{
    put(msg, ' ');
    msg_str(msg, key);
    put(msg, '=');
    msg_str(msg, value);
}

void msg_kv_hex32(msg_t *msg, const char *key, uint32_t value)
{
    static const char digits[] = "0123456789abcdef";
    put(msg, ' ');
    msg_str(msg, key);
    put(msg, '=');
    for (unsigned i = U32_HEX_DIGITS; i > 0u; --i) {
        put(msg, digits[(value >> (HEX_DIGIT_BITS * (i - 1u))) & HEX_DIGIT_MASK]);
    }
}

void msg_end(msg_t *msg)
{
    msg->text[msg->len++] = '\n';
}

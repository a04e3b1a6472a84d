/* Test helpers: format a streamed row exactly as the host does. */
#ifndef MSR_LINK_HELPERS_H
#define MSR_LINK_HELPERS_H
#include <stdio.h>
#include <string.h>

#include "crc16.h"

static inline void format_row(char *out, size_t cap, unsigned seq, const char *x, const char *y,
                              const char *z)
{
    char payload[96];
    snprintf(payload, sizeof payload, "%u,%s,%s,%s", seq, x, y, z);
    snprintf(out, cap, "%s*%04X\n", payload, crc16((const uint8_t *)payload, strlen(payload)));
}
#endif

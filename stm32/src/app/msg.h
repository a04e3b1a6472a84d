/**
 * @file msg.h
 * Building one report line (no printf on the target): text and unsigned decimals.
 */
#ifndef MSR_MSG_H
#define MSR_MSG_H

#include <stddef.h>
#include <stdint.h>

#define MSG_MAX_LINE 160u

typedef struct {
    char text[MSG_MAX_LINE];
    size_t len;
} msg_t;

void msg_begin(msg_t *msg, const char *tag);
void msg_str(msg_t *msg, const char *text);
void msg_u32(msg_t *msg, uint32_t value);
/** Append " key=value". */
void msg_kv_u32(msg_t *msg, const char *key, uint32_t value);
void msg_kv_str(msg_t *msg, const char *key, const char *value);
/** Append " key=xxxxxxxx" (8 lower-case hex digits). */
void msg_kv_hex32(msg_t *msg, const char *key, uint32_t value);
/** Terminate with LF (always fits: text is cut to leave room). */
void msg_end(msg_t *msg);

#endif

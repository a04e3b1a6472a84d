/**
 * @file text_parse.h
 * Small parsers of the link's command words: unsigned decimals and fixed-width hex.
 */
#ifndef MSR_TEXT_PARSE_H
#define MSR_TEXT_PARSE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/** Decimal digits only, no sign, no overflow past UINT32_MAX. */
bool parse_u32(const char *text, size_t len, uint32_t *value);

/** 1..8 hex digits (either case) -> value. */
bool parse_hex_u32(const char *text, size_t len, uint32_t *value);

/** One hex digit -> 0..15, or -1. */
int parse_hex_digit(char c);

/** True when text[0..len) equals the NUL-terminated @p word. */
bool text_is(const char *text, size_t len, const char *word);

#endif

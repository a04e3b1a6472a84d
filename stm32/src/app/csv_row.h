/**
 * @file csv_row.h
 * Byte-stream parser for field CSV rows (the paper's format, Yao et al. 2023).
 *
 * A file is an optional header line (``,mag_x,mag_y,mag_z`` or ``index,mag_x,mag_y,mag_z`` or
 * ``mag_x,mag_y,mag_z``), then one row per 1/100 s: an optional integer index column followed
 * by the field components in millitesla. Lines end in LF or CRLF. Numbers are decimal with an
 * optional sign, fraction and exponent (``1.5``, ``-2e-3``, ``.5E+1``); ``nan`` and ``inf`` are
 * rejected. Every rejection carries the 1-based line number and a csv_status_t reason.
 *
 * Three layers, each usable alone:
 *  - csv_parse_number(): one decimal field -> double,
 *  - csv_parse_row(): one line (no terminator) -> index + 3 values,
 *  - csv_line_reader / csv_stream: bytes in, complete lines / rows out (no allocation).
 */
#ifndef MSR_CSV_ROW_H
#define MSR_CSV_ROW_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/** Longest accepted line in bytes, terminator excluded. Longer lines are rejected whole. */
#define CSV_MAX_LINE 128u
/** Field components per row (x, y, z). */
#define CSV_AXES 3u
/** Columns of a row without / with the leading index column. */
#define CSV_COLUMNS_PLAIN 3u
#define CSV_COLUMNS_INDEXED 4u

/** Why a line was rejected (CSV_OK when it was not). */
typedef enum {
    CSV_OK = 0,
    CSV_ERR_TRUNCATED,       /**< fewer columns than the row format has */
    CSV_ERR_EXTRA_COLUMNS,   /**< more columns than the row format has */
    CSV_ERR_EMPTY_FIELD,     /**< a value column is empty */
    CSV_ERR_NOT_A_NUMBER,    /**< a value is not a decimal number */
    CSV_ERR_NON_FINITE,      /**< nan / inf spelled out */
    CSV_ERR_OUT_OF_RANGE,    /**< the number overflows a double */
    CSV_ERR_BAD_INDEX,       /**< index column is not a non-negative integer */
    CSV_ERR_LINE_TOO_LONG,   /**< more than CSV_MAX_LINE bytes before the terminator */
    CSV_ERR_BAD_HEADER,      /**< header line without mag_x, mag_y, mag_z as its last columns */
    CSV_ERR_BAD_CHAR,        /**< control byte (NUL, lone CR, ...) inside a line */
    CSV_STATUS_COUNT
} csv_status_t;

/** Short lower-case reason for @p status, e.g. "truncated" (never NULL). */
const char *csv_status_reason(csv_status_t status);

/** One parsed data row. */
typedef struct {
    bool has_index;               /**< the row had an index column */
    uint32_t index;               /**< value of the index column (0 when absent) */
    double mag_mT[CSV_AXES];      /**< field x, y, z in millitesla */
} csv_row_t;

/**
 * Parse one decimal number occupying exactly @p len bytes (surrounding spaces/tabs allowed).
 * Up to 15 significant digits with a decimal exponent within +-22 convert exactly rounded.
 */
csv_status_t csv_parse_number(const char *text, size_t len, double *value);

/**
 * Parse one line (terminator removed) with @p columns columns (CSV_COLUMNS_PLAIN or
 * CSV_COLUMNS_INDEXED). Column counts other than @p columns give TRUNCATED / EXTRA_COLUMNS.
 */
csv_status_t csv_parse_row(const char *line, size_t len, unsigned columns, csv_row_t *row);

/** True when @p line looks like a header: its last column is not a number. */
bool csv_line_is_header(const char *line, size_t len);

/**
 * Parse a header line; on success *columns is 3 or 4 (index column first).
 * Accepted: the last three columns are mag_x, mag_y, mag_z, preceded by at most one column.
 */
csv_status_t csv_parse_header(const char *line, size_t len, unsigned *columns);

/** Assembles lines from a byte stream. Zero-initialise or call csv_line_reader_init(). */
typedef struct {
    char buf[CSV_MAX_LINE];
    size_t len;
    bool too_long;
    bool bad_char;
    bool pending_cr;         /**< last byte was CR: only LF may follow */
    uint32_t line_no;        /**< 1-based number of the line being assembled */
} csv_line_reader_t;

/** Result of pushing one byte. */
typedef enum {
    CSV_LINE_NONE = 0,       /**< line not complete yet */
    CSV_LINE_READY,          /**< a line is complete: see csv_line_t */
    CSV_LINE_ERROR           /**< a line ended but was unusable: see csv_line_t.status */
} csv_line_event_t;

/** A completed line; @c text points into the reader and is valid until the next push. */
typedef struct {
    const char *text;
    size_t len;
    uint32_t line_no;
    csv_status_t status;
} csv_line_t;

void csv_line_reader_init(csv_line_reader_t *reader);

/** Feed one byte; LF ends a line, one CR right before it is dropped. */
csv_line_event_t csv_line_push(csv_line_reader_t *reader, uint8_t byte, csv_line_t *line);

/** What a csv_stream produced. */
typedef enum {
    CSV_EVENT_NONE = 0,
    CSV_EVENT_HEADER,
    CSV_EVENT_ROW,
    CSV_EVENT_ERROR
} csv_event_kind_t;

typedef struct {
    csv_event_kind_t kind;
    uint32_t line_no;        /**< 1-based line of the file */
    csv_status_t status;     /**< reason when kind == CSV_EVENT_ERROR */
    csv_row_t row;           /**< when kind == CSV_EVENT_ROW */
} csv_event_t;

/** Whole-file parser: optional header, column count fixed by the header or first row. */
typedef struct {
    csv_line_reader_t reader;
    unsigned columns;        /**< 0 until the header or the first row decides */
    bool seen_content;
} csv_stream_t;

void csv_stream_init(csv_stream_t *stream);

/** Feed one byte; returns true and fills @p event when a header, row or error completes. */
bool csv_stream_feed(csv_stream_t *stream, uint8_t byte, csv_event_t *event);

/** Finish a file that does not end in LF (flushes the last line). */
bool csv_stream_finish(csv_stream_t *stream, csv_event_t *event);

#endif

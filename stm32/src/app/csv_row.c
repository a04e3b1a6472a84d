#include "csv_row.h"

#include <float.h>

#define CHAR_COMMA ','
#define CHAR_DOT '.'
#define CHAR_LF '\n'
#define CHAR_CR '\r'
#define CHAR_TAB '\t'
#define CHAR_SPACE ' '
#define CHAR_FIRST_PRINTABLE 0x20u
#define CHAR_DELETE 0x7Fu

/** Significant decimal digits kept in the 64-bit mantissa (10^19 < 2^64). */
#define MAX_MANTISSA_DIGITS 19
/** Digits and powers of ten for which mantissa * 10^e is one correctly rounded operation. */
#define EXACT_MANTISSA_DIGITS 15
#define EXACT_POW10_MAX 22
/** Exponent literals saturate here: far beyond double range either way. */
#define EXPONENT_SATURATION 100000
#define DECIMAL_BASE 10u

static const double k_pow10[EXACT_POW10_MAX + 1] = {
    1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
};

static const char *const k_reasons[CSV_STATUS_COUNT] = {
    [CSV_OK] = "ok",
    [CSV_ERR_TRUNCATED] = "truncated",
    [CSV_ERR_EXTRA_COLUMNS] = "extra-columns",
    [CSV_ERR_EMPTY_FIELD] = "empty-field",
    [CSV_ERR_NOT_A_NUMBER] = "not-a-number",
    [CSV_ERR_NON_FINITE] = "non-finite",
    [CSV_ERR_OUT_OF_RANGE] = "out-of-range",
    [CSV_ERR_BAD_INDEX] = "bad-index",
    [CSV_ERR_LINE_TOO_LONG] = "line-too-long",
    [CSV_ERR_BAD_HEADER] = "bad-header",
    [CSV_ERR_BAD_CHAR] = "bad-char",
};

const char *csv_status_reason(csv_status_t status)
{
    if ((unsigned)status >= (unsigned)CSV_STATUS_COUNT) {
        return "unknown";
    }
    return k_reasons[status];
}

static bool is_blank(char c) { return c == CHAR_SPACE || c == CHAR_TAB; }
static bool is_digit(char c) { return c >= '0' && c <= '9'; }
static char lower(char c) { return (c >= 'A' && c <= 'Z') ? (char)(c - 'A' + 'a') : c; }

static void trim(const char **text, size_t *len)
{
    const char *s = *text;
    size_t n = *len;
    while (n > 0 && is_blank(s[0])) {
        ++s;
        --n;
    }
    while (n > 0 && is_blank(s[n - 1])) {
        --n;
    }
    *text = s;
    *len = n;
}

static bool equals_word(const char *s, size_t len, const char *word)
{
    size_t i = 0;
    for (; i < len; ++i) {
        if (word[i] == '\0' || lower(s[i]) != word[i]) {
            return false;
        }
    }
    return word[i] == '\0';
}

csv_status_t csv_parse_number(const char *text, size_t len, double *value)
{
    trim(&text, &len);
    if (len == 0) {
        return CSV_ERR_EMPTY_FIELD;
    }
    size_t i = 0;
    bool negative = false;
    if (text[0] == '+' || text[0] == '-') {
        negative = text[0] == '-';
        ++i;
    }
    if (equals_word(text + i, len - i, "nan") || equals_word(text + i, len - i, "inf") ||
        equals_word(text + i, len - i, "infinity")) {
        return CSV_ERR_NON_FINITE;
    }

    uint64_t mantissa = 0;
    int digits = 0;       /* significant digits held in mantissa */
    long exp10 = 0;
    bool any_digit = false;
    for (; i < len && is_digit(text[i]); ++i) {
        unsigned d = (unsigned)(text[i] - '0');
        any_digit = true;
        if (mantissa == 0 && d == 0) {
            continue; /* leading zero */
        }
        if (digits < MAX_MANTISSA_DIGITS) {
            mantissa = mantissa * DECIMAL_BASE + d;
            ++digits;
        } else {
            ++exp10; /* digit beyond the kept precision */
        }
    }
    if (i < len && text[i] == CHAR_DOT) {
        for (++i; i < len && is_digit(text[i]); ++i) {
            unsigned d = (unsigned)(text[i] - '0');
            any_digit = true;
            if (mantissa == 0 && d == 0) {
                --exp10;
            } else if (digits < MAX_MANTISSA_DIGITS) {
                mantissa = mantissa * DECIMAL_BASE + d;
                ++digits;
                --exp10;
            }
        }
    }
    if (!any_digit) {
        return CSV_ERR_NOT_A_NUMBER;
    }
    if (i < len && (text[i] == 'e' || text[i] == 'E')) {
        ++i;
        bool exp_negative = false;
        if (i < len && (text[i] == '+' || text[i] == '-')) {
            exp_negative = text[i] == '-';
            ++i;
        }
        if (i >= len || !is_digit(text[i])) {
            return CSV_ERR_NOT_A_NUMBER;
        }
        long e = 0;
        for (; i < len && is_digit(text[i]); ++i) {
            if (e < EXPONENT_SATURATION) {
                e = e * (long)DECIMAL_BASE + (long)(text[i] - '0');
            }
        }
        exp10 += exp_negative ? -e : e;
    }
    if (i != len) {
        return CSV_ERR_NOT_A_NUMBER;
    }

    double v = (double)mantissa;
    if (mantissa != 0) {
        if (!(digits <= EXACT_MANTISSA_DIGITS && exp10 >= -EXACT_POW10_MAX &&
              exp10 <= EXACT_POW10_MAX)) {
            while (exp10 > EXACT_POW10_MAX && v <= DBL_MAX) {
                v *= k_pow10[EXACT_POW10_MAX];
                exp10 -= EXACT_POW10_MAX;
            }
            while (exp10 < -EXACT_POW10_MAX && v != 0.0) {
                v /= k_pow10[EXACT_POW10_MAX];
                exp10 += EXACT_POW10_MAX;
            }
        }
        if (v > DBL_MAX) {
            return CSV_ERR_OUT_OF_RANGE;
        }
        if (exp10 > EXACT_POW10_MAX || exp10 < -EXACT_POW10_MAX) {
            exp10 = 0; /* only reached when v overflowed (handled) or underflowed to 0 */
        }
        v = exp10 < 0 ? v / k_pow10[-exp10] : v * k_pow10[exp10];
        if (v > DBL_MAX) {
            return CSV_ERR_OUT_OF_RANGE;
        }
    }
    *value = negative ? -v : v;
    return CSV_OK;
}

/** Split @p line at commas into at most @p max fields; returns the total field count. */
static unsigned split_fields(const char *line, size_t len, const char **starts, size_t *lens,
                             unsigned max)
{
    unsigned count = 0;
    size_t start = 0;
    for (size_t i = 0; i <= len; ++i) {
        if (i == len || line[i] == CHAR_COMMA) {
            if (count < max) {
                starts[count] = line + start;
                lens[count] = i - start;
            }
            ++count;
            start = i + 1;
        }
    }
    return count;
}

static csv_status_t parse_index(const char *text, size_t len, uint32_t *index)
{
    trim(&text, &len);
    if (len == 0) {
        return CSV_ERR_BAD_INDEX;
    }
    uint32_t v = 0;
    for (size_t i = 0; i < len; ++i) {
        if (!is_digit(text[i])) {
            return CSV_ERR_BAD_INDEX;
        }
        uint32_t d = (uint32_t)(text[i] - '0');
        if (v > (UINT32_MAX - d) / DECIMAL_BASE) {
            return CSV_ERR_BAD_INDEX;
        }
        v = v * DECIMAL_BASE + d;
    }
    *index = v;
    return CSV_OK;
}

csv_status_t csv_parse_row(const char *line, size_t len, unsigned columns, csv_row_t *row)
{
    const char *starts[CSV_COLUMNS_INDEXED];
    size_t lens[CSV_COLUMNS_INDEXED];
    if (columns != CSV_COLUMNS_PLAIN && columns != CSV_COLUMNS_INDEXED) {
        return CSV_ERR_TRUNCATED;
    }
    unsigned n = split_fields(line, len, starts, lens, CSV_COLUMNS_INDEXED);
    if (n < columns) {
        return CSV_ERR_TRUNCATED;
    }
    if (n > columns) {
        return CSV_ERR_EXTRA_COLUMNS;
    }
    unsigned first = 0;
    row->has_index = columns == CSV_COLUMNS_INDEXED;
    row->index = 0;
    if (row->has_index) {
        csv_status_t st = parse_index(starts[0], lens[0], &row->index);
        if (st != CSV_OK) {
            return st;
        }
        first = 1;
    }
    for (unsigned axis = 0; axis < CSV_AXES; ++axis) {
        csv_status_t st =
            csv_parse_number(starts[first + axis], lens[first + axis], &row->mag_mT[axis]);
        if (st != CSV_OK) {
            return st;
        }
    }
    return CSV_OK;
}

bool csv_line_is_header(const char *line, size_t len)
{
    size_t last = 0;
    for (size_t i = 0; i < len; ++i) {
        if (line[i] == CHAR_COMMA) {
            last = i + 1;
        }
    }
    double ignored;
    return csv_parse_number(line + last, len - last, &ignored) == CSV_ERR_NOT_A_NUMBER;
}

csv_status_t csv_parse_header(const char *line, size_t len, unsigned *columns)
{
    static const char *const names[CSV_AXES] = {"mag_x", "mag_y", "mag_z"};
    const char *starts[CSV_COLUMNS_INDEXED];
    size_t lens[CSV_COLUMNS_INDEXED];
    unsigned n = split_fields(line, len, starts, lens, CSV_COLUMNS_INDEXED);
    if (n != CSV_COLUMNS_PLAIN && n != CSV_COLUMNS_INDEXED) {
        return CSV_ERR_BAD_HEADER;
    }
    unsigned first = n - CSV_AXES;
    for (unsigned axis = 0; axis < CSV_AXES; ++axis) {
        const char *s = starts[first + axis];
        size_t l = lens[first + axis];
        trim(&s, &l);
        size_t k = 0;
        while (k < l && names[axis][k] != '\0' && s[k] == names[axis][k]) {
            ++k;
        }
        if (k != l || names[axis][k] != '\0') {
            return CSV_ERR_BAD_HEADER;
        }
    }
    *columns = n;
    return CSV_OK;
}

void csv_line_reader_init(csv_line_reader_t *reader)
{
    reader->len = 0;
    reader->too_long = false;
    reader->bad_char = false;
    reader->pending_cr = false;
    reader->line_no = 1;
}

csv_line_event_t csv_line_push(csv_line_reader_t *reader, uint8_t byte, csv_line_t *line)
{
    if (byte == (uint8_t)CHAR_LF) {
        csv_line_event_t event = CSV_LINE_READY;
        line->text = reader->buf;
        line->len = reader->len;
        line->line_no = reader->line_no;
        line->status = CSV_OK;
        if (reader->too_long) {
            line->status = CSV_ERR_LINE_TOO_LONG;
        } else if (reader->bad_char) {
            line->status = CSV_ERR_BAD_CHAR;
        }
        if (line->status != CSV_OK) {
            event = CSV_LINE_ERROR;
            line->len = 0;
        }
        uint32_t next = reader->line_no + 1;
        csv_line_reader_init(reader);
        reader->line_no = next;
        return event;
    }
    if (reader->pending_cr) {
        reader->bad_char = true; /* lone CR inside a line */
        reader->pending_cr = false;
    }
    if (byte == (uint8_t)CHAR_CR) {
        reader->pending_cr = true;
        return CSV_LINE_NONE;
    }
    if ((byte < CHAR_FIRST_PRINTABLE && byte != (uint8_t)CHAR_TAB) || byte >= CHAR_DELETE) {
        reader->bad_char = true;
    }
    if (reader->len < CSV_MAX_LINE) {
        reader->buf[reader->len++] = (char)byte;
    } else {
        reader->too_long = true;
    }
    return CSV_LINE_NONE;
}

void csv_stream_init(csv_stream_t *stream)
{
    csv_line_reader_init(&stream->reader);
    stream->columns = 0;
    stream->seen_content = false;
}

static bool line_is_blank(const char *text, size_t len)
{
    for (size_t i = 0; i < len; ++i) {
        if (!is_blank(text[i])) {
            return false;
        }
    }
    return true;
}

static bool handle_line(csv_stream_t *stream, csv_line_event_t ev, const csv_line_t *line,
                        csv_event_t *event)
{
    event->line_no = line->line_no;
    event->status = CSV_OK;
    if (ev == CSV_LINE_ERROR) {
        event->kind = CSV_EVENT_ERROR;
        event->status = line->status;
        return true;
    }
    if (line_is_blank(line->text, line->len)) {
        return false;
    }
    if (!stream->seen_content) {
        stream->seen_content = true;
        if (csv_line_is_header(line->text, line->len)) {
            unsigned columns = 0;
            event->status = csv_parse_header(line->text, line->len, &columns);
            event->kind = event->status == CSV_OK ? CSV_EVENT_HEADER : CSV_EVENT_ERROR;
            stream->columns = columns;
            return true;
        }
    }
    if (stream->columns == 0) {
        const char *starts[CSV_COLUMNS_INDEXED];
        size_t lens[CSV_COLUMNS_INDEXED];
        unsigned n = split_fields(line->text, line->len, starts, lens, CSV_COLUMNS_INDEXED);
        if (n < CSV_COLUMNS_PLAIN) {
            event->kind = CSV_EVENT_ERROR;
            event->status = CSV_ERR_TRUNCATED;
            return true;
        }
        if (n > CSV_COLUMNS_INDEXED) {
            event->kind = CSV_EVENT_ERROR;
            event->status = CSV_ERR_EXTRA_COLUMNS;
            return true;
        }
        stream->columns = n;
    }
    event->status = csv_parse_row(line->text, line->len, stream->columns, &event->row);
    event->kind = event->status == CSV_OK ? CSV_EVENT_ROW : CSV_EVENT_ERROR;
    return true;
}

bool csv_stream_feed(csv_stream_t *stream, uint8_t byte, csv_event_t *event)
{
    csv_line_t line;
    csv_line_event_t ev = csv_line_push(&stream->reader, byte, &line);
    event->kind = CSV_EVENT_NONE;
    if (ev == CSV_LINE_NONE) {
        return false;
    }
    return handle_line(stream, ev, &line, event);
}

bool csv_stream_finish(csv_stream_t *stream, csv_event_t *event)
{
    const csv_line_reader_t *r = &stream->reader;
    event->kind = CSV_EVENT_NONE;
    if (r->len == 0 && !r->too_long && !r->bad_char && !r->pending_cr) {
        return false;
    }
    return csv_stream_feed(stream, (uint8_t)CHAR_LF, event);
}

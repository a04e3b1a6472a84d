#include "test_common.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csv_row.h"

static csv_status_t num(const char *text, double *v) { return csv_parse_number(text, strlen(text), v); }

static void test_numbers_good(void **state)
{
    (void)state;
    double v = 0;
    assert_int_equal(num("1.5", &v), CSV_OK);
    assert_true(v == 1.5);
    assert_int_equal(num("-2e-3", &v), CSV_OK);
    assert_true(v == -2e-3);
    assert_int_equal(num(".5E+1", &v), CSV_OK);
    assert_true(v == 5.0);
    assert_int_equal(num("  3\t", &v), CSV_OK);
    assert_true(v == 3.0);
    assert_int_equal(num("+7.", &v), CSV_OK);
    assert_true(v == 7.0);
    assert_int_equal(num("0", &v), CSV_OK);
    assert_true(v == 0.0);
    assert_int_equal(num("1E2", &v), CSV_OK);
    assert_true(v == 100.0);
    assert_int_equal(num("0.000", &v), CSV_OK);
    assert_true(v == 0.0);
    assert_int_equal(num("1e-400", &v), CSV_OK); /* underflows to zero: finite */
    assert_true(v == 0.0);
}

static void test_numbers_bad(void **state)
{
    (void)state;
    double v = 0;
    assert_int_equal(num("", &v), CSV_ERR_EMPTY_FIELD);
    assert_int_equal(num("   ", &v), CSV_ERR_EMPTY_FIELD);
    assert_int_equal(num("nan", &v), CSV_ERR_NON_FINITE);
    assert_int_equal(num("NaN", &v), CSV_ERR_NON_FINITE);
    assert_int_equal(num("-inf", &v), CSV_ERR_NON_FINITE);
    assert_int_equal(num("Infinity", &v), CSV_ERR_NON_FINITE);
    assert_int_equal(num("1e400", &v), CSV_ERR_OUT_OF_RANGE);
    assert_int_equal(num("1.2.3", &v), CSV_ERR_NOT_A_NUMBER);
    assert_int_equal(num("e5", &v), CSV_ERR_NOT_A_NUMBER);
    assert_int_equal(num("1e", &v), CSV_ERR_NOT_A_NUMBER);
    assert_int_equal(num("1e+", &v), CSV_ERR_NOT_A_NUMBER);
    assert_int_equal(num("0x10", &v), CSV_ERR_NOT_A_NUMBER);
    assert_int_equal(num("-", &v), CSV_ERR_NOT_A_NUMBER);
    assert_int_equal(num(".", &v), CSV_ERR_NOT_A_NUMBER);
    assert_int_equal(num("1 2", &v), CSV_ERR_NOT_A_NUMBER);
    assert_int_equal(num("--1", &v), CSV_ERR_NOT_A_NUMBER);
}

/* Up to 15 significant digits (|x| >= 1e-7): identical to the C library's correctly rounded strtod. */
static void test_numbers_exact_against_strtod(void **state)
{
    (void)state;
    srand(12345);
    char text[64];
    for (int i = 0; i < 20000; ++i) {
        double x = ((double)rand() / RAND_MAX - 0.5) * pow(10.0, (rand() % 12) - 4);
        if (fabs(x) < 1e-7) {
            continue; /* 15 digits below 1e-7 need a power of ten beyond 1e22 */
        }
        snprintf(text, sizeof text, "%.14e", x); /* 15 significant digits */
        double v = 0;
        assert_int_equal(num(text, &v), CSV_OK);
        if (v != strtod(text, NULL)) {
            fail_msg("%s parsed as %.17g, strtod %.17g", text, v, strtod(text, NULL));
        }
        snprintf(text, sizeof text, "%.15g", x);
        assert_int_equal(num(text, &v), CSV_OK);
        assert_true(v == strtod(text, NULL));
    }
}

/* 17-digit forms (the paper's file) parse within one unit in the last place. */
static void test_numbers_long_close(void **state)
{
    (void)state;
    double v = 0;
    const char *text = "-0.30000001192092896";
    assert_int_equal(num(text, &v), CSV_OK);
    assert_true(fabs(v - strtod(text, NULL)) <= fabs(v) * 2.3e-16);
    text = "123456789012345678901234567890";
    assert_int_equal(num(text, &v), CSV_OK);
    assert_true(fabs(v - 1.2345678901234568e29) <= 1e29 * 1e-15);
}

static csv_status_t row(const char *text, unsigned cols, csv_row_t *r)
{
    return csv_parse_row(text, strlen(text), cols, r);
}

static void test_rows(void **state)
{
    (void)state;
    csv_row_t r;
    assert_int_equal(row("12,-0.3,0.25,1e-3", CSV_COLUMNS_INDEXED, &r), CSV_OK);
    assert_true(r.has_index);
    assert_int_equal(r.index, 12);
    assert_true(r.mag_mT[0] == -0.3 && r.mag_mT[1] == 0.25 && r.mag_mT[2] == 1e-3);
    assert_int_equal(row(" 1 , 2 , 3 ", CSV_COLUMNS_PLAIN, &r), CSV_OK);
    assert_false(r.has_index);
    assert_true(r.mag_mT[2] == 3.0);
    assert_int_equal(row("1,2", CSV_COLUMNS_PLAIN, &r), CSV_ERR_TRUNCATED);
    assert_int_equal(row("0,1,2", CSV_COLUMNS_INDEXED, &r), CSV_ERR_TRUNCATED);
    assert_int_equal(row("0,1,2,3,4", CSV_COLUMNS_INDEXED, &r), CSV_ERR_EXTRA_COLUMNS);
    assert_int_equal(row("1,2,3,", CSV_COLUMNS_PLAIN, &r), CSV_ERR_EXTRA_COLUMNS);
    assert_int_equal(row("0,1,,3", CSV_COLUMNS_INDEXED, &r), CSV_ERR_EMPTY_FIELD);
    assert_int_equal(row("0,1,nan,3", CSV_COLUMNS_INDEXED, &r), CSV_ERR_NON_FINITE);
    assert_int_equal(row("-1,1,2,3", CSV_COLUMNS_INDEXED, &r), CSV_ERR_BAD_INDEX);
    assert_int_equal(row("1.5,1,2,3", CSV_COLUMNS_INDEXED, &r), CSV_ERR_BAD_INDEX);
    assert_int_equal(row("99999999999,1,2,3", CSV_COLUMNS_INDEXED, &r), CSV_ERR_BAD_INDEX);
    assert_int_equal(row("0,1,abc,3", CSV_COLUMNS_INDEXED, &r), CSV_ERR_NOT_A_NUMBER);
}

static void test_header(void **state)
{
    (void)state;
    unsigned cols = 0;
    const char *h1 = ",mag_x,mag_y,mag_z";
    const char *h2 = "mag_x, mag_y , mag_z";
    const char *bad = "a,b,c";
    assert_true(csv_line_is_header(h1, strlen(h1)));
    assert_int_equal(csv_parse_header(h1, strlen(h1), &cols), CSV_OK);
    assert_int_equal(cols, 4);
    assert_int_equal(csv_parse_header(h2, strlen(h2), &cols), CSV_OK);
    assert_int_equal(cols, 3);
    assert_int_equal(csv_parse_header(bad, strlen(bad), &cols), CSV_ERR_BAD_HEADER);
    assert_false(csv_line_is_header("0,1,2,3", 7));
}

/* Feed a whole text; collect events. */
#define MAX_EVENTS 16
static size_t feed(const char *text, size_t len, csv_event_t *events)
{
    csv_stream_t s;
    csv_stream_init(&s);
    size_t n = 0;
    csv_event_t ev;
    for (size_t i = 0; i < len; ++i) {
        if (csv_stream_feed(&s, (uint8_t)text[i], &ev) && n < MAX_EVENTS) {
            events[n++] = ev;
        }
    }
    if (csv_stream_finish(&s, &ev) && n < MAX_EVENTS) {
        events[n++] = ev;
    }
    return n;
}

static void test_stream_paper_format_crlf(void **state)
{
    (void)state;
    csv_event_t ev[MAX_EVENTS];
    const char *text = ",mag_x,mag_y,mag_z\r\n0,-0.30000001192092896,-0.3,0\r\n\r\n1,1e-3,2E1,-.5\r\n";
    size_t n = feed(text, strlen(text), ev);
    assert_int_equal(n, 3);
    assert_int_equal(ev[0].kind, CSV_EVENT_HEADER);
    assert_int_equal(ev[1].kind, CSV_EVENT_ROW);
    assert_int_equal(ev[1].line_no, 2);
    assert_int_equal(ev[1].row.index, 0);
    assert_int_equal(ev[2].kind, CSV_EVENT_ROW);
    assert_int_equal(ev[2].line_no, 4); /* blank line 3 skipped but counted */
    assert_true(ev[2].row.mag_mT[1] == 20.0 && ev[2].row.mag_mT[2] == -0.5);
}

static void test_stream_no_header_no_index_no_final_newline(void **state)
{
    (void)state;
    csv_event_t ev[MAX_EVENTS];
    const char *text = "1,2,3\n4,5,6";
    size_t n = feed(text, strlen(text), ev);
    assert_int_equal(n, 2);
    assert_int_equal(ev[1].kind, CSV_EVENT_ROW);
    assert_false(ev[1].row.has_index);
    assert_true(ev[1].row.mag_mT[2] == 6.0);
}

static void test_stream_errors_name_line_and_reason(void **state)
{
    (void)state;
    csv_event_t ev[MAX_EVENTS];
    const char *text = "0,1,2,3\n1,1,2\n2,1,2,3,4\n3,nan,0,0\n4,1,2,3\n";
    size_t n = feed(text, strlen(text), ev);
    assert_int_equal(n, 5);
    assert_int_equal(ev[1].kind, CSV_EVENT_ERROR);
    assert_int_equal(ev[1].line_no, 2);
    assert_int_equal(ev[1].status, CSV_ERR_TRUNCATED);
    assert_string_equal(csv_status_reason(ev[1].status), "truncated");
    assert_int_equal(ev[2].status, CSV_ERR_EXTRA_COLUMNS);
    assert_int_equal(ev[2].line_no, 3);
    assert_int_equal(ev[3].status, CSV_ERR_NON_FINITE);
    assert_int_equal(ev[4].kind, CSV_EVENT_ROW); /* parser recovers on the next line */
}

static void test_stream_very_long_line(void **state)
{
    (void)state;
    static char text[CSV_MAX_LINE * 4];
    size_t len = 0;
    len += (size_t)snprintf(text + len, sizeof text - len, "0,1,2,3\n1,");
    while (len < CSV_MAX_LINE * 3) {
        text[len++] = '5';
    }
    len += (size_t)snprintf(text + len, sizeof text - len, ",0,0\n2,1,2,3\n");
    csv_event_t ev[MAX_EVENTS];
    size_t n = feed(text, len, ev);
    assert_int_equal(n, 3);
    assert_int_equal(ev[1].kind, CSV_EVENT_ERROR);
    assert_int_equal(ev[1].status, CSV_ERR_LINE_TOO_LONG);
    assert_int_equal(ev[1].line_no, 2);
    assert_int_equal(ev[2].kind, CSV_EVENT_ROW);
    assert_int_equal(ev[2].line_no, 3);
}

static void test_stream_bad_bytes(void **state)
{
    (void)state;
    csv_event_t ev[MAX_EVENTS];
    const char text[] = "0,1,2,3\n1,1\r,2,3\n2,1,\0002,3\n";
    size_t n = feed(text, sizeof text - 1, ev);
    assert_int_equal(n, 3);
    assert_int_equal(ev[1].status, CSV_ERR_BAD_CHAR);
    assert_int_equal(ev[2].status, CSV_ERR_BAD_CHAR);
}

static void test_stream_bad_header_and_column_change(void **state)
{
    (void)state;
    csv_event_t ev[MAX_EVENTS];
    const char *text = "x,y,z\n";
    size_t n = feed(text, strlen(text), ev);
    assert_int_equal(n, 1);
    assert_int_equal(ev[0].status, CSV_ERR_BAD_HEADER);
    text = "mag_x,mag_y,mag_z\n0,1,2,3\n";
    n = feed(text, strlen(text), ev);
    assert_int_equal(n, 2);
    assert_int_equal(ev[1].status, CSV_ERR_EXTRA_COLUMNS);
    text = "1,2\n";
    n = feed(text, strlen(text), ev);
    assert_int_equal(ev[0].status, CSV_ERR_TRUNCATED);
    assert_int_equal(n, 1);
}

static void test_reason_names(void **state)
{
    (void)state;
    for (int s = 0; s < CSV_STATUS_COUNT; ++s) {
        assert_non_null(csv_status_reason((csv_status_t)s));
        assert_string_not_equal(csv_status_reason((csv_status_t)s), "unknown");
    }
    assert_string_equal(csv_status_reason(CSV_STATUS_COUNT), "unknown");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_numbers_good),
        cmocka_unit_test(test_numbers_bad),
        cmocka_unit_test(test_numbers_exact_against_strtod),
        cmocka_unit_test(test_numbers_long_close),
        cmocka_unit_test(test_rows),
        cmocka_unit_test(test_header),
        cmocka_unit_test(test_stream_paper_format_crlf),
        cmocka_unit_test(test_stream_no_header_no_index_no_final_newline),
        cmocka_unit_test(test_stream_errors_name_line_and_reason),
        cmocka_unit_test(test_stream_very_long_line),
        cmocka_unit_test(test_stream_bad_bytes),
        cmocka_unit_test(test_stream_bad_header_and_column_change),
        cmocka_unit_test(test_reason_names),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

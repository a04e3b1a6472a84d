/*
 * Fuzz target for the byte-stream CSV parser and the host-link row path.
 * libFuzzer: clang -fsanitize=fuzzer,address,undefined (stm32/fuzz.sh). The same function runs
 * under ctest over the seed corpus (fuzz/replay_main.c) so it always compiles and passes.
 * Invariants checked: no crash/UB, every event names a line within the input, every error has a
 * known reason, every accepted row holds finite numbers.
 */
#include <float.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "csv_row.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int ok)
{
    if (!ok) {
        abort();
    }
}

static int finite(double x) { return x == x && x <= DBL_MAX && x >= -DBL_MAX; }

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    csv_stream_t s;
    csv_event_t ev;
    size_t newlines = 0;
    csv_stream_init(&s);
    for (size_t i = 0; i <= size; ++i) {
        int got = i < size ? csv_stream_feed(&s, data[i], &ev) : csv_stream_finish(&s, &ev);
        if (i < size && data[i] == '\n') {
            ++newlines;
        }
        if (!got) {
            continue;
        }
        check(ev.line_no >= 1 && ev.line_no <= newlines + 1);
        if (ev.kind == CSV_EVENT_ERROR) {
            check(ev.status != CSV_OK && ev.status < CSV_STATUS_COUNT);
        } else if (ev.kind == CSV_EVENT_ROW) {
            for (unsigned a = 0; a < CSV_AXES; ++a) {
                check(finite(ev.row.mag_mT[a]));
            }
        }
    }
    /* Whole input as one row of either width. */
    csv_row_t row;
    if (size <= CSV_MAX_LINE) {
        if (csv_parse_row((const char *)data, size, CSV_COLUMNS_INDEXED, &row) == CSV_OK) {
            check(finite(row.mag_mT[0]) && finite(row.mag_mT[1]) && finite(row.mag_mT[2]));
        }
        (void)csv_parse_row((const char *)data, size, CSV_COLUMNS_PLAIN, &row);
    }
    return 0;
}

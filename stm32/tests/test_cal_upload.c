/* Calibration upload over the link: accepted, stored and active after a "reset"; every refusal
 * names its reason and keeps the previous calibration (in RAM and in flash). */
#include "test_common.h"
#include "test_calib.h"

#include <stdio.h>
#include <string.h>

#include "cal_upload.h"
#include "calib_active.h"
#include "crc16.h"
#include "crc32.h"
#include "fake_board.h"

static calib_t calib;
static calib_active_t active;
static cal_upload_t upload;
static calib_named_t compiled;
static char reply[MSG_MAX_LINE + 1];
static uint32_t hash_xor; /* nonzero: COMMIT with a wrong CRC-32 */

static calib_named_t named(const char *name, double limit)
{
    calib_named_t c;
    memset(&c, 0, sizeof c);
    c.params = k_test_calib;
    c.params.current_limit_A[0] = limit;
    strcpy(c.name, name);
    return c;
}

static const char *send(const char *line, bool safe)
{
    msg_t msg;
    cal_upload_line(&upload, &active, safe, line, strlen(line), &msg);
    memcpy(reply, msg.text, msg.len);
    reply[msg.len] = '\0';
    return reply;
}

/* Upload @p c as the host does; returns the last reply. @p corrupt_crc: break one DATA CRC. */
static const char *upload_calibration(const calib_named_t *c, bool corrupt_crc, uint32_t stop_at)
{
    uint8_t rec[CALIB_RECORD_BYTES];
    calib_record_encode(c, rec);
    const char *r = send("CAL BEGIN", true);
    assert_string_equal(r, "OK CAL-BEGIN bytes=216");
    for (uint32_t off = 0; off < CALIB_RECORD_BYTES && off < stop_at; off += CAL_UPLOAD_CHUNK_BYTES) {
        char line[200];
        int n = snprintf(line, sizeof line, "CAL DATA %u ", (unsigned)off);
        for (uint32_t i = off; i < off + CAL_UPLOAD_CHUNK_BYTES && i < CALIB_RECORD_BYTES; ++i) {
            n += snprintf(line + n, sizeof line - (size_t)n, "%02x", rec[i]);
        }
        uint16_t crc = crc16((const uint8_t *)line, (size_t)n);
        snprintf(line + n, sizeof line - (size_t)n, "*%04X", corrupt_crc ? crc ^ 1u : crc);
        r = send(line, true);
        if (strncmp(r, "OK CAL-DATA", 11) != 0) {
            return r;
        }
    }
    char commit[40];
    snprintf(commit, sizeof commit, "CAL COMMIT %08x", (unsigned)(crc32(rec, sizeof rec) ^ hash_xor));
    return send(commit, true);
}

static int setup(void **state)
{
    (void)state;
    fake_flash_blank();
    hash_xor = 0;
    compiled = named("compiled", 2.0);
    cal_upload_init(&upload);
    assert_int_equal(calib_active_init(&active, &calib, &compiled), CALIB_OK);
    return 0;
}

static void test_upload_is_active_and_survives_reset(void **state)
{
    (void)state;
    assert_int_equal(active.source, CALIB_SOURCE_COMPILED);
    calib_named_t bigger = named("bigger", 8.0);
    char expect[80];
    snprintf(expect, sizeof expect, "OK CAL-COMMIT name=bigger hash=%08x slot=0",
             (unsigned)calib_record_hash(&bigger));
    assert_string_equal(upload_calibration(&bigger, false, CALIB_RECORD_BYTES), expect);
    assert_int_equal(active.source, CALIB_SOURCE_FLASH);
    assert_true(calib.params.current_limit_A[0] == 8.0);
    /* reset: RAM state is gone, the stored calibration is loaded again */
    memset(&calib, 0, sizeof calib);
    memset(&active, 0, sizeof active);
    assert_int_equal(calib_active_init(&active, &calib, &compiled), CALIB_OK);
    assert_int_equal(active.source, CALIB_SOURCE_FLASH);
    assert_string_equal(active.current.name, "bigger");
    assert_int_equal(active.hash, calib_record_hash(&bigger));
    assert_true(calib.valid && calib.params.current_limit_A[0] == 8.0);
}

static void expect_refusal_keeps_previous(const char *got, const char *want)
{
    assert_string_equal(got, want);
    assert_int_equal(active.source, CALIB_SOURCE_COMPILED);
    assert_string_equal(active.current.name, "compiled");
    assert_true(calib.params.current_limit_A[0] == 2.0);
    calib_named_t none;
    unsigned slot;
    uint32_t seq;
    assert_false(calib_store_load(&none, &slot, &seq));
}

static void test_refusals_name_the_reason(void **state)
{
    (void)state;
    calib_named_t bad = named("bad", 2.0);
    bad.params.tick_hz = 1000.0;
    expect_refusal_keeps_previous(upload_calibration(&bad, false, CALIB_RECORD_BYTES),
                                  "ERR cal-refused reason=tick-rate");
    bad = named("bad", 2.0);
    bad.params.actuation_T_per_A[0][1] = 1.98e-3;
    bad.params.actuation_T_per_A[1][0] = 1.98e-3;
    expect_refusal_keeps_previous(upload_calibration(&bad, false, CALIB_RECORD_BYTES),
                                  "ERR cal-refused reason=ill-conditioned");
    bad = named("bad", 25.0);
    expect_refusal_keeps_previous(upload_calibration(&bad, false, CALIB_RECORD_BYTES),
                                  "ERR cal-refused reason=over-rating");
    calib_named_t good = named("good", 4.0);
    expect_refusal_keeps_previous(upload_calibration(&good, true, CALIB_RECORD_BYTES),
                                  "ERR cal-refused reason=checksum");
    expect_refusal_keeps_previous(upload_calibration(&good, false, 96),
                                  "ERR cal-refused reason=incomplete");
    expect_refusal_keeps_previous(send("CAL COMMIT 00000000", true),
                                  "ERR cal-refused reason=no-begin");
    send("CAL BEGIN", true);
    expect_refusal_keeps_previous(send("CAL DATA 48 00*0000", true),
                                  "ERR cal-refused reason=checksum");
    expect_refusal_keeps_previous(send("CAL BEGIN", false), "ERR cal-refused reason=busy");
    fake_flash.erase_fails = true;
    expect_refusal_keeps_previous(upload_calibration(&good, false, CALIB_RECORD_BYTES),
                                  "ERR cal-refused reason=flash-erase");
}

static void test_hash_mismatch(void **state)
{
    (void)state;
    calib_named_t good = named("good", 4.0);
    hash_xor = 1u;
    expect_refusal_keeps_previous(upload_calibration(&good, false, CALIB_RECORD_BYTES),
                                  "ERR cal-refused reason=hash-mismatch");
}

/* Garbage of every kind after a BEGIN: never a crash, never an out-of-range write, never an
 * accepted calibration. */
static void test_random_lines_change_nothing(void **state)
{
    (void)state;
    static const char alphabet[] = "CAL DATCOMIT BEGN0123456789abcdefABCDEF*- xyz\t";
    uint32_t seed = 12345u;
    char line[160];
    for (unsigned n = 0; n < 20000u; ++n) {
        if (n % 7u == 0u) {
            send("CAL BEGIN", true);
        }
        seed = seed * 1664525u + 1013904223u;
        size_t len = (seed >> 8) % (sizeof line - 1u);
        size_t start = 0;
        if ((seed & 3u) != 0u) { /* mostly well-formed heads */
            static const char *const heads[] = {"CAL DATA 0 ", "CAL DATA 48 ", "CAL COMMIT "};
            const char *head = heads[(seed >> 4) % 3u];
            start = strlen(head);
            memcpy(line, head, start);
        }
        for (size_t i = start; i < len; ++i) {
            seed = seed * 1664525u + 1013904223u;
            line[i] = alphabet[(seed >> 16) % (sizeof alphabet - 1u)];
        }
        line[len > start ? len : start] = '\0';
        send(line, (seed & 16u) != 0u);
        assert_true(upload.received <= CALIB_RECORD_BYTES);
    }
    assert_int_equal(active.source, CALIB_SOURCE_COMPILED);
    assert_string_equal(active.current.name, "compiled");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_upload_is_active_and_survives_reset, setup),
        cmocka_unit_test_setup(test_refusals_name_the_reason, setup),
        cmocka_unit_test_setup(test_hash_mismatch, setup),
        cmocka_unit_test_setup(test_random_lines_change_nothing, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

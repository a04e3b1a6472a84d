/**
 * @file link.h
 * The host link protocol on USART1 (text lines, LF-terminated; CRLF accepted).
 *
 * Host -> board:
 *   STREAM                       start a streaming session of field rows (numbered from 0),
 *                                answered OK STREAM queue=<n> prefill=<n>
 *   STREAM CURRENTS              start a streaming session of coil-current rows, answered
 *                                OK STREAM queue=<n> prefill=<n> mode=currents (another word
 *                                after STREAM: ERR unknown-stream-mode)
 *   <seq>,<mx>,<my>,<mz>*<CRC>   one row: field in mT (or, in a STREAM CURRENTS session, the
 *                                currents of outputs 0, 1, 2 in A); CRC = 4 hex digits,
 *                                CRC-16/CCITT-FALSE of every byte before '*'
 *   END <rows>                   all rows sent: play the rest, then mid-scale (reason "end")
 *   PLAY                         play the table compiled into flash
 *   STOP                         mid-scale now (reason "host-stop")
 *   PING                         answered with PONG
 *   STATUS                       answered with STATUS state=.. calibration=.. hash=.. source=..
 *   CAL BEGIN|DATA|COMMIT ...    upload a calibration (cal_upload.h)
 *   RESET                        outputs to mid-scale, then a system reset
 *
 * Board -> host:
 *   MSR-FW ... / READY           banner after reset
 *   OK <command> ...             command accepted
 *   CREDIT <n>                   the host may send rows with seq < n (flow control)
 *   DAC <row> <x> <y> <z>        codes written to the DACs at a tick ("DAC safe ..." at mid-scale)
 *   SAFE <reason> row=<r> applied=<a> [line=<l>] [detail=<d>]   outputs went to mid-scale
 *   ERR <reason> line=<l>        a command that could not be run (outputs unchanged, safe)
 */
#ifndef MSR_LINK_H
#define MSR_LINK_H

#include <stddef.h>
#include <stdint.h>

#include "cal_upload.h"
#include "calib_active.h"
#include "csv_row.h"
#include "player.h"

/** A CREDIT line goes out once the window has grown by this many rows. */
#define LINK_CREDIT_BATCH 16u
#define LINK_CHECKSUM_SEPARATOR '*'
#define LINK_CHECKSUM_HEX_DIGITS 4u
/** The command that starts a session, and its argument for coil-current rows. */
#define LINK_STREAM_COMMAND "STREAM"
#define LINK_STREAM_CURRENTS "CURRENTS"
/** The mode=... value of a coil-current session's OK STREAM answer. */
#define LINK_MODE_CURRENTS "currents"

typedef void (*link_send_fn)(void *ctx, const char *text, size_t len);

typedef struct {
    csv_line_reader_t reader;
    player_t *player;
    link_send_fn send;
    void *ctx;
    uint32_t credit_sent;
    const double (*table)[CALIB_AXES];
    uint32_t table_rows;
    calib_active_t *active;  /**< for STATUS and CAL; NULL: both answered with ERR */
    cal_upload_t upload;
} link_t;

void link_init(link_t *link, player_t *player, link_send_fn send, void *ctx,
               const double (*table)[CALIB_AXES], uint32_t table_rows);

/** Give the link the active calibration (STATUS, CAL). */
void link_set_calibration(link_t *link, calib_active_t *active);

/** Feed one received byte. */
void link_feed(link_t *link, uint8_t byte);

/** Send a CREDIT line when the window has grown enough (call after ticks). */
void link_update_credit(link_t *link);

#endif

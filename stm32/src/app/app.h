/**
 * @file app.h
 * The firmware's application: calibration + DAC bank + player + host link, over board.h.
 * main() on the target is board_init(), app_init(), then app_poll() / board_idle() forever.
 */
#ifndef MSR_APP_H
#define MSR_APP_H

#include <stdbool.h>
#include <stdint.h>

#include "board.h"
#include "calibration.h"

#define APP_FIRMWARE_VERSION "1.0"
/** Report every DAC write on the UART ("DAC ..." lines), as the end-to-end test needs. */
#ifndef APP_REPORT_DAC_CODES
#define APP_REPORT_DAC_CODES 1
#endif
/** Received bytes handled per poll before pending ticks run. */
#define APP_BYTES_PER_POLL 256u

typedef struct {
    const char *calibration_name;
    const calib_params_t *calibration;
    const double (*table)[CALIB_AXES];   /**< waveform compiled into flash, mT */
    uint32_t table_rows;
} app_config_t;

void app_init(const app_config_t *config, const board_info_t *info);
void app_poll(void);

#endif

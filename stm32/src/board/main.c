/**
 * @file main.c
 * Target entry point: board, then the application with the calibration and the flash table
 * generated at build time from the calibration JSON and a field CSV.
 */
#include "app.h"
#include "board.h"
#include "calibration_gen.h"
#include "waveform_table.h"

int main(void)
{
    static const calib_params_t calibration = MSR_CALIBRATION_PARAMS;
    board_info_t info;
    board_init(&info);
    const app_config_t config = {MSR_CALIBRATION_NAME, &calibration, msr_waveform_table,
                                 MSR_WAVEFORM_ROWS};
    app_init(&config, &info);
    for (;;) {
        app_poll();
        board_idle();
    }
}

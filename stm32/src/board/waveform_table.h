/**
 * @file waveform_table.h
 * The PLAY waveform compiled into flash: field rows in mT, generated at build time by
 * `python -m elastica_magnetic.hardware.export` (also `msr real firmware`) into waveform_table.c.
 */
#ifndef MSR_WAVEFORM_TABLE_H
#define MSR_WAVEFORM_TABLE_H

#include <stdint.h>

extern const double msr_waveform_table[][3];
extern const uint32_t msr_waveform_rows;
#define MSR_WAVEFORM_ROWS msr_waveform_rows

#endif

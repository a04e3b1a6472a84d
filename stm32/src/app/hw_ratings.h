/**
 * @file hw_ratings.h
 * Absolute ratings of the coil driver compiled into the firmware: a calibration uploaded at run
 * time is refused when it asks for more (calib_check.c). The host checks the same numbers before
 * sending (elastica_magnetic/hardware/plausibility.py; tests/hardware/test_plausibility.py keeps
 * the two equal). Change them here and there for other amplifiers.
 */
#ifndef MSR_HW_RATINGS_H
#define MSR_HW_RATINGS_H

/** Largest coil current limit a calibration may set, per axis [A]. */
#define HW_MAX_CURRENT_A 20.0
/** Largest current slew limit a calibration may set, per axis [A/s]. */
#define HW_MAX_SLEW_A_PER_S 2000.0
/** DAC8563 with its internal 2.5 V reference and gain 2: 0..5 V, so at most 2.5 V from mid-scale [V]. */
#define HW_MAX_DAC_HALF_SPAN_V 2.5
/** Largest amplifier input offset [V]. */
#define HW_MAX_ABS_OFFSET_V 0.5
/** Range of the amplifier transconductance magnitude [A/V]. */
#define HW_MIN_TRANSCONDUCTANCE_A_PER_V 0.01
#define HW_MAX_TRANSCONDUCTANCE_A_PER_V 100.0
/** Largest 1-norm condition number ||A||_1 ||inv(A)||_1 of the actuation matrix. */
#define HW_MAX_MATRIX_CONDITION 100.0
/** The firmware's fixed row rate [Hz] (SCHED_TICK_HZ); a calibration's tick_hz must equal it. */
#define HW_TICK_HZ 100.0

#endif

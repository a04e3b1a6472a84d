"""Host side of the STM32F407 field-playback firmware (``stm32/``).

- :mod:`~elastica_magnetic.hardware.calibration`: the calibration file (JSON, SI units), its C
  header for the firmware build, the DAC codes the firmware computes (bit-identical model), and
  the least-squares fit of the actuation matrix.
- :mod:`~elastica_magnetic.hardware.protocol`: the line protocol spoken over the UART.
- :mod:`~elastica_magnetic.hardware.stream`: streaming a waveform, or up to three coil currents, to
  a board (pyserial).
- :mod:`~elastica_magnetic.hardware.coil_currents`: a coil-current file the board plays, read and
  checked against a calibration's limits.
- :mod:`~elastica_magnetic.hardware.export`: flash table sources and ``expected_dac_codes.csv``.
"""

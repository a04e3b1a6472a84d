"""The clock columns every reader shares (elastica_magnetic.clock_columns): a file that needs t_s
and has a clock in another spelling or unit names it, with the conversion."""

from __future__ import annotations

import re

import pytest


@pytest.mark.parametrize("header, hint", [
    ("t_ms", "'t_ms' reads as a clock in ms: give seconds under t_s (divided by 1000)"),
    ("Time (min)", "'Time (min)' reads as a clock in min: give seconds under t_s (multiplied by 60)"),
    ("time", "'time' reads as a clock in seconds: name it t_s"),
    ("t [fortnights]", "'t [fortnights]' reads as a clock in 'fortnights': give its times in seconds")])
def test_every_reader_that_needs_t_s_names_a_clock_in_another_spelling(tmp_path, header, hint):
    """One vocabulary of clock columns (elastica_magnetic.clock_columns): a tracker's CSV, a coil-current
    file for the board, a catheter's coil and magnet paths lacking t_s name the clock they have."""
    from elastica_magnetic_rl.sim2real.coil_path import read_coil_path
    from elastica_magnetic_rl.sim2real.magnet_path import read_magnet_path
    from elastica_magnetic_rl.sim2real.tracking import TrajectoryError, read_trajectory

    from elastica_magnetic.hardware.coil_currents import CoilCurrentsError, read_coil_currents

    files = {"track.csv": f"{header},x_0_m,y_0_m,x_1_m,y_1_m\n0,0,0,0.016,0\n",
             "coils.csv": f"{header},current_0_A\n0,1\n",
             "magnet.csv": f"{header},magnet_x_m,magnet_y_m,magnet_z_m,direction_x,direction_y,direction_z\n"
                           "0,0,0.05,0,0,-1,0\n"}
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    readers = [(read_trajectory, "track.csv", TrajectoryError),
               (read_coil_currents, "coils.csv", CoilCurrentsError),
               (read_coil_path, "coils.csv", TrajectoryError),
               (read_magnet_path, "magnet.csv", TrajectoryError)]
    for read, name, error in readers:
        with pytest.raises(error, match=re.escape(hint)):
            read(tmp_path / name)


def test_clock_scales():
    from elastica_magnetic.clock_columns import clock_scale, is_clock

    assert clock_scale("t_s") == ("s", 1.0) and clock_scale("time [ms]") == ("ms", 1e-3)
    assert clock_scale("timestamp_us") == ("us", 1e-6) and clock_scale("t (h)") == ("h", 3600.0)
    assert clock_scale("t [weeks]") == ("weeks", None)
    assert clock_scale("index") is None and not is_clock("mag_x") and not is_clock("tip_x_m")

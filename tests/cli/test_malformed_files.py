"""CSV tables saved as "UTF-8 with BOM" at the command line's doors (issue 48, "Tracebacks and
vague messages", item 3): the mark would only hide the first header (``KeyError: '\\ufeffmag_x'``),
so tables are read as if it were not there. Field CSVs: ``tests/test_field_csv_robustness.py``;
measurements: ``tests/hardware/test_byte_order_marks.py``; spec files and calibrations, which are
refused with a message instead: ``tests/test_byte_order_marks.py``."""

from __future__ import annotations

import pandas as pd

from elastica_magnetic.cli.commands import _read_reference
from elastica_magnetic.reference import reference_trajectory_csv

BOM = b"\xef\xbb\xbf"


def test_a_reference_trajectory_with_a_byte_order_mark_is_read_as_without(tmp_path):
    marked = tmp_path / "trajectory.csv"
    marked.write_bytes(BOM + reference_trajectory_csv().read_bytes())
    pd.testing.assert_frame_equal(_read_reference(marked, 1.0),
                                  _read_reference(reference_trajectory_csv(), 1.0))

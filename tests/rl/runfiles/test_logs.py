"""Run logs (rl/runfiles/logs.py): steps that go back are a damaged log, named (round 4, S12: a
learning curve stepping back was plotted without a word); a spreadsheet's byte-order mark is read
(V6: "the header lacks global_step" for a header that has it)."""

from __future__ import annotations

import pytest
from elastica_magnetic_rl.runfiles.logs import read_log


def test_steps_that_go_back_are_a_damaged_log(tmp_path):
    log = tmp_path / "evaluations.csv"
    log.write_text("global_step,mean_return\n100,1.0\n150,2.0\n100,3.0\n")
    with pytest.raises(ValueError, match=r"evaluations\.csv: damaged log: row 4: global_step 100 is "
                                         r"before the previous row's 150"):
        read_log(log, ("global_step", "mean_return"))
    log.write_text("global_step,mean_return\n100,1.0\n100,2.0\n150,3.0\n")  # equal steps are fine
    assert len(read_log(log, ("global_step", "mean_return"))) == 3


def test_a_byte_order_mark_is_read(tmp_path):
    log = tmp_path / "evaluations.csv"
    log.write_bytes(b"\xef\xbb\xbfglobal_step,mean_return\n100,1.0\n")
    assert read_log(log, ("global_step", "mean_return")) == [{"global_step": "100", "mean_return": "1.0"}]

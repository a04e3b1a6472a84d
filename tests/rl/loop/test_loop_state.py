"""loop.json of another format is refused, not read and rewritten (round 4, S6)."""

from __future__ import annotations

import json

import pytest
from elastica_magnetic_rl.loop.state import LOOP_FORMAT, LOOP_JSON, LoopError, LoopState


def test_a_loop_json_of_another_format_is_refused(tmp_path):
    data = {"format": "msr-loop-v7", "case": "c", "spec": {}, "settings": {}, "steps": {}}
    (tmp_path / LOOP_JSON).write_text(json.dumps(data))
    with pytest.raises(LoopError, match=r"format 'msr-loop-v7' is not one this msr reads"):
        LoopState.read(tmp_path)
    (tmp_path / LOOP_JSON).write_text(json.dumps({**data, "format": LOOP_FORMAT}))
    assert LoopState.read(tmp_path).case == "c"

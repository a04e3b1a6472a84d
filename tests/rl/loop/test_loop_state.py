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


def test_a_loop_json_cut_short_is_named_as_damaged_with_what_restoring_keeps(tmp_path):
    """Round 5, W08: a loop.json cut in half read as a version mismatch ("not a loop state this
    msr can read ... choose another --out", i.e. start over, training included)."""
    data = {"format": LOOP_FORMAT, "case": "c", "spec": {}, "settings": {}, "steps": {}}
    text = json.dumps(data)
    (tmp_path / LOOP_JSON).write_text(text[: len(text) // 2])
    with pytest.raises(LoopError) as refused:
        LoopState.read(tmp_path)
    message = str(refused.value)
    assert "not readable as JSON" in message and "damaged or cut short" in message
    assert "it records the finished steps" in message

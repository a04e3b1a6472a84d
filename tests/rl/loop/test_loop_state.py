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


def test_a_step_result_replaced_by_another_command_runs_again(tmp_path, monkeypatch):
    """Round 8, S7: `msr policy generate --out LOOP/generate --force` replaced the loop's generate
    result; the loop then reported every step done over a result it did not write. A done step
    whose folder no longer holds the recorded result runs again, with the steps that use it."""
    import io

    from elastica_magnetic_rl.cases.case import load_case
    from elastica_magnetic_rl.loop.runner import run_loop
    from elastica_magnetic_rl.loop.settings import LoopSettings
    from elastica_magnetic_rl.loop.state import STEPS

    from elastica_magnetic.result_markers import MARKER
    from elastica_magnetic.results import result_folder

    calls: list[str] = []

    def fake(step):
        def run(ctx):
            calls.append(step)
            with result_folder(ctx.folder / step, kind=step, force=True) as folder:
                (folder.path / "result.txt").write_text(step)
            return {}
        return run

    from elastica_magnetic_rl.loop import runner

    monkeypatch.setattr(runner, "write_report", lambda ctx: None)  # the fakes have no summaries
    monkeypatch.setattr(runner, "headline", lambda step, summary: step)
    functions = {step: fake(step) for step in STEPS}
    out = tmp_path / "loop"
    case, settings = load_case("m1-4mT"), LoopSettings()
    run_loop(case, out, settings, progress=False, log=io.StringIO(), steps=functions)
    assert calls == list(STEPS)
    calls.clear()
    run_loop(case, out, settings, progress=False, log=io.StringIO(), steps=functions)
    assert calls == []  # nothing changed: nothing runs
    marker = out / "generate" / MARKER
    marker.write_text(marker.read_text().replace('"written_utc": "', '"written_utc": "1999'))
    log = io.StringIO()
    run_loop(case, out, settings, progress=False, log=log, steps=functions)
    assert calls == ["generate", "robustness", "firmware"]
    assert "generate/ no longer holds the result this loop wrote" in log.getvalue()


def test_more_steps_alone_extend_the_training_and_with_new_training_settings_start_it_over():
    """A larger ``--steps`` alone resumes the training (its folder kept); with a changed
    ``[training]`` as well, the check and the training run again afresh (--redo check,train)."""
    from pathlib import Path

    import pytest
    from elastica_magnetic_rl.loop.state import STEPS, LoopError, LoopState, plan_loop

    done = {s: {"status": "done", "summary": {"steps": 100} if s == "train" else {}} for s in STEPS}
    state = LoopState(Path("out/loop.json"), "c", {"training": {"a": 1}}, {"steps": 100}, done)
    plan = plan_loop(state, {"training": {"a": 1}}, {"steps": 200}, (), (), False)
    assert plan.extend == ("train",) and plan.run[0] == "train" and "yardstick" in plan.done
    with pytest.raises(LoopError, match="never shortened"):
        plan_loop(state, {"training": {"a": 1}}, {"steps": 50}, (), (), False)
    with pytest.raises(LoopError, match="which only steps check, train use: pass --redo check,train"):
        plan_loop(state, {"training": {"a": 2}}, {"steps": 200}, (), (), False)
    plan = plan_loop(state, {"training": {"a": 2}}, {"steps": 200}, (), ("check", "train"), False)
    assert plan.extend == () and plan.run[:2] == ("check", "train")

"""A crawl's ``[training.td3] yardstick_warmup`` before its ``[yardstick] period`` is recorded: the
spec is valid (a sweep, ``msr field baseline --set-yardstick`` or ``msr loop`` records the period),
``msr case check`` warns, and only the training refuses it. Found in this project's own use: the
refusal sat in the spec parser, so ``msr field baseline --set-yardstick``, the command its message
named as the fix, refused the same spec, and ``msr loop`` could not find the yardstick its training
would warm up from."""

from __future__ import annotations

import contextlib
import copy
import io
import json
from pathlib import Path

import pytest
import tomli_w
from elastica_magnetic_rl.cases.case import load_case, warmup_refusal
from elastica_magnetic_rl.shipping.baseline_sweep import yardstick_spec

from elastica_magnetic.cli import main as msr


def _warm_spec() -> dict:
    data = copy.deepcopy(load_case("m1-4mT").to_dict())
    data["name"] = "warm"
    data["training"] = {**data["training"], "td3": {"yardstick_warmup": 100}}
    data["yardstick"] = {k: v for k, v in data["yardstick"].items() if k not in ("period", "clockwise")}
    return data


def _write(tmp_path: Path) -> Path:
    path = tmp_path / "warm.toml"
    path.write_bytes(tomli_w.dumps(_warm_spec()).encode())
    return path


def _msr(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = msr(list(argv))
        except SystemExit as exc:  # argparse
            status = exc.code
    return status, out.getvalue(), err.getvalue()


def test_the_spec_reads_and_the_refusal_names_what_records_the_period():
    case = load_case(_warm_spec())
    assert not case.has_yardstick_controller
    refusal = warmup_refusal(case)
    assert refusal is not None and "[training.td3] yardstick_warmup = 100" in refusal
    assert "msr field baseline --case SPEC --set-yardstick FILE" in refusal and "msr loop" in refusal
    data = _warm_spec()
    data["yardstick"] = {**data["yardstick"], "period": 2.5, "clockwise": True}
    assert warmup_refusal(load_case(data)) is None


def test_case_check_warns_and_train_refuses_before_any_folder(tmp_path):
    spec = _write(tmp_path)
    status, out, _ = _msr("case", "check", str(spec), "--no-sag", "--json")
    assert status == 0
    issues = json.loads(out)["issues"]
    warned = [i for i in issues if i["key"] == "[training.td3] yardstick_warmup"]
    assert warned and warned[0]["level"] == "warning" and "msr train refuses it" in warned[0]["message"]
    runs = tmp_path / "runs"
    status, _, err = _msr("train", "--case", str(spec), "--seeds", "1", "--steps", "10", "--out", str(runs))
    assert status == 2 and "yardstick_warmup = 100" in err and "give [yardstick] period" in err
    assert not runs.exists()


def test_the_loop_takes_the_spec_and_quick_refuses_it_by_name(tmp_path):
    spec = _write(tmp_path)
    later = "yardstick,train,generate,robustness,refine,robustness-refined,firmware"
    status, _, err = _msr("loop", str(spec), "--out", str(tmp_path / "full"), "--skip", later)
    assert status == 0, err
    assert json.loads((tmp_path / "full" / "loop.json").read_text())["steps"]["check"]["status"] == "done"
    quick = tmp_path / "quick"
    status, _, err = _msr("loop", str(spec), "--out", str(quick), "--quick")
    assert status != 0 and "--quick" in err and "yardstick_warmup needs [yardstick] period" in err
    assert not quick.exists()


@pytest.mark.parametrize("physics, duration, recorded", [("accurate", 10.0, True), ("training", 0.5, False)])
def test_the_sweep_s_spec_copy_is_trainable_when_it_measured_the_yardstick(tmp_path, physics, duration,
                                                                            recorded):
    best = {"mid_dx_m": 0.02, "period_s": 2.5, "clockwise": True, "period_achieved_s": 2.5}
    path = yardstick_spec(load_case(_warm_spec()), best, tmp_path / "warm.toml", physics=physics,
                          duration=duration)
    copy_ = load_case(path)
    assert (warmup_refusal(copy_) is None) == recorded
    if recorded:
        assert copy_.yardstick.period == 2.5 and copy_.yardstick.clockwise

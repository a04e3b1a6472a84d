"""Checks of the shipped policies against what their files claim (``rl/policies/<name>/``).

Each shipped policy records, in ``policy.json``, the distance its actor makes the robot's middle
move in 10 s in the accurate physics from a zero field, and ships that run's waveform as
``fields.csv``. :func:`verify_shipped` runs the actor again and compares: the distance to a relative
tolerance, the distance against the target, and the waveform row by row.

The waveform is reproduced bit for bit on the kind of machine that recorded it (the same CPU model
and numerical libraries: ``evaluation.machine`` in ``policy.json``); there the closed-loop distance
must equal the recorded one. On another CPU the round-off differs at the last bit, and the closed
loop amplifies it through contact switches (a node that touches the ground or not changes the
observation by 1): the waveforms part after a few rows and the policy's distance moves by up to
~1 % (measured: 1.2e-2 for ``m1-4mT-robust``, 2.1e-3 for ``hu2018-crawl``, 1.4e-5 for ``m1-10mT``
on an AMD EPYC against the Intel Xeon that recorded them). There the closed-loop distance is
reported and must still meet the target, and what is machine-independent is checked instead: the
shipped waveform, played open loop as the coils play it, moves the robot the recorded distance to
1e-3 or :data:`REPLAY_DISTANCE_ATOL_M`, whichever is larger (on the recording machine the replay of
the rollout's own field is the closed loop bit for bit; the CSV's mT round trip and another CPU
change the field in its last bit, which moves the 4 mT gaits by tens of micrometres: measured
3e-6 to 1.4e-3, 0.1 to 15 um, over the ten shipped crawlers across those machines).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..runfiles.provenance import machine_fingerprint
from .goto import goto_target
from .policy_files import POLICIES_DIR, POLICY_JSON, read_policy_json, resolve_policy
from .policy_runs import node_dx, run_policy

#: A re-run on the recording machine, or the shipped waveform played open loop on any machine, must
#: reproduce the recorded distance to this relative difference (the closed loop is deterministic on
#: one machine; the open-loop replay differs from it by the hold's sample boundaries, ~1e-4).
DISTANCE_RTOL = 1e-3
#: m: ... or, for the open-loop replay on another machine, to this, whichever is larger: a change of
#: the field in its last bit (as the CSV's mT round trip or another CPU makes) moves the 4 mT gaits,
#: whose feet stick and slip, by up to 16 um (measured: m1-4mT-reach, 3 draws of +-1 ulp on every
#: row, 9.437 mm -> 9.421 to 9.435 mm), 1.7e-3 of its distance; this is 3x that, 1/400 of the
#: robot's 20 mm: a waveform that is not the policy's moves the robot millimetres.
REPLAY_DISTANCE_ATOL_M = 50e-6
#: ... and the shipped waveform to this, mT (the CSV holds full double precision).
FIELD_ATOL_MT = 1e-6


def shipped_names(policies_dir: Path = POLICIES_DIR) -> list[str]:
    """Names of the shipped policies (folders with a ``policy.json``), sorted."""
    return sorted(p.name for p in Path(policies_dir).iterdir() if (p / POLICY_JSON).is_file())


def verify_shipped(name: str, duration: float = 10.0, progress: bool = False,
                   policies_dir: Path = POLICIES_DIR, quick: bool = False,
                   closed_loop_elsewhere: bool = True) -> dict[str, Any]:
    """Roll the shipped policy ``name`` out for ``duration`` s (accurate physics, zero field) and
    compare with its files. Returns the measured and recorded distances (m), their relative
    difference, the largest field difference from ``fields.csv`` over the rows run (mT), the first
    row that differs by more than the tolerance, whether the waveform must match (``waveform_check``:
    ``"exact"`` on the recording machine, else why not), whether the target is reached
    (``meets_target``: only for a run as long as the recorded one, of a case with a yardstick) and
    ``passed``. A policy.json whose evaluation lasts another time than ``duration`` fails (its
    distance cannot be compared), unless the run is ``quick`` (a shorter look: ``distance_check``
    says nothing was compared). ``closed_loop_elsewhere=False``: on another machine than the
    recording one, only the shipped waveform's open-loop replay runs (the closed loop's distance
    is only reported there), judged against the recorded distance and the target: one 10 s run,
    not two."""
    from elastica_magnetic import read_field_csv

    folder = Path(policies_dir) / name
    policy = resolve_policy(folder)  # first: it finishes a replacement a killed ship left
    info = read_policy_json(folder / POLICY_JSON)
    if not policy.case.field_actuated:
        return _verify_tip_reach(name, folder, policy, info, duration, quick)
    evaluation = info.get("evaluation")
    if (not closed_loop_elsewhere and not quick and _recorded_distance(evaluation)
            and evaluation.get("machine") != machine_fingerprint()
            and evaluation["duration_s"] == duration):
        return _verify_replay_only(name, folder, policy, info, duration)
    # a goto policy's waveform was recorded toward its task's target straight ahead (msr policy ship)
    target = goto_target(policy.case, None)
    rollout = run_policy(policy, duration, "accurate", "zero", progress, target=target)
    shipped = read_field_csv(folder / "fields.csv")
    rows = min(len(rollout.fields), len(shipped))
    row_diff_mt = np.max(np.abs(rollout.fields[:rows] - shipped[:rows]), axis=1) * 1e3
    field_diff_mt = float(row_diff_mt.max()) if rows else 0.0
    apart = np.flatnonzero(row_diff_mt > FIELD_ATOL_MT)
    waveform_check = _waveform_check((info.get("evaluation") or {}).get("machine"))
    result: dict[str, Any] = {
        "name": name, "case": info["case"], "duration_s": float(duration), "rows_compared": rows,
        "max_field_diff_mT": field_diff_mt, "field_atol_mT": FIELD_ATOL_MT,
        "first_row_apart": int(apart[0]) if apart.size else None, "waveform_check": waveform_check,
        "mid_dx_m": rollout.mid_dx, "diverged": bool(rollout.meta["diverged"]),
    }
    passed = not result["diverged"] and (waveform_check != "exact" or field_diff_mt <= FIELD_ATOL_MT)
    if not _recorded_distance(evaluation):
        result.update(problem=f"{folder / POLICY_JSON}: no evaluation with duration_s and mid_dx_m (s, m): "
                              "the distance this policy claims is not recorded, so nothing is compared",
                      passed=False)
        return result
    if _other_duration(result, folder, float(evaluation["duration_s"]), duration, quick):
        return result
    if abs(duration - float(evaluation["duration_s"])) < 1e-9:
        recorded = float(evaluation["mid_dx_m"])
        relative = _relative(rollout.mid_dx, recorded)
        met = policy.case.meets_yardstick(rollout.mid_dx, node_dx(rollout), duration,
                                          rollout.meta["diverged"])
        result.update(recorded_mid_dx_m=recorded, relative_diff=relative,
                      distance_rtol=DISTANCE_RTOL, target=policy.case.target_label)
        if policy.case.yardstick.distance_10s > 0.0:
            result["yardstick_10s_m"] = policy.case.yardstick.distance_10s
        if met is not None:  # None: the case has no yardstick, nothing to meet
            result["meets_target"] = met
        if waveform_check == "exact":
            result["distance_check"] = "closed loop"
            distance_ok = relative <= DISTANCE_RTOL
        else:  # another machine: the closed loop's distance is reported, the waveform's checked
            replay = _replayed_distance(policy, shipped, duration)
            allowed = max(DISTANCE_RTOL * abs(recorded), REPLAY_DISTANCE_ATOL_M)
            result.update(distance_check="the shipped waveform, open loop", replay_mid_dx_m=replay,
                          replay_relative_diff=_relative(replay, recorded),
                          replay_allowed_diff_m=allowed)
            distance_ok = abs(replay - recorded) <= allowed
        passed = passed and distance_ok and met is not False
    result["passed"] = bool(passed)
    return result


def _other_duration(result: dict[str, Any], folder: Path, recorded_s: float, run_s: float,
                    quick: bool) -> bool:
    """Whether the evaluation policy.json records (``recorded_s`` s) is not comparable with this
    re-run of ``run_s`` s: a ``quick`` run says so in ``distance_check``; a full one fails
    (``problem``): a distance claimed over another time than the one shipped policies are judged
    on is not checked (``result`` is updated)."""
    if abs(run_s - recorded_s) < 1e-9:
        return False
    if quick:
        result["distance_check"] = (f"not compared: a {run_s:g} s quick run ({POLICY_JSON} records "
                                    f"{recorded_s:g} s)")
        return False
    result.update(problem=f"{folder / POLICY_JSON}: evaluation.duration_s is {recorded_s:g} s, not the "
                          f"{run_s:g} s this re-run lasts (a shipped policy is judged on {run_s:g} s): "
                          "the distance it claims cannot be compared", passed=False)
    return True


def _relative(measured: float, recorded: float) -> float:
    """``|measured - recorded| / |recorded|``; for a recorded 0, 0 when equal, else infinity."""
    if recorded == 0.0:
        return 0.0 if measured == 0.0 else float("inf")
    return abs(measured - recorded) / abs(recorded)


def _recorded_distance(evaluation: Any) -> bool:
    """Whether ``policy.json``'s ``evaluation`` records a distance to compare: ``duration_s`` (s)
    and ``mid_dx_m`` (m), numbers."""
    return isinstance(evaluation, dict) and all(
        isinstance(evaluation.get(k), int | float) and not isinstance(evaluation.get(k), bool)
        for k in ("duration_s", "mid_dx_m"))


def _waveform_check(recorded_on: dict[str, Any] | None) -> str:
    """``"exact"`` where this machine recorded ``fields.csv`` (``recorded_on``: policy.json's
    machine fingerprint), else why the waveform is only reported."""
    here = machine_fingerprint()
    if recorded_on == here:
        return "exact"
    if recorded_on is None:
        return "reported: policy.json does not record the machine that made fields.csv"
    changed = ", ".join(k for k in here if recorded_on.get(k) != here[k])
    return f"reported: fields.csv was recorded on another machine ({changed} differ)"


def _verify_replay_only(name: str, folder: Path, policy: Any, info: dict[str, Any],
                        duration: float) -> dict[str, Any]:
    """:func:`verify_shipped` on another machine without the closed loop: the shipped waveform
    played open loop for ``duration`` s (the recorded evaluation's) must reproduce the recorded
    distance (to :data:`DISTANCE_RTOL` or :data:`REPLAY_DISTANCE_ATOL_M`) and meet the target."""
    from elastica_magnetic import SimulationDivergedError, TabulatedField, read_field_csv, run_open_loop

    shipped = read_field_csv(folder / "fields.csv")
    recorded = float(info["evaluation"]["mid_dx_m"])
    try:
        replay = run_open_loop(policy.case.robot_spec("accurate"), TabulatedField(shipped), duration)
        moved, diverged = replay.mid_dx, False
        first, last = replay.shapes[0][1], replay.shapes[-1][1]
        node = float(last[0, last.shape[1] // 2] - first[0, first.shape[1] // 2])
    except SimulationDivergedError:
        moved, diverged, node = float("nan"), True, float("nan")
    allowed = max(DISTANCE_RTOL * abs(recorded), REPLAY_DISTANCE_ATOL_M)
    met = policy.case.meets_yardstick(moved, node, duration, diverged)
    result: dict[str, Any] = {
        "name": name, "case": info["case"], "duration_s": float(duration), "rows_compared": 0,
        "waveform_check": "not run: the closed loop was left out on this machine (not the recording one)",
        "distance_check": "the shipped waveform, open loop", "diverged": diverged,
        "recorded_mid_dx_m": recorded, "replay_mid_dx_m": moved,
        "replay_relative_diff": _relative(moved, recorded), "replay_allowed_diff_m": allowed,
        "target": policy.case.target_label}
    if met is not None:
        result["meets_target"] = met
    result["passed"] = bool(not diverged and abs(moved - recorded) <= allowed and met is not False)
    return result


def _replayed_distance(policy: Any, fields: np.ndarray, duration: float) -> float:
    """The middle's distance (m, NaN if the simulation diverges) when ``fields`` (T, shape
    ``(rows, 3)``, 100 rows/s) is played open loop for ``duration`` s on the policy's robot in the
    accurate physics: what the coils do with the shipped waveform."""
    from elastica_magnetic import SimulationDivergedError, TabulatedField, run_open_loop

    try:
        return run_open_loop(policy.case.robot_spec("accurate"), TabulatedField(fields), duration).mid_dx
    except SimulationDivergedError:
        return float("nan")


#: m: a tip-reach policy re-run on its held-out targets must end each within this of the recorded
#: final distance (1 % of a catheter's 1 mm tolerance: other CPUs' round-off over 3 s, not a change).
TIP_DISTANCE_ATOL_M = 1e-5


def _tip_reach_record_problem(recorded: Any, n_targets: int, path: Path) -> str | None:
    """What keeps a tip-reach policy's recorded evaluation (``policy.json``'s ``evaluation``) from
    being compared with a re-run over ``n_targets`` held-out targets, or ``None``: ``duration_s``
    (s), ``tip_reach.policy.successes`` (a count) and ``final_distance_m`` (one finite distance,
    m, per target). The message names the key, what it holds and what was expected."""
    fix = "so nothing is compared; restore it (e.g. from git) or ship the policy again"
    mine = (recorded.get("tip_reach") or {}).get("policy") if isinstance(recorded, dict) else None
    if not (isinstance(recorded, dict) and isinstance(mine, dict)):
        return (f"{path}: no evaluation with duration_s and tip_reach.policy (successes, final_distance_m): "
                "the targets this policy claims are not recorded, so nothing is compared")
    entries = (("evaluation.duration_s", recorded, "duration_s", "a duration (s, a number > 0)"),
               ("evaluation.tip_reach.policy.successes", mine, "successes",
                f"a count (an integer from 0 to {n_targets})"))
    for key, table, name, expected in entries:
        if name not in table:
            return f"{path}: {key} is not recorded: expected {expected}, {fix}"
        value = table[name]
        fine = (_is_number(value) and math.isfinite(value) and value > 0 if name == "duration_s" else
                isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= n_targets)
        if not fine:
            return f"{path}: {key} is {value!r} ({type(value).__name__}): expected {expected}, {fix}"
    if "final_distance_m" not in mine:
        return (f"{path}: evaluation.tip_reach.policy.final_distance_m is not recorded: expected {n_targets} "
                f"distances (m, numbers >= 0), {fix}")
    distances = mine["final_distance_m"]
    key = "evaluation.tip_reach.policy.final_distance_m"
    if not isinstance(distances, list) or len(distances) != n_targets:
        given = (f"holds {len(distances)} entries" if isinstance(distances, list) else
                 f"is {type(distances).__name__}")
        shown = ", ".join(repr(d) for d in distances[:3]) if isinstance(distances, list) else ""
        shown = f" ({shown}, ...)" if shown else ""
        return (f"{path}: {key} {given}{shown}: expected {n_targets} distances (m, numbers >= 0), one per "
                f"held-out target, {fix}")
    for i, d in enumerate(distances):
        if not (_is_number(d) and math.isfinite(d) and d >= 0.0):
            return (f"{path}: {key}[{i}] is {d!r} ({type(d).__name__}): expected a distance (m, a finite "
                    f"number >= 0), one per held-out target, {fix}")
    return None


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _verify_tip_reach(name: str, folder: Path, policy: Any, info: dict[str, Any], duration: float,
                      quick: bool = False) -> dict[str, Any]:
    """:func:`verify_shipped` of a tip-reach policy: its case's held-out targets again (accurate
    physics, ``duration`` s at most the task's episode); run as long as recorded, the same targets
    reached and every final distance within :data:`TIP_DISTANCE_ATOL_M` of the recorded one."""
    from .tip_reach import judge_held_out

    judged = judge_held_out(policy.case, policy, duration)
    seconds, run = judged["duration_s"], judged["policy"]
    diverged = "divergence" in run["ended_by"]
    result: dict[str, Any] = {"name": name, "case": info["case"], "duration_s": seconds,
                              "successes": run["successes"], "diverged": diverged}
    passed = not diverged
    recorded = info.get("evaluation")
    summary = f"{run['successes']} of {len(run['targets_m'])} held-out targets in {seconds:g} s"
    problem = _tip_reach_record_problem(recorded, len(run["targets_m"]), folder / POLICY_JSON)
    if problem is not None:
        result.update(problem=problem, passed=False, summary=f"{summary}; {problem}")
        return result
    if _other_duration(result, folder, float(recorded["duration_s"]), seconds, quick):
        result["summary"] = summary + f"; {result['problem']}"
        return result
    if abs(seconds - float(recorded["duration_s"])) < 1e-9:
        mine = recorded["tip_reach"]["policy"]
        difference = float(np.max(np.abs(np.asarray(run["final_distance_m"])
                                          - np.asarray(mine["final_distance_m"]))))
        result.update(recorded_successes=mine["successes"], max_final_distance_diff_m=difference,
                      distance_atol_m=TIP_DISTANCE_ATOL_M)
        passed = passed and run["successes"] == mine["successes"] and difference <= TIP_DISTANCE_ATOL_M
        summary += (f" (recorded {mine['successes']}; final distances within {difference:.1e} m of the "
                    "recorded ones)")
    result.update(summary=summary, passed=bool(passed))
    return result

"""The shipped policies (rl/shipping/shipped.py, rl/policies/): each generates, exports and reaches
what its files claim; one distance re-run in full; a rollout is deterministic."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.shipping import policy_files

from elastica_magnetic.cli import main as msr

#: Whether each shipped policy reaches the authors' 10 s distance, as rl/policies/README.md and
#: the docs state it (a policy re-shipped with another result must update them, and this).
PAPER_CASES = ("m1-10mT", "m1-4mT", "m2-10mT", "m2-4mT")
#: Each paper case's waveform for the robots a lab may build (``<case>-robust``: a policy of the
#: case, fine-tuned on randomized robots; docs/sim_to_real.md).
ROBUST = tuple(f"{case}-robust" for case in PAPER_CASES)
SHIPPED = tuple(sorted(("hu2018-crawl", "m1-4mT-reach", "m1-4mT-designed", "m1-4mT-designed-robust",
                        *PAPER_CASES, *ROBUST)))
#: The shipped tip-reach policies (catheters steered by a source: no waveform, judged on their
#: case's held-out targets).
TIP_REACH_SHIPPED = ("catheter-coils-reach", "catheter-magnet-reach")
#: The shipped goto policies (judged on their task's ring of 12 targets in the accurate physics,
#: beside the steering yardstick; the count their README row and card state).
GOTO_SHIPPED = {"m1-4mT-goto": 12, "m1-10mT-goto": 12}


def case_of(name: str) -> str:
    """The case a shipped policy drives (a ``<case>-robust`` policy drives ``<case>``)."""
    return name.removesuffix("-robust") if name in ROBUST else name


def test_every_shipped_policy_is_tested():
    from elastica_magnetic_rl.shipping.shipped import shipped_names

    assert shipped_names() == sorted(SHIPPED + TIP_REACH_SHIPPED + tuple(GOTO_SHIPPED))


def _strings(value):
    """Every string inside a JSON value."""
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _strings(item)
    elif isinstance(value, list):
        for item in value:
            yield from _strings(item)


def test_no_shipped_policy_records_the_machine_it_was_shipped_on():
    """A shipped policy.json names where it came from portably (``<case>/seedN/best.pt``): no absolute
    path of the shipping machine (a goto ring's ``policy`` once held one)."""
    from pathlib import PurePosixPath, PureWindowsPath

    from elastica_magnetic_rl.shipping.shipped import shipped_names

    for name in shipped_names():
        info = json.loads((policy_files.POLICIES_DIR / name / "policy.json").read_text())
        machine = [s for s in _strings(info) if PurePosixPath(s).is_absolute() or PureWindowsPath(s).drive]
        assert not machine, (name, machine)


@pytest.mark.parametrize("name", sorted(GOTO_SHIPPED))
def test_a_shipped_goto_policy_holds_its_ring_and_plays_by_name(name, tmp_path, capsys):
    """A shipped goto policy's policy.json records at least its stated count of the ring's 12
    targets reached in the accurate physics, beside the yardstick on the same ring; its exported
    module gives its actions (a residual policy, the yardstick corrected by its actor, is refused
    export); and it plays by name (targets off the ring: test_shipped_goto_off_ring.py)."""
    info = json.loads((policy_files.POLICIES_DIR / name / "policy.json").read_text())
    ring, theirs = info["evaluation"]["ring"], info["evaluation"]["yardstick_ring"]
    assert ring["physics"] == theirs["physics"] == "accurate" and ring["targets"] == theirs["targets"] == 12
    assert ring["successes"] >= GOTO_SHIPPED[name]
    assert info["architecture"]["actor_input"] == "steering"
    policy = policy_files.resolve_policy(name)
    assert info["architecture"].get("residual", 0.0) == policy.residual
    assert policy.actor.mirror == info["architecture"].get("actor_mirror", False)
    if policy.residual:  # the yardstick corrected by the actor: no network alone is the policy
        assert msr(["policy", "export", name, "--out", str(tmp_path / "exp")]) != 0
        assert "a residual policy" in capsys.readouterr().err
    else:
        assert msr(["policy", "export", name, "--out", str(tmp_path / "exp")]) == 0
        capsys.readouterr()
        module = torch.jit.load(str(next((tmp_path / "exp").glob("*.ts.pt"))))
        obs = np.random.default_rng(0).normal(size=policy.case.obs_dim).astype(np.float32)
        np.testing.assert_allclose(module(torch.from_numpy(obs)[None]).detach().numpy()[0], policy.act(obs),
                                   atol=1e-6)
    assert msr(["policy", "generate", name, "--target", "0.004,0.011", "--physics", "training", "--duration",
                "0.5", "--out", str(tmp_path / "g"), "--json", "--no-figures", "--no-gif"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert {"final_distance_to_target_m", "time_to_target_s"} <= set(result)


@pytest.mark.parametrize("name", sorted(GOTO_SHIPPED))
def test_a_shipped_goto_policy_runs_on_its_case_as_the_case_is_today(name):
    """A shipped goto policy plays on the robot, ground and physics recorded in its policy.json; its
    card's numbers hold for ``msr train --case NAME`` only while that record is the case's spec. A
    case edited (its ground's friction model switched, say) without the policy shipped again fails
    here instead of leaving a card measured on physics the case no longer has."""
    from elastica_magnetic_rl.cases.case import load_case

    info = json.loads((policy_files.POLICIES_DIR / name / "policy.json").read_text())
    assert isinstance(info.get("case_spec"), dict), name  # nothing recorded would compare as the same
    differ = policy_files.case_spec_difference(info["case_spec"], load_case(name).to_dict())
    assert differ is None, f"{name}: shipped on a spec that differs from its case's today at {differ}"


#: TD3 settings a run sets itself (where it writes, how often it logs), not the recipe's.
RUN_SETTINGS = ("device", "checkpoint_every", "log_every")
#: Shipped residual policies that correct a yardstick other than their case's today (their cards say
#: so first), with the TD3 settings (shipped, the case's) the case changed for its newer yardstick:
#: ``msr train --case`` trains a correction of the case's yardstick. None now: every shipped residual policy
#: corrects its case's yardstick (``m1-4mT-goto`` corrected the 1 s one until the 2 s one's was shipped).
EARLIER_YARDSTICK: dict[str, dict[str, list]] = {}


@pytest.mark.parametrize("name", sorted((*TIP_REACH_SHIPPED, *GOTO_SHIPPED)))
def test_a_residual_policys_case_trains_it_as_it_was_shipped(name):
    """``msr train --case NAME`` sets up the training a shipped residual policy came from: its
    recorded TD3 configuration is the one the case's ``[training]`` recipe and ``[training.td3]``
    give (the seed its own), and the case trains at least as many steps as the shipped actor had
    (its ``best.pt`` may come from before the last). A setting added to TD3 after the policy was
    shipped is not in its record and must keep its default. A policy listed in
    ``EARLIER_YARDSTICK`` differs in exactly the settings listed there."""
    from elastica_magnetic_rl.cases.case import load_case
    from elastica_magnetic_rl.sweep.sweep_plan import _seed_configs

    info = json.loads((policy_files.POLICIES_DIR / name / "policy.json").read_text())
    assert info["architecture"].get("residual")
    recorded = info["training"]["config"]
    case = load_case(name)
    config = _seed_configs({name: case}, [recorded["seed"]], case.training.recipe, None)[recorded["seed"]]
    planned = json.loads(json.dumps(dataclasses.asdict(config)))
    defaults = json.loads(json.dumps(dataclasses.asdict(type(config)())))  # a setting newer than the record
    differ = {key: [value, planned[key]] for key, value in {**defaults, **recorded}.items()
              if key not in RUN_SETTINGS and planned[key] != value}
    assert differ == EARLIER_YARDSTICK.get(name, {}), f"{name}: (shipped, msr train --case) {differ}"
    assert case.training.steps >= info["training"]["training_steps"]
    # the yardstick it corrects is the case's, or the exception is recorded (and still true)
    same_yardstick = info["case_spec"]["yardstick"] == case.to_dict()["yardstick"]
    assert same_yardstick != (name in EARLIER_YARDSTICK), (name, info["case_spec"]["yardstick"])
    if name in EARLIER_YARDSTICK:
        assert "Judged against a slower yardstick than the case's today" in info["notes"]


@pytest.mark.parametrize("name", TIP_REACH_SHIPPED)
def test_a_shipped_tip_reach_policy_plays_by_name_and_holds_its_claim(name, tmp_path, capsys):
    """A shipped catheter policy steers by name to a target (``--target X,Y,Z``), its policy.json
    records at least 18 of the 20 held-out targets within the tolerance (the 90 % its README row
    and card state) beside its yardstick's count, and a short re-run verifies."""
    from elastica_magnetic_rl.shipping.shipped import verify_shipped

    info = json.loads((policy_files.POLICIES_DIR / name / "policy.json").read_text())
    judged = info["evaluation"]["tip_reach"]
    assert judged["policy"]["successes"] >= 18 and len(judged["policy"]["targets_m"]) == 20
    assert judged["yardstick"]["targets_m"] == judged["policy"]["targets_m"]
    assert msr(["policy", "generate", name, "--target", "0.045,0.004,-0.003", "--duration", "0.05",
                "--physics", "training", "--out", str(tmp_path / "g"), "--json", "--no-figures"]) == 0
    assert "tip_error_m" in json.loads(capsys.readouterr().out)
    result = verify_shipped(name, duration=0.05, quick=True)
    assert result["passed"] and result["duration_s"] == 0.05 and "recorded_successes" not in result
    assert result["distance_check"].startswith("not compared: a 0.05 s quick run")


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_policy_generates_and_exports(name, tmp_path, capsys):
    """A policy shipped in the package: generate a short run by name, export it, reload it; its
    card and policy.json agree with the case and report a 10 s distance that reaches the authors'
    (as the README states for every shipped policy), or its target for cases beyond the paper."""


    assert msr(["policy", "generate", name, "--duration", "0.05", "--out", str(tmp_path / "gen"),
                "--no-gif", "--no-figures", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    fields = np.loadtxt(result["fields_csv"], delimiter=",", skiprows=1)
    assert fields.shape == (5, 4)
    assert np.all(np.abs(fields[:, 1:3]) <= 5 * 0.3 + 1e-9)  # mT: from zero, +-0.3 mT per step
    assert msr(["policy", "export", name, "--out", str(tmp_path / "exp")]) == 0
    policy = policy_files.resolve_policy(name)
    assert policy.case.name == case_of(name)
    obs = np.zeros(policy.case.obs_dim, dtype=np.float32)
    module = torch.jit.load(str(next((tmp_path / "exp").glob("*.ts.pt"))))
    action = module(torch.from_numpy(obs)[None]).detach().numpy()[0]
    np.testing.assert_allclose(action, policy.act(obs), atol=1e-6)
    info = policy_files.read_policy_json(policy_files.POLICIES_DIR / name / "policy.json")
    assert info["case"] == case_of(name) and info["name"] == name
    assert info["evaluation"]["duration_s"] == 10.0
    ev = info["evaluation"]
    assert policy.case.meets_yardstick(ev["mid_dx_m"], ev.get("node_dx_m", ev["mid_dx_m"]),
                                       ev["duration_s"], ev["diverged"])
    if case_of(name) in PAPER_CASES:
        assert ev["mid_dx_m"] >= info["yardstick_10s_m"]  # older files: authors_mid_dx_10s_m
    card = (policy_files.POLICIES_DIR / name / "MODEL_CARD.md").read_text()
    assert "meets the target" in card
    shipped_fields = np.loadtxt(policy_files.POLICIES_DIR / name / "fields.csv", delimiter=",", skiprows=1)
    assert shipped_fields.shape == (1000, 4)  # the 10 s waveform, 100 rows/s


@pytest.mark.slow
def test_one_shipped_distance_is_re_run_in_full():
    """The whole 10 s accurate rollout of one shipped policy (a different one each day, in turn;
    ``msr validate shipped`` runs them all; ``--quick``, in the validation tests, their first 0.3 s)
    reaches its target, and on the machine that recorded it reproduces policy.json's distance to
    1e-3 relative and the shipped waveform row by row; elsewhere (round-off, amplified by contact
    switches, parts the waveforms; see elastica_magnetic_rl.shipping.shipped) the shipped waveform
    played open loop reproduces the distance to 1e-3 (there the closed loop, only reported by ``msr
    validate shipped``, is left out: one 10 s run, not two)."""
    import datetime

    from elastica_magnetic_rl.shipping.shipped import verify_shipped

    name = SHIPPED[datetime.date.today().toordinal() % len(SHIPPED)]
    # elsewhere the closed loop is only reported: the suite runs the replay alone (one 10 s run)
    result = verify_shipped(name, closed_loop_elsewhere=False)
    if result["rows_compared"] == 0:  # another machine: the shipped waveform, open loop
        recorded = result["recorded_mid_dx_m"]
        assert abs(result["replay_mid_dx_m"] - recorded) <= max(1e-3 * abs(recorded), 50e-6), result
        assert result["meets_target"] and result["passed"], result
        return
    assert result["rows_compared"] == 1000
    # the closed loop on the recording machine, else the shipped waveform open loop (module docstring)
    if result["distance_check"] == "closed loop":
        assert result["relative_diff"] <= result["distance_rtol"] == 1e-3, result
    else:
        recorded = result["recorded_mid_dx_m"]
        assert abs(result["replay_mid_dx_m"] - recorded) <= max(1e-3 * abs(recorded), 50e-6), result
    assert result["meets_target"] and result["passed"], result
    if result["waveform_check"] == "exact":
        assert result["max_field_diff_mT"] <= 1e-6


def test_a_policy_rollout_is_deterministic_on_one_machine():
    """The claim behind the shipped waveforms: on one machine, two rollouts of a policy give the
    same waveform and trajectory bit for bit."""
    from elastica_magnetic_rl.shipping.policy_runs import resolve_policy, run_policy

    policy = resolve_policy("m2-4mT")
    first, second = (run_policy(policy, 0.3, "accurate", "zero", False) for _ in range(2))
    assert np.array_equal(first.fields, second.fields)
    assert np.array_equal(first.positions, second.positions)


def test_a_shipped_policy_of_a_case_without_a_yardstick_passes_without_a_verdict(tmp_path, monkeypatch):
    """Issue 34: ``msr validate shipped`` of a policy whose case has no yardstick reports no
    ``meets_target`` and passes on the distance alone (the rollout is stood in for: its recorded
    distance and waveform)."""
    import shutil
    from types import SimpleNamespace

    from elastica_magnetic_rl.shipping import shipped

    from elastica_magnetic import read_field_csv

    folder = tmp_path / "hu2018-crawl"
    shutil.copytree(policy_files.POLICIES_DIR / "hu2018-crawl", folder,
                    ignore=shutil.ignore_patterns("seeds"))
    info = json.loads((folder / "policy.json").read_text())
    info["case_spec"]["yardstick"] = {"distance_10s": 0.0, "source": ""}
    # as shipped for such a case: its hash of the case_spec it was shipped with
    info["case_spec_sha256"] = policy_files.case_spec_sha256(info["case_spec"])
    (folder / "policy.json").write_text(json.dumps(info))
    recorded = info["evaluation"]["mid_dx_m"]
    fields = read_field_csv(folder / "fields.csv")
    positions = np.zeros((2, 3, 17))
    positions[1, 0, :] = recorded
    rollout = SimpleNamespace(mid_dx=recorded, fields=fields, positions=positions,
                              meta={"diverged": None})
    monkeypatch.setattr(shipped, "run_policy", lambda *a, **k: rollout)
    monkeypatch.setattr(shipped, "_replayed_distance", lambda *a: recorded)  # another machine's check
    result = shipped.verify_shipped("hu2018-crawl", policies_dir=tmp_path)
    assert "meets_target" not in result and "yardstick_10s_m" not in result and result["passed"]
    # the committed policy, with its yardstick (+25.3 mm): judged, and met
    committed = shipped.verify_shipped("hu2018-crawl")
    assert committed["meets_target"] is True and committed["passed"]
    assert committed["yardstick_10s_m"] == 0.0253


def _stand_in_rollout(name: str, mid_dx: float):
    """A closed-loop rollout of the shipped policy ``name`` stood in for: its shipped waveform and
    a middle that moved ``mid_dx`` (m)."""
    from types import SimpleNamespace

    from elastica_magnetic import read_field_csv

    positions = np.zeros((2, 3, 17))
    positions[1, 0, :] = mid_dx
    fields = read_field_csv(policy_files.POLICIES_DIR / name / "fields.csv")
    return SimpleNamespace(mid_dx=mid_dx, fields=fields, positions=positions, meta={"diverged": None})


@pytest.mark.parametrize("closed_loop, replayed, passed", [
    (1.012, 1.0002, True),  # m1-4mT-robust on an AMD EPYC: the closed loop 1.2 % away, the waveform 2e-4
    (1.0, 1.0019, True),  # 40 um: within a last bit's reach of a 4 mT gait (50 um), though 1.9e-3
    (1.0, 1.003, False),  # 63 um
    (1.0, 1.01, False),  # the shipped waveform no longer moves the robot its recorded distance
    (1.0, float("nan"), False),  # ... or diverges
    (0.9, 1.0, False),  # the closed loop falls short of the target (+20.5 mm; recorded +21.0)
])
def test_on_another_machine_the_shipped_waveform_is_what_reproduces_the_distance(
        monkeypatch, closed_loop, replayed, passed):
    """On a CPU other than the recording one the closed loop's round-off parts the waveforms and
    moves the distance by up to ~1 %: the distance is then checked by playing the shipped waveform
    open loop, the closed loop's reported and judged against the target only."""
    from elastica_magnetic_rl.shipping import shipped

    name = "m1-4mT-robust"
    info = policy_files.read_policy_json(policy_files.POLICIES_DIR / name / "policy.json")
    recorded = info["evaluation"]["mid_dx_m"]
    monkeypatch.setattr(shipped, "machine_fingerprint", lambda: {"cpu": "another CPU"})
    rollout = _stand_in_rollout(name, closed_loop * recorded)
    monkeypatch.setattr(shipped, "run_policy", lambda *a, **k: rollout)
    monkeypatch.setattr(shipped, "_replayed_distance", lambda *a: replayed * recorded)
    result = shipped.verify_shipped(name)
    assert result["waveform_check"].startswith("reported") and result["passed"] is passed
    assert result["distance_check"] == "the shipped waveform, open loop"
    assert result["relative_diff"] == pytest.approx(abs(closed_loop - 1.0))
    assert result["meets_target"] is (closed_loop * recorded >= 0.0205)


def test_on_the_recording_machine_the_closed_loop_distance_must_reproduce(monkeypatch):
    """Where ``policy.json``'s machine is this one the waveform must match bit for bit and the closed
    loop's distance to 1e-3; no open-loop replay stands in for it."""
    from elastica_magnetic_rl.shipping import shipped

    name = "m1-4mT-robust"
    info = policy_files.read_policy_json(policy_files.POLICIES_DIR / name / "policy.json")
    recorded = info["evaluation"]["mid_dx_m"]
    monkeypatch.setattr(shipped, "machine_fingerprint", lambda: info["evaluation"]["machine"])
    monkeypatch.setattr(shipped, "_replayed_distance", lambda *a: pytest.fail("no replay on this machine"))
    for factor, passed in ((1.0, True), (1.002, False)):
        rollout = _stand_in_rollout(name, factor * recorded)
        monkeypatch.setattr(shipped, "run_policy", lambda *a, r=rollout, **k: r)
        result = shipped.verify_shipped(name)
        assert result["waveform_check"] == "exact" and result["distance_check"] == "closed loop"
        assert result["passed"] is passed and "replay_mid_dx_m" not in result


def test_the_open_loop_replay_of_a_rollouts_waveform_moves_the_robot_as_the_rollout_did():
    """What stands in for the closed loop on another machine: the waveform a policy commanded, played
    open loop on the case's robot, gives the rollout's distance (1 s of m1-4mT)."""
    from elastica_magnetic_rl.shipping.policy_runs import resolve_policy, run_policy
    from elastica_magnetic_rl.shipping.shipped import DISTANCE_RTOL, _replayed_distance

    policy = resolve_policy("m1-4mT")
    rollout = run_policy(policy, 1.0, "accurate", "zero", False)
    replayed = _replayed_distance(policy, rollout.fields, 1.0)
    assert abs(rollout.mid_dx) > 1e-4  # it moved: a relative difference means something
    assert abs(replayed - rollout.mid_dx) <= DISTANCE_RTOL * abs(rollout.mid_dx), (replayed, rollout.mid_dx)


def test_on_another_machine_the_replay_alone_can_judge_a_shipped_policy(tmp_path, monkeypatch):
    """``verify_shipped(closed_loop_elsewhere=False)`` on a machine that did not record the policy:
    no closed-loop rollout, the shipped waveform played open loop against the recorded distance
    (what the suite's full 10 s check runs there, one run instead of two). Here 0.3 s of
    ``m1-4mT``, its evaluation recorded over 0.3 s on "another" machine."""
    import shutil

    from elastica_magnetic_rl.shipping import shipped

    from elastica_magnetic import read_field_csv

    folder = tmp_path / "m1-4mT"
    shutil.copytree(policy_files.POLICIES_DIR / "m1-4mT", folder, ignore=shutil.ignore_patterns("seeds"))
    info = json.loads((folder / "policy.json").read_text())
    policy = policy_files.resolve_policy(folder)
    moved = shipped._replayed_distance(policy, read_field_csv(folder / "fields.csv"), 0.3)
    monkeypatch.setattr(shipped, "run_policy", lambda *a, **k: pytest.fail("the closed loop ran"))
    for recorded, passes in ((moved, True), (moved + 1e-3, False)):
        info["evaluation"] = {**info["evaluation"], "duration_s": 0.3, "mid_dx_m": recorded,
                              "machine": {"cpu": "another machine's"}}
        (folder / "policy.json").write_text(json.dumps(info))
        result = shipped.verify_shipped("m1-4mT", duration=0.3, policies_dir=tmp_path,
                                        closed_loop_elsewhere=False)
        assert result["rows_compared"] == 0 and result["distance_check"] == "the shipped waveform, open loop"
        assert result["replay_mid_dx_m"] == pytest.approx(moved, abs=1e-12)
        assert result["passed"] is passes and "meets_target" not in result  # 0.3 s: no verdict

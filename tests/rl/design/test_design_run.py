"""``msr design`` end to end at smoke settings (issue 52): the batched evaluation is the
yardstick's own rollout, a killed design resumes to the result of an uninterrupted one, the
folder rules, and drawn robots of every form."""

from __future__ import annotations

import csv
import json
import signal
from pathlib import Path

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.design.evaluate import Trial, run_trials
from elastica_magnetic_rl.design.folder import DesignError
from elastica_magnetic_rl.design.run import DesignSettings, run_design
from elastica_magnetic_rl.envs.yardsticks import RotatingFieldPolicy
from elastica_magnetic_rl.shipping.policy_runs import run_policy
from faults import Fault
from hypothesis import HealthCheck, Phase, given, settings
from spec_matrix import user_specs

from elastica_magnetic.cli import main as msr
from elastica_magnetic.io import OutputPathError
from elastica_magnetic.specfile import dumps, read_spec

#: A design of seconds: 0.3 s runs of the training physics, two judged periods, one process.
TINY = DesignSettings(physics="training", search_duration=0.3, final_physics="training",
                      final_duration=0.3, final_periods=(0.5, 1.0), generations=2, minutes=None,
                      popsize=3, workers=1, gif=False)
QUICK = ["--quick", "--popsize", "3", "--workers", "1", "--no-progress"]


@pytest.mark.parametrize("period, clockwise", [(1.0, True), (0.7, False)])
def test_the_batched_trial_is_the_yardsticks_own_rollout(period, clockwise):
    """The search's distance of a robot under a rotating field is the one ``msr field baseline``
    measures with the environment, to the last bit (same field rows, same simulator)."""
    case = load_case("m1-4mT")
    batched = run_trials(case, [Trial(case.robot_spec("training"), period, clockwise)], 0.5)[0]
    rollout = run_policy(RotatingFieldPolicy(case, period, clockwise), 0.5, "training", progress=False)
    mid = rollout.trajectory["mid_x_m"]
    assert batched == mid.iloc[-1] - mid.iloc[0]


def test_robots_of_one_batch_do_not_see_each_other():
    case = load_case("m1-4mT")
    robot = case.robot_spec("training")
    alone = run_trials(case, [Trial(robot, 1.0, True)], 0.3)
    together = run_trials(case, [Trial(robot, 0.6, False), Trial(robot, 1.0, True)], 0.3)
    assert together[1] == alone[0] and together[0] != alone[0]


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_the_design_folder_and_its_summary(tmp_path):
    out = tmp_path / "design"
    summary = run_design("m1-4mT", out, TINY)
    assert {p.name for p in out.iterdir()} >= {"best.toml", "history.csv", "summary.json", "design.json",
                                                "final_sweep.csv", "convergence.png", "magnetization.png",
                                                "report.md", "gait"}
    assert json.loads((out / "summary.json").read_text()) == json.loads(json.dumps(summary))
    assert len(_rows(out / "history.csv")) == 2 * 3
    best = case_from_dict(read_spec(out / "best.toml"), "best.toml")
    assert best.name == "m1-4mT-designed"
    # round 10, V5: the words of the starting robot described its own magnetization
    assert best.description.startswith("Designed by msr design from m1-4mT")
    assert best.robot.tables["robot"]["name"] == "yao2023-m1-designed"
    # round 17 S: a smoke run's distance (of the training physics) was written as
    # the 10 s accurate-physics yardstick, which msr train then took as the target (TINY: 0.3 s)
    assert best.yardstick.distance_10s == 0.0 and best.yardstick.period is None
    # the start is the spec's own robot, judged by the same sweep as the best
    sweep = _rows(out / "final_sweep.csv")
    assert {r["design"] for r in sweep} == {"start", "best"}
    start = max(float(r["distance_m"]) for r in sweep if r["design"] == "start")
    assert summary["objective_start_m"] == pytest.approx(start)
    segments = summary["best_segments"]
    m = best.robot_spec("accurate").magnetization
    assert np.allclose(m[:, 0], np.array(segments[0]["direction"]) * segments[0]["magnitude"])


def test_the_first_generation_tries_the_turning_designs(tmp_path):
    """Beside CMA-ES's draws, one full turn of the direction along the body in each sense."""
    run_design("m1-4mT", tmp_path / "d", TINY)
    first = [r for r in _rows(tmp_path / "d" / "history.csv") if r["generation"] == "1"]
    angles = [[round(float(r[f"angle_deg_{k}"])) % 360 for k in range(6)] for r in first]
    assert angles[0] == [0, 60, 120, 180, 240, 300]
    assert angles[1] == [0, 300, 240, 180, 120, 60]
    assert angles[2] not in angles[:2]


def test_a_resumed_design_equals_an_uninterrupted_one(tmp_path):
    whole = run_design("m1-4mT", tmp_path / "whole", TINY)
    first = run_design("m1-4mT", tmp_path / "parts", DesignSettings(**{**TINY.__dict__, "generations": 1}))
    assert first["search"]["generations"] == 1
    again = run_design("m1-4mT", tmp_path / "parts", TINY, resume=True)
    assert _rows(tmp_path / "parts" / "history.csv") == _rows(tmp_path / "whole" / "history.csv")
    assert again["objective_best_m"] == whole["objective_best_m"]
    assert again["best_segments"] == whole["best_segments"]


def test_a_design_killed_mid_checkpoint_resumes_to_the_same_result(fault_server, tmp_path, capsys):
    argv = ["design", "m1-4mT", "--generations", "3", *QUICK]
    assert msr([*argv, "--out", str(tmp_path / "whole"), "--json"]) == 0
    whole = json.loads(capsys.readouterr().out)
    out = tmp_path / "killed"
    # the checkpoints: the start (1), after generation 1 (2), killed while writing generation 2's
    done = fault_server.run([*argv, "--out", str(out)],
                            Fault("open", r"/search/\.state\.tmp\d+\.pkl$", "SIGKILL", nth=3))
    assert done.returncode == -signal.SIGKILL
    assert len(_rows(out / "history.csv")) == 3  # generation 1 only: the second was not recorded
    assert msr([*argv, "--out", str(out), "--resume", "--json"]) == 0
    resumed = json.loads(capsys.readouterr().out)
    assert _rows(out / "history.csv") == _rows(tmp_path / "whole" / "history.csv")
    assert resumed["objective_best_m"] == whole["objective_best_m"]
    assert (out / "best.toml").read_text() == (tmp_path / "whole" / "best.toml").read_text()


def test_the_folder_rules(tmp_path, capsys):
    out = tmp_path / "design"
    run_design("m1-4mT", out, TINY)
    with pytest.raises(OutputPathError, match="continue it with --resume, or replace it with --force"):
        run_design("m1-4mT", out, TINY)
    other = DesignSettings(**{**TINY.__dict__, "seed": 7})
    with pytest.raises(DesignError, match=r"other options \(--seed: 0 then, 7 now\)"):
        run_design("m1-4mT", out, other, resume=True)
    # round 19 V: an option left out read "None then"
    with pytest.raises(DesignError, match=r"other options \(--popsize: 3 then, the default now\)"):
        run_design("m1-4mT", out, DesignSettings(**{**TINY.__dict__, "popsize": None}), resume=True)
    (out / "mine.txt").write_text("a user's note")
    with pytest.raises(OutputPathError, match="files msr did not write \\(mine.txt\\)"):
        run_design("m1-4mT", out, other, force=True)
    (out / "mine.txt").unlink()
    replaced = run_design("m1-4mT", out, other, force=True)
    assert replaced["search"]["seed"] == 7
    with pytest.raises(DesignError, match="holds no design to continue"):
        run_design("m1-4mT", tmp_path / "new", TINY, resume=True)
    # a folder of another command is refused, untouched
    assert msr(["field", "simulate", "--duration", "0.01", "--out", str(tmp_path / "sim")]) == 0
    before = sorted(p.name for p in (tmp_path / "sim").iterdir())
    assert msr(["design", "m1-4mT", "--out", str(tmp_path / "sim"), "--generations", "1", *QUICK]) == 2
    assert "simulate" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "sim").iterdir()) == before


def test_bad_options_are_refused_before_any_work(tmp_path, capsys):
    spec = load_case("m1-4mT").to_dict()
    spec["design"] = {"segments": 20}
    path = tmp_path / "my.toml"
    path.write_text(dumps(spec))
    for argv, named in (([str(path)], "[design] segments: must be <= 12"),
                        (["m1-4mT", "--popsize", "1"], "--popsize"),
                        (["m1-4mT", "--search-physics", "fast"], "--search-physics"),
                        (["m1-4mT", "--finalists", "0"], "--finalists")):
        with pytest.raises(SystemExit) as refused:  # as the options are parsed
            msr(["design", *argv, "--out", str(tmp_path / "d")])
        assert refused.value.code == 2 and named in capsys.readouterr().err
    assert not (tmp_path / "d").exists()
    # finalists are the accurate judgement of a search run in the training physics: alone, nothing
    assert msr(["design", "m1-4mT", "--finalists", "3", "--out", str(tmp_path / "d")]) == 2
    assert "--finalists 3: acts only with --search-physics training" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


DRAWN = settings(max_examples=3, derandomize=True, database=None, deadline=None,
                 phases=[Phase.generate],
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


@DRAWN
@given(spec=user_specs(task="crawl"))
def test_designs_of_drawn_robots(tmp_path_factory, spec):
    """Robots of every form (segments, tables, named patterns; Poisson ratio or shear modulus;
    band or round; two or three axes) design, and the best spec parses back."""
    folder = tmp_path_factory.mktemp("drawn")
    path = folder / "drawn.toml"
    length = spec["robot"]["length"]
    spec = {**spec, "design": {"segments": 3, "magnitude": "free", "length": [0.9 * length, 1.1 * length]}}
    path.write_text(dumps(spec))
    summary = run_design(path, folder / "design", DesignSettings(**{**TINY.__dict__, "generations": 1}))
    best = case_from_dict(read_spec(folder / "design" / "best.toml"), "best.toml")
    assert len(summary["best_segments"]) == 3
    assert best.robot.n_elements == spec["robot"]["n_elements"]
    assert 0.9 * length <= best.robot.tables["robot"]["length"] <= 1.1 * length
    assert best.robot.tables["robot"]["length"] == pytest.approx(summary["best_sizes_m"]["length"])
    assert summary["objective_start_m"] is not None


def test_a_minutes_budget_counts_the_whole_design(tmp_path):
    """--minutes covers the starting sweep, the search and the final judgement: a budget smaller
    than one generation runs one (at least one), a larger one stops early enough for the end."""
    from elastica_magnetic_rl.design.run import _spent
    from elastica_magnetic_rl.design.search import SearchState

    short = run_design("m1-4mT", tmp_path / "d", DesignSettings(**{**TINY.__dict__, "generations": None,
                                                                  "minutes": 0.001}))
    assert short["search"]["generations"] == 1
    state = SearchState(es=type("ES", (), {"popsize": 9})(), rng_state=None, generation=3, elapsed_s=600.0)
    # the search runs the judged 10 s: 18 trials took 90 s, 5 s each; the end: the best design's
    # 24 judged trials (the start's reused) x 5 s + the gait (2 workers x 5 s) + 60 s = 190 s
    spent = 120 + 600 + 90 + 190
    assert not _spent(state, DesignSettings(minutes=spent / 60 + 0.01), 90.0, 18, 120.0)
    assert _spent(state, DesignSettings(minutes=spent / 60 - 0.01), 90.0, 18, 120.0)
    # 5 s runs judged by 10 s ones: each end trial costs 2; both designs judged (48 trials) and
    # the 6 finalists run again (12): 60 x 10 s + the gait 20 s + 60 s = 680 s
    shorter = {"search_duration": 5.0}
    spent = 120 + 600 + 90 + 680
    assert not _spent(state, DesignSettings(minutes=spent / 60 + 0.01, **shorter), 90.0, 18, 120.0)
    assert _spent(state, DesignSettings(minutes=spent / 60 - 0.01, **shorter), 90.0, 18, 120.0)


def test_a_candidate_without_magnetization_scores_as_no_robot():
    from elastica_magnetic_rl.design.run import load_design
    from elastica_magnetic_rl.design.search import DIVERGED_SCORE, evaluate_candidates

    design = load_design("m1-4mT")
    spec = design.base | {"robot": {**design.base["robot"], "magnetization": {
        "kind": "uniform", "magnitude": 0.0}}}
    records = evaluate_candidates(design.case, [spec, design.base], [1.0, 1.0], "training", 0.05, 1)
    assert records[0]["objective_m"] == DIVERGED_SCORE and records[1]["objective_m"] > DIVERGED_SCORE


@pytest.mark.slow
def test_the_robust_objective_runs_on_a_pattern_robot(tmp_path):
    """Round 10, T2: --objective robust died with a KeyError (the variation set of the segments
    form applied to the spec's own pattern form)."""
    summary = run_design("m1-4mT", tmp_path / "robust",
                         DesignSettings(**{**TINY.__dict__, "objective": "robust", "generations": 1}))
    assert summary["objective"] == "robust" and summary["objective_start_m"] is not None
    best = summary["best"]
    assert len(best["variants"]) == 25 and best["robust_m"] == min(
        v["distance_m"] for v in best["variants"])


@pytest.mark.slow
def test_the_robust_search_sees_the_corners_and_its_judgement_the_searched_field(tmp_path):
    """Issue 52: the robust search judged each candidate on 9 robots (no corners) and the end
    judged the 25 robots under the nominal robot's best field only: the weak-and-stiff corners,
    which set the worst case, were never searched for, and a design found for slow rotations was
    judged under a fast one. Now the search sees the 25 robots, and the judgement takes the
    better of the nominal best field and the field the search found."""
    from elastica_magnetic_rl.design.run import _variation_set, load_design
    from elastica_magnetic_rl.design.search import _worst, variant_specs

    design = load_design("m1-4mT")
    robust = DesignSettings(**{**TINY.__dict__, "objective": "robust", "generations": 1, "popsize": 2,
                               "search_duration": 0.2, "finalists": 2})
    variations = _variation_set(design, robust)
    assert len(variations[1]) == 25 and sum(v.kind == "corner" for v in variations[1]) == 16
    summary = run_design("m1-4mT", tmp_path / "robust", robust)
    record = json.loads((tmp_path / "robust" / "design.json").read_text())
    best = summary["best"]
    searched = record["finalists"][summary["search"]["chosen_finalist"]]
    fields = {(float(f"{period:.12g}"), clockwise) for period, clockwise in (  # the sweep's digits
        (best["period_s"], best["clockwise"]), (searched["period_s"], searched["clockwise"]))}
    spec = design.space.spec_of(design.base, np.array(searched["vector"]))
    robots = variant_specs(design.case, spec, "training", variations)
    worst = {f: _worst(list(run_trials(design.case, [Trial(r, *f) for r in robots], 0.3))) for f in fields}
    chosen = (best["robust_field"]["period_s"], best["robust_field"]["clockwise"])
    assert best["robust_m"] == worst[chosen] == max(worst.values())
    # the design is meant for that field: its gait is drawn under it, the report names both worst cases
    gait = json.loads((tmp_path / "robust" / "gait" / "generate.json").read_text())
    turn = "clockwise" if chosen[1] else "counter-clockwise"
    assert gait["policy"] == f"rotating field, {turn}, period {chosen[0]:g} s"
    # its files are named where they are, not where the end was staged (they named .msr-end/gait)
    assert Path(gait["trajectory_csv"]).is_file() and Path(gait["fields_csv"]).parent == (
        tmp_path / "robust" / "gait").resolve()
    report = (tmp_path / "robust" / "report.md").read_text()
    assert "| design | worst | its field | worst robot |" in report and report.count("| start |") == 2


def test_a_design_interrupted_in_its_first_generation_resumes(tmp_path, monkeypatch):
    """Round 10, D1: killed before its first checkpoint of a generation, --resume and --force
    both refused the design's own search/ folder as "files msr did not write"."""
    import elastica_magnetic_rl.design.run as design_run

    calls = {"n": 0}
    real = design_run.run_generation

    def interrupted(*args, **kwargs):
        calls["n"] += 1
        raise KeyboardInterrupt

    monkeypatch.setattr(design_run, "run_generation", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_design("m1-4mT", tmp_path / "d", TINY)
    monkeypatch.setattr(design_run, "run_generation", real)
    resumed = run_design("m1-4mT", tmp_path / "d", TINY, resume=True)
    assert calls["n"] == 1 and resumed["search"]["generations"] == 2


def test_a_users_file_saved_during_a_design_is_never_taken_for_the_designs(tmp_path, monkeypatch):
    """Round 10, D4: a file the user saved into the folder while the design ran was listed in its
    marker, and the next --force removed it."""
    import elastica_magnetic_rl.design.run as design_run

    out = tmp_path / "d"
    real = design_run.run_generation

    def with_a_note(*args, **kwargs):
        (out / "user.txt").write_text("my lab notes\n")
        return real(*args, **kwargs)

    monkeypatch.setattr(design_run, "run_generation", with_a_note)
    run_design("m1-4mT", out, TINY)
    monkeypatch.setattr(design_run, "run_generation", real)
    with pytest.raises(OutputPathError, match=r"files msr did not write \(user.txt\)"):
        run_design("m1-4mT", out, TINY, force=True)
    assert (out / "user.txt").read_text() == "my lab notes\n"


def _fingerprint(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _stopped_in_the_second_generation(monkeypatch) -> dict[str, int]:
    """``run_generation`` patched to raise a Ctrl-C at its second call; the calls counted."""
    import elastica_magnetic_rl.design.run as design_run

    real, calls = design_run.run_generation, {"n": 0}

    def stopped_in_the_second(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(design_run, "run_generation", stopped_in_the_second)
    return calls


def test_an_interrupted_force_keeps_the_earlier_design(tmp_path, monkeypatch):
    """Round 10, D2: --force removed the earlier design at its start; a Ctrl-C then left neither."""
    out = tmp_path / "d"
    run_design("m1-4mT", out, TINY)
    before = _fingerprint(out)
    other = DesignSettings(**{**TINY.__dict__, "seed": 5})
    with monkeypatch.context() as m:
        calls = _stopped_in_the_second_generation(m)
        with pytest.raises(KeyboardInterrupt):
            run_design("m1-4mT", out, other, force=True)
    assert calls["n"] == 2 and _fingerprint(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]  # nothing left beside it
    replaced = run_design("m1-4mT", out, other, force=True)
    assert replaced["search"]["seed"] == 5 and _fingerprint(out) != before
    assert json.loads((out / "summary.json").read_text())["search"]["seed"] == 5


def test_a_full_disk_at_the_end_leaves_an_unfinished_design_to_resume(tmp_path, monkeypatch):
    """Round 10, D3: a disk filling during the end's writes left summary.json and best.toml (a
    design that looked finished) without gait/, and the message did not say --resume."""
    import errno

    import elastica_magnetic_rl.design.outputs as outputs

    real = outputs._write_gait

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    out = tmp_path / "d"
    monkeypatch.setattr(outputs, "_write_gait", full)
    with pytest.raises(OutputPathError, match="is unfinished .*continue with --resume"):
        run_design("m1-4mT", out, TINY)
    names = {p.name for p in out.iterdir()}
    assert names.isdisjoint({"summary.json", "best.toml", "report.md", "gait"})
    assert {"design.json", "history.csv", "search"} <= names
    monkeypatch.setattr(outputs, "_write_gait", real)
    summary = run_design("m1-4mT", out, TINY, resume=True)
    assert summary["search"]["generations"] == 2 and (out / "gait").is_dir()
    assert not (out / ".msr-end").exists()


def test_a_design_being_written_is_named_before_the_folders_content(tmp_path):
    """Round 10, V7: a second design on a folder another one was writing was told to --resume,
    which then called the running design's checkpoint a user's file."""
    import subprocess
    import sys

    out = tmp_path / "d"
    run_design("m1-4mT", out, TINY)
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time; from elastica_magnetic.locks import FolderLock\n"
         "with FolderLock(sys.argv[1]):\n    print('held', flush=True); time.sleep(60)", str(out)],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        for flags in ({"resume": True}, {"force": True}, {}):
            with pytest.raises(OutputPathError, match="being written by pid"):
                run_design("m1-4mT", out, TINY, **flags)
    finally:
        holder.kill()
        holder.wait()


def test_a_minutes_budget_that_cuts_the_generations_says_so(tmp_path, capsys):
    """Round 10, S4: --generations 3 --minutes 0.05 ran one generation without a word."""
    out = tmp_path / "d"
    assert msr(["design", "m1-4mT", "--out", str(out), "--generations", "3", "--minutes", "0.001",
                *QUICK]) == 0
    err = capsys.readouterr().err
    assert "stopped by --minutes 0.001 after 1 of 3 generations" in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["search"]["stopped"] == {"by": "--minutes", "minutes": 0.001, "generations": 1,
                                            "generations_asked": 3}
    assert "after 1 of the 3 generations asked" in (out / "report.md").read_text()


def test_a_resume_with_other_options_names_the_option(tmp_path):
    """Round 10, V3: the mismatch named an internal key (final_duration) for --quick."""
    out = tmp_path / "d"
    run_design("m1-4mT", out, TINY)
    longer = DesignSettings(**{**TINY.__dict__, "final_duration": 10.0})
    with pytest.raises(DesignError, match=r"--quick: given in one and not the other"):
        run_design("m1-4mT", out, longer, resume=True)
    accurate = DesignSettings(**{**TINY.__dict__, "physics": "accurate"})
    with pytest.raises(DesignError, match=r"--search-physics: 'training' then, 'accurate' now"):
        run_design("m1-4mT", out, accurate, resume=True)
    with pytest.raises(DesignError, match=r"another spec \(case m1-4mT then, m2-4mT now; first difference"
                                          r".*resume it with its own spec \(case m1-4mT\), or choose another "
                                          r"--out for this one"):  # round 37, V1: --force refused it
        run_design("m2-4mT", out, TINY, resume=True)
    # round 34, V3: the derived [design] table (remanence) was named, not the key changed
    spec = load_case("m1-4mT").to_dict()
    spec["robot"]["magnetization"]["magnitude"] = 70000.0
    (tmp_path / "m1-4mT.toml").write_text(dumps(spec))
    with pytest.raises(DesignError, match=r"first difference: \[robot.magnetization\] magnitude\)"):
        run_design(str(tmp_path / "m1-4mT.toml"), out, TINY, resume=True)
    # round 37, V1: with another name and description too, the value is named, not the description
    spec["name"], spec["description"] = "m1-4mT-mine", "a stronger band"
    (tmp_path / "mine.toml").write_text(dumps(spec))
    with pytest.raises(DesignError, match=r"first difference: \[robot.magnetization\] magnitude\)"):
        run_design(str(tmp_path / "mine.toml"), out, TINY, resume=True)


def test_sizes_get_a_time_step_stable_at_every_corner(tmp_path):
    """Round 10, S6: a design with size ranges wrote a best.toml whose training step msr case
    check called likely unstable (a 15.7 mm robot at the 20 mm robot's dt)."""
    from elastica_magnetic_rl.design.run import load_design

    from elastica_magnetic.spec_check import unstable_time_step

    spec = load_case("m1-4mT").to_dict()
    spec["design"] = {"segments": 4, "lengths": "free", "width": [0.004, 0.012],
                      "length": [0.015, 0.03]}
    path = tmp_path / "width.toml"
    path.write_text(dumps(spec))
    design = load_design(path)
    assert design.base["physics"]["training"]["dt"] < 1e-4  # the spec's own 1e-4 s is lowered
    assert design.base["physics"]["accurate"]["dt"] == 8e-6  # stable already: kept
    low = design.start_vector(1.0)
    where = design.space._slices()
    low[where["size:length"]] = low[where["size:width"]] = 0.0  # the shortest, narrowest corner
    corner = design.case_of(low)
    for physics in ("training", "accurate"):
        assert unstable_time_step(corner.robot_spec(physics), physics) is None
    run_design(design, tmp_path / "out", TINY)
    best = load_case(tmp_path / "out" / "best.toml")
    assert unstable_time_step(best.robot_spec("training"), "training") is None


def test_a_users_file_inside_the_designs_subfolders_is_refused_not_removed(tmp_path):
    """Round 11, D1: the design's own names were checked at the top level only; --force deleted
    a user's gait/notes.txt and search/mine.txt."""
    out = tmp_path / "d"
    run_design("m1-4mT", out, TINY)
    (out / "gait" / "notes.txt").write_text("my measurements\n")
    (out / "search" / "mine.txt").write_text("mine\n")
    for flags in ({"force": True}, {"resume": True}):
        with pytest.raises(OutputPathError, match=r"files msr did not write \(gait/notes.txt, "
                                                  r"search/mine.txt\)"):
            run_design("m1-4mT", out, TINY, **flags)
    assert (out / "gait" / "notes.txt").read_text() == "my measurements\n"
    assert (out / "search" / "mine.txt").read_text() == "mine\n"
    (out / "search" / ".state.tmp4242.pkl").write_bytes(b"")  # msr's own, left by a kill
    (out / "gait" / "notes.txt").unlink()
    (out / "search" / "mine.txt").unlink()
    assert run_design("m1-4mT", out, TINY, force=True)["search"]["generations"] == 2


def test_finalists_are_run_again_when_the_search_measures_less(tmp_path):
    """A search of shorter runs than the judgement's: its best distinct candidates are run again
    for the judged duration and the best of those is judged (issue 52: 5 s ranked designs
    differently from 10 s); a search that measures what the judgement does reuses the start's
    sweep and has no finalists."""
    shorter = DesignSettings(**{**TINY.__dict__, "search_duration": 0.2, "finalists": 3})
    summary = run_design("m1-4mT", tmp_path / "d", shorter)
    finalists = summary["search"]["finalists"]
    assert len(finalists) == 3
    chosen = finalists[summary["search"]["chosen_finalist"]]
    assert chosen["objective_m"] == max(f["objective_m"] for f in finalists)
    # the chosen finalist's 0.3 s run is the judged design's distance under its own period
    best_sweep = [r for r in _rows(tmp_path / "d" / "final_sweep.csv") if r["design"] == "best"]
    at_its_period = [float(r["distance_m"]) for r in best_sweep
                     if abs(float(r["period_s"]) - chosen["period_s"]) < 1e-5]
    assert chosen["objective_m"] == pytest.approx(max(at_its_period), abs=1e-12)
    same = run_design("m1-4mT", tmp_path / "same", TINY)
    assert same["search"]["finalists"] == []
    start_sweep = [r for r in _rows(tmp_path / "same" / "final_sweep.csv") if r["design"] == "start"]
    record = json.loads((tmp_path / "same" / "design.json").read_text())["start"]["sweep"]
    for row in record:  # the judgement's start rows are the search's own start sweep
        for clockwise, key in ((1, "distance_cw_m"), (0, "distance_ccw_m")):
            judged = [float(r["distance_m"]) for r in start_sweep if int(r["clockwise"]) == clockwise
                      and abs(float(r["period_s"]) - row["period_s"]) < 1e-9]
            assert judged == [pytest.approx(row[key], rel=1e-8)]  # the CSV keeps 9 digits


def test_a_users_file_saved_in_gait_during_the_end_is_kept(tmp_path, monkeypatch):
    """The end replaces gait/ of a finished design that is resumed: a file the user saved there
    while the end ran is never removed (the resumed design, built beside, is not swapped in: it is
    left beside, named)."""
    import elastica_magnetic_rl.design.outputs as outputs

    out = tmp_path / "d"
    run_design("m1-4mT", out, TINY)
    real = outputs.write_outputs

    def and_a_note(*args, **kwargs):
        summary = real(*args, **kwargs)
        (out / "gait" / "notes.txt").write_text("mine\n")
        return summary

    monkeypatch.setattr(outputs, "write_outputs", and_a_note)
    kept = r"changed while the command ran \(new or changed: gait, gait/notes.txt\); it was not replaced"
    with pytest.raises(OutputPathError, match=kept):
        run_design("m1-4mT", out, TINY, resume=True)
    assert (out / "gait" / "notes.txt").read_text() == "mine\n"
    assert not (out / ".msr-end").exists()
    beside = [p for p in tmp_path.iterdir() if p.name.startswith("d-new-")]
    assert len(beside) == 1 and (beside[0] / "summary.json").is_file()


def test_a_resume_removes_what_a_killed_replacement_left_beside(tmp_path):
    """Round 11: after a SIGKILLed --force, a --resume of the earlier design finished but left the
    killed replacement's folder (several MB) beside it."""
    from elastica_magnetic.results import LeftoverWarning

    out = tmp_path / "d"
    run_design("m1-4mT", out, TINY)
    leftover = tmp_path / ".d.msr-new-vm-99999999-abcdef"
    leftover.mkdir()
    (leftover / "design.json").write_text("{}")
    with pytest.warns(LeftoverWarning, match="left by a run that was killed"):
        run_design("m1-4mT", out, TINY, resume=True)
    assert not leftover.exists()


def test_a_minutes_budget_alone_is_recorded_and_its_overrun_said(tmp_path, capsys):
    """Round 32, S2: ``msr design --minutes 0.01`` (0.6 s for the whole command) ran one generation and
    the judgement (40 s), said nothing and recorded ``stopped: null``. The record says the budget
    ended the search after its one generation, and the overrun is said."""
    out = tmp_path / "d"
    assert msr(["design", "m1-4mT", "--out", str(out), "--minutes", "0.001", *QUICK]) == 0
    err = capsys.readouterr().err
    assert "beyond --minutes 0.001 (0.06 s): the search runs at least one generation (1 run)" in err, err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["search"]["stopped"] == {"by": "--minutes", "minutes": 0.001, "generations": 1,
                                            "generations_asked": None}
    assert "Ended by --minutes 0.001 after 1 generation(s)." in (out / "report.md").read_text()


def test_an_interrupted_resume_of_a_finished_design_keeps_it_whole(tmp_path, monkeypatch):
    """Round 48 D1: ``--resume`` with more generations on a finished design, killed, left its end
    (summary.json, best.toml, report) of one generation beside a search of five, the folder's
    record crediting the killed command: a finished design is continued beside it now and swapped
    in whole with its new end."""
    out = tmp_path / "d"
    one = DesignSettings(**{**TINY.__dict__, "generations": 1})
    run_design("m1-4mT", out, one)
    before = _fingerprint(out)
    three = DesignSettings(**{**TINY.__dict__, "generations": 3})
    with monkeypatch.context() as m:
        calls = _stopped_in_the_second_generation(m)
        with pytest.raises(KeyboardInterrupt):
            run_design("m1-4mT", out, three, resume=True)
    assert calls["n"] == 2 and _fingerprint(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]  # nothing left beside it
    resumed = run_design("m1-4mT", out, three, resume=True)
    assert resumed["search"]["generations"] == 3
    assert {int(row["generation"]) for row in _rows(out / "history.csv")} == {1, 2, 3}
    assert json.loads((out / "summary.json").read_text())["search"]["generations"] == 3


def test_a_resume_asking_fewer_generations_than_searched_says_so(tmp_path):
    """Borderline of round 48: ``--resume --generations 1`` on a search two deep reported two
    without a word."""
    out = tmp_path / "d"
    run_design("m1-4mT", out, TINY)
    one = DesignSettings(**{**TINY.__dict__, "generations": 1})
    with pytest.warns(UserWarning, match="--generations 1: the search has 2 generations already"):
        summary = run_design("m1-4mT", out, one, resume=True)
    assert summary["search"]["generations"] == 2


def test_a_finished_designs_resume_with_other_settings_names_its_folder(tmp_path):
    """Round 50 V4: the refusal named the hidden copy it is continued in (``.d.msr-new-...``)."""
    out = tmp_path / "d"
    run_design("m1-4mT", out, TINY)
    with pytest.raises(DesignError) as refused:
        run_design("m1-4mT", out, DesignSettings(**{**TINY.__dict__, "seed": 7}), resume=True)
    assert f"{out.name}" in str(refused.value) and ".msr-new" not in str(refused.value), refused.value
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]


def test_an_interrupted_resume_of_a_finished_design_says_it_is_kept_as_it_was(tmp_path, monkeypatch, capsys):
    """Borderline of round 51: the interruption said "the design's progress (its last whole generation,
    if any) is in D4: continue with ... --resume", where the continued search is dropped."""
    out = tmp_path / "d"
    assert msr(["design", "m1-4mT", "--out", str(out), *QUICK, "--generations", "1"]) == 0
    capsys.readouterr()
    with monkeypatch.context() as m:
        _stopped_in_the_second_generation(m)
        assert msr(["design", "m1-4mT", "--out", str(out), *QUICK, "--generations", "3", "--resume"]) == 130
    err = capsys.readouterr().err
    assert f"the finished design in {out} is kept as it was (its continued search is dropped" in err, err
    assert "progress" not in err


def test_a_smoke_designs_micrometres_are_not_shown_as_zero():
    """Borderline of round 51: ``msr design --quick`` printed "start +0.0 mm, best +0.0 mm (2.25x)"."""
    from elastica_magnetic_rl.reports.text import millimetres

    assert millimetres(1.2e-6) == "+0.0012 mm" and millimetres(-3.4e-5) == "-0.034 mm"
    assert millimetres(0.0123) == "+12.3 mm" and millimetres(0.0) == "+0.0 mm"
    assert millimetres(None) == "diverged"

"""The goto task's yardstick and results (issue 51): the steering rotating field walks the paper's
band to a target beside it, a ring of targets is written whole with its top view, and the options
that send a robot somewhere are refused where they cannot act."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.envs.yardsticks import SteeringFieldPolicy

from elastica_magnetic.cli import main

FAST = ["--physics", "training", "--no-progress", "--no-gif", "--json"]


@pytest.mark.parametrize("left", [0.015, -0.015])
def test_the_steering_yardstick_walks_the_band_to_a_target_beside_it(tmp_path, capsys, left):
    out = tmp_path / "side"
    assert main(["field", "baseline", "--case", "m1-4mT-goto", "--target", f"0,{left}",
                 "--duration", "3", "--out", str(out), "--no-figures", *FAST]) == 0
    result = json.loads(capsys.readouterr().out)
    goto = result["goto"]
    assert goto["target_left_m"] == left and goto["target_z_m"] == pytest.approx(-left)  # left: -z
    assert goto["success"] and result["final_distance_to_target_m"] <= 0.002
    assert 0.5 < result["time_to_target_s"] < 3.0
    assert math.copysign(1.0, result["mid_dz_m"]) == -math.copysign(1.0, left)


def _obs(policy, field=(0.0, 0.0, 0.0), heading=0.0, target=(0.01, 0.0)):
    obs = np.zeros(policy.obs_dim, dtype=np.float32)
    layout = policy.layout
    obs[layout["field_amplitude"]] = 200.0 * math.hypot(field[0], field[1])
    obs[layout["field_angle"]] = math.atan2(field[1], field[0])
    obs[layout["field_z"]] = 200.0 * field[2]
    obs[layout["heading"]] = (math.cos(heading), math.sin(heading))
    obs[layout["target_offset"]] = 100.0 * np.asarray(target)
    return obs


def test_the_yardstick_walks_toward_a_target_abeam_and_turns_for_one_ahead():
    policy = SteeringFieldPolicy("m1-4mT-goto", period=1.0)
    assert policy.plane_bearing(0.0, 0.01) == pytest.approx(math.pi / 2)  # abeam: walk there
    # walking goes on while the target stays within 60 degrees of abeam
    assert policy.plane_bearing(0.01, 0.01) == pytest.approx(math.pi / 4)
    policy.reset()
    # 45 degrees ahead-left on a fresh start: turn clockwise in place, the plane 15 degrees from
    # the axis, its rotation reversed (the plane flipped) after each turn of the field (100 steps)
    first = policy.plane_bearing(0.01, 0.01)
    assert first == pytest.approx(math.pi / 12)
    policy._step = 100
    assert policy.plane_bearing(0.01, 0.01) == pytest.approx(math.pi / 12 - math.pi)
    policy.reset()
    assert policy.plane_bearing(0.01, -0.01) == pytest.approx(-math.pi / 12)  # ahead-right
    policy.reset()
    assert policy.plane_bearing(-0.01, 0.01) == pytest.approx(-math.pi / 12)  # behind-left
    # at the target it ramps the field down at the increment limit
    action = policy.act(_obs(policy, field=(1e-3, -2e-3, 0.5e-3), target=(0.0005, 0.0)))
    assert action == pytest.approx([-1.0, 1.0, -1.0])


def test_the_yardstick_keeps_each_axis_within_its_limit():
    data = load_case("m1-4mT-goto").to_dict()
    data["actuation"]["field_limit"] = [0.004, 0.004, 0.002]  # a weaker z pair
    policy = SteeringFieldPolicy(case_from_dict(data, "weak.toml", "weak"))
    assert policy.plane_amplitude(0.0) == pytest.approx(0.004)
    assert policy.plane_amplitude(math.pi / 2) == pytest.approx(0.002)
    assert policy.plane_amplitude(math.pi / 4) == pytest.approx(0.002 * math.sqrt(2))


def test_the_yardstick_refuses_a_case_without_a_target():
    with pytest.raises(ValueError, match="case 'm1-4mT' has the crawl task, not goto"):
        SteeringFieldPolicy("m1-4mT")


def test_a_ring_is_written_whole_with_its_top_view(tmp_path, capsys):
    out = tmp_path / "ring"
    args = ["field", "baseline", "--case", "m1-4mT-goto", "--ring", "2", "--duration", "0.3",
            "--out", str(out), *FAST]
    assert main(args) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["targets"] == 2 and result["successes"] == 0  # 0.3 s is too short to get there
    assert result["mean_time_to_target_s"] is None
    rows = json.loads((out / "ring.json").read_text())["targets_table"]
    assert [r["target_forward_m"] for r in rows] == pytest.approx([0.015, -0.015])
    assert (out / "ring.png").stat().st_size > 0 and (out / "ring.csv").read_text().count("\n") == 3
    before = (out / "ring.csv").read_bytes()
    assert main(args) == 2  # an existing result needs --force
    assert "--force" in capsys.readouterr().err and (out / "ring.csv").read_bytes() == before
    assert main([*args, "--force"]) == 0
    capsys.readouterr()
    assert main([*args, "--force", "--no-figures"]) == 0  # no picture asked, none left behind
    assert "ring.png" not in json.loads(capsys.readouterr().out)["files"]
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["ring.csv", "ring.json"]


@pytest.mark.parametrize(("args", "message"), [
    (["field", "baseline", "--case", "m1-4mT", "--target", "0,0.01"],
     "--target is for a goto case; case 'm1-4mT' has the crawl task"),
    (["field", "baseline", "--case", "m1-4mT", "--ring"],
     "--ring is for a goto case; case 'm1-4mT' has the crawl task"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--target", "15,0"],
     "15,0 is 15 m from the start: metres, not mm"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--target", "0.01"],
     "expected FORWARD,LEFT (a goto case) or X,Y,Z (a tip-reach case) in m"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--ring", "0"], "expected 1 to 72 targets"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--ring", "--target", "0,0.01"],
     "not allowed with argument"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--counterclockwise"],
     "--counterclockwise belongs to the rotating-field sweep of a crawl case"),
    (["policy", "generate", "m1-4mT", "--target", "0,0.01"],
     "--target is for a goto case; case 'm1-4mT' has the crawl task"),
    (["field", "baseline", "--case", "m1-4mT", "--period", "1", "--turn-in-place", "no"],
     "--turn-in-place is a goto case's steering yardstick's; case 'm1-4mT' has the crawl task"),
    (["field", "baseline", "--case", "catheter-magnet-reach", "--turn-in-place", "yes"],
     "--turn-in-place does not apply to case 'catheter-magnet-reach'"),
])
def test_goto_options_that_cannot_act_are_refused(tmp_path, capsys, args, message):
    out = tmp_path / "never"
    try:
        status = main([*args, "--out", str(out)])
    except SystemExit as exc:  # refused while parsing
        status = exc.code
    assert status == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_a_ring_run_in_worker_processes_is_the_same_ring():
    from elastica_magnetic_rl.shipping.goto import evaluate_ring

    policy = SteeringFieldPolicy("m1-4mT-goto")
    here, there = [], []
    alone = evaluate_ring(policy, 0.3, "training", n_targets=2, paths=here)
    side_by_side = evaluate_ring(policy, 0.3, "training", n_targets=2, paths=there, workers=2)
    assert side_by_side == alone
    assert all(np.array_equal(a, b) for a, b in zip(here, there, strict=True))


def test_a_goto_model_card_shows_the_ring_beside_the_yardstick():
    from elastica_magnetic_rl.shipping.model_card import model_card
    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

    case = load_case("m1-4mT-goto")
    info = json.loads((POLICIES_DIR / "m1-4mT" / "policy.json").read_text())
    info.update(name="m1-4mT-goto", notes=None, seeds=None)
    info["architecture"] = {**info["architecture"], "obs_dim": case.obs_dim, "act_dim": 3}

    def row(forward, left, distance, time):
        return {"target_forward_m": forward, "target_left_m": left, "success": distance <= 0.002,
                "final_distance_to_target_m": distance, "time_to_target_s": time}

    def ring(rows):
        reached = [r for r in rows if r["success"]]
        return {"physics": "accurate", "duration_s": 30.0, "targets": len(rows),
                "successes": len(reached), "targets_table": rows,
                "mean_time_to_target_s": (sum(r["time_to_target_s"] for r in reached) / len(reached)
                                          if reached else None)}

    info["evaluation"] = {"duration_s": 30.0, "mid_dx_m": 0.014, "node_dx_m": 0.014,
                          "diverged": None,
                          "ring": ring([row(0.015, 0.0, 0.0011, 4.5), row(-0.015, 0.0, 0.009, None)]),
                          "yardstick_ring": ring([row(0.015, 0.0, 0.0009, 14.9),
                                                  row(-0.015, 0.0, 0.0009, 9.1)])}
    card = model_card(info, None, case)
    assert "go to a point on the floor 15 mm away in any direction and stay within 2 mm" in card
    assert "--target FORWARD,LEFT" in card and "3 actions in [-1, 1] (dB_x, dB_y, dB_z)" in card
    assert ("Ring of 2 targets (accurate physics, 30 s each from a zero field): **1 of 2 targets, "
            "mean time to target 4.5 s**; the steering yardstick: 2 of 2 targets, mean time to "
            "target 12.0 s.") in card
    assert "| +15.0, +0.0 | 1.10 | 4.50 | 0.90, 14.90 |" in card
    assert "| -15.0, +0.0 | 9.00 (missed) | never | 0.90, 9.10 |" in card


#: A clone of the yardstick cut to a token (the case trains a residual learner; the clone's 16000 steps
#: and 6000 of DAgger are not what these tests test: they took some 30 s of each).
QUICK_CLONE = ("--set", "residual=0", "--set", "correction_penalty=0", "--set", "critic_warmup=0",
               "--set", "yardstick_warmup=10", "--set", "yardstick_dagger=0")


def _quick_goto_spec(folder):
    """m1-4mT-goto with 0.1 s episodes, its evaluations' too (``--episode-duration`` shortens the
    training episodes only: a goto evaluation is the task's whole 30 s episode)."""
    spec, text = folder / "goto-quick.toml", load_case("m1-4mT-goto").toml()
    assert "episode_duration = 30.0" in text
    spec.write_text(text.replace("episode_duration = 30.0", "episode_duration = 0.1"))
    return spec


def test_a_goto_run_ships_with_its_ring_and_the_yardsticks(tmp_path, monkeypatch):
    """`msr policy ship` of a goto run measures the ring (patched here to 0.2 s of the training
    physics, the shipped judge being 30 s of the accurate one) for the policy and the steering
    yardstick, and writes both into policy.json and the card, with the top view of both rings
    (ring.png); the ring names the policy's file from its case folder on, not this machine's path."""
    from elastica_magnetic_rl.shipping import ship as ship_module
    from elastica_magnetic_rl.shipping.goto import evaluate_ring

    runs = tmp_path / "runs"
    assert main(["train", "--case", str(_quick_goto_spec(tmp_path)), "--seeds", "1", "--steps", "20",
                 "--out", str(runs), "--set", "learning_starts=10", "--set", "batch_size=8", "--set",
                 "hidden_sizes=8", *QUICK_CLONE, "--no-progress"]) == 0
    asked = []

    def quick_ring(policy, duration, physics, **kwargs):
        asked.append((duration, physics))
        return evaluate_ring(policy, 0.2, "training", n_targets=2, paths=kwargs.get("paths"))

    monkeypatch.setattr(ship_module, "evaluate_ring", quick_ring)
    result = ship_module.ship(runs / "goto-quick" / "seed0", "goto-test", dest=tmp_path / "shipped",
                              duration=0.2, progress=False)
    assert asked == [(None, "accurate"), (None, "accurate")]  # the task's episode, accurate physics
    info = json.loads((tmp_path / "shipped" / "goto-test" / "policy.json").read_text())
    ev = info["evaluation"]
    assert ev["goto"]["target_forward_m"] == 0.015 and ev["ring"]["targets"] == 2
    assert ev["yardstick_ring"]["policy"].startswith("steering rotating field")
    assert ev["ring"]["policy"] == "goto-quick/seed0/checkpoint.pt", ev["ring"]["policy"]
    card = (tmp_path / "shipped" / "goto-test" / "MODEL_CARD.md").read_text()
    assert "Ring of 2 targets" in card and "the steering yardstick:" in card
    figure = tmp_path / "shipped" / "goto-test" / "ring.png"
    assert figure.read_bytes().startswith(b"\x89PNG") and "](ring.png)" in card
    assert result["name"] == "goto-test"


def test_the_actor_choice_of_a_goto_run_prefers_the_one_ending_closer():
    from elastica_magnetic_rl.shipping.policy_runs import prefer_best

    case = load_case("m1-4mT-goto")
    final = {"diverged": None, "mid_dx_m": 0.010, "final_distance_to_target_m": 0.006}
    best = {"diverged": None, "mid_dx_m": 0.001, "final_distance_to_target_m": 0.001}
    assert prefer_best(case, final, best) and not prefer_best(case, best, final)


def test_the_commands_that_judge_a_distance_ahead_refuse_a_goto_case(tmp_path, capsys):
    """`msr loop` and `msr real robustness` measure how far ahead a robot goes: on a goto case
    they would report that as if it meant something; both refuse it by name before any work."""
    assert main(["loop", "m1-4mT-goto", "--out", str(tmp_path / "loop")]) == 2
    assert "case 'm1-4mT-goto' has the goto task: the loop's steps" in capsys.readouterr().err
    fields = tmp_path / "fields.csv"
    fields.write_text("index,mag_x,mag_y,mag_z\n0,0,0,0\n1,0.3,0,0\n2,0.6,0,0\n")
    assert main(["real", "robustness", str(fields), "--case", "m1-4mT-goto", "--out",
                 str(tmp_path / "robust")]) == 2
    assert "case 'm1-4mT-goto' has the goto task: a robustness study" in capsys.readouterr().err
    assert not (tmp_path / "loop").exists() and not (tmp_path / "robust").exists()


def test_round17_generate_states_and_chooses_for_the_target_asked(tmp_path, capsys):
    """Round 17 S: with --target, generate's `target` line stated the task's default target and
    episode (15 mm ahead, 30 s), `--checkpoint auto` chose the actor by its distance to that
    default target (and quoted distances ahead), and a target inside the tolerance of the start
    ("success" by staying put) passed without a word."""
    runs = tmp_path / "runs"
    assert main(["train", "--case", str(_quick_goto_spec(tmp_path)), "--seeds", "1", "--steps", "40",
                 "--out", str(runs), "--set", "learning_starts=10", "--set", "batch_size=8", "--set",
                 "hidden_sizes=8", *QUICK_CLONE, "--set", "eval_every=20", "--no-progress"]) == 0
    run = runs / "goto-quick" / "seed0"
    assert (run / "best.pt").is_file()
    capsys.readouterr()
    assert main(["policy", "generate", str(run), "--target", "0,0.004", "--duration", "0.03",
                 "--physics", "training", "--no-figures", "--no-progress", "--json",
                 "--out", str(tmp_path / "g")]) == 0
    out = capsys.readouterr().out
    result = json.loads(out[out.index("{"):])
    assert result["target"] == "within 2.0 mm of the target (+0.0, +4.0) mm (ahead, left) in 0.03 s"
    summary = result["actor_choice"]["summary"]
    assert "the nearer of the two to the target (+0, +4) mm (ahead, left) at the end" in summary
    assert "mm from it" in summary
    evaluated = result["actor_choice"]["final"]
    assert evaluated["target_m"] == [0.0, 0.004]
    assert main(["policy", "generate", str(run), "--target", "0.001,0", "--duration", "0.03",
                 "--checkpoint", "final", "--physics", "training", "--no-figures", "--no-progress",
                 "--out", str(tmp_path / "h")]) == 0
    assert "lies within the 2 mm tolerance of the start" in capsys.readouterr().err
    # round 17 S: export-seeds scored a goto run's seeds by the distance ahead
    assert main(["policy", "export-seeds", str(runs / "goto-quick"), "--out", str(tmp_path / "seeds"),
                 "--no-progress"]) == 2
    assert "has the goto task, and msr policy export-seeds scores each seed" in capsys.readouterr().err
    assert not (tmp_path / "seeds").exists()


def test_the_baseline_plays_the_yardstick_the_case_or_the_option_says(tmp_path, capsys):
    """``--turn-in-place yes|no`` overrides the case's ``[yardstick] turn_in_place`` (m1-10mT-goto:
    false), and ``--period`` its ``steering_period`` (0.15 s), so every law can be measured on one
    case; the result names the one played."""
    sources = {}
    for option in (None, "yes", "no", "period"):
        out = tmp_path / str(option)
        extra = {None: [], "period": ["--period", "0.05"]}.get(option, ["--turn-in-place", option])
        assert main(["field", "baseline", "--case", "m1-10mT-goto", "--duration", "0.05", "--physics",
                     "training", "--no-figures", "--no-gif", "--no-progress", "--json", *extra,
                     "--out", str(out)]) == 0
        sources[option] = json.loads(capsys.readouterr().out)["policy"]
    assert "never turning in place" in sources[None] and "never turning in place" in sources["no"]
    assert "never turning in place" not in sources["yes"]
    assert all("period 0.15 s" in sources[option] for option in (None, "yes", "no"))
    assert "period 0.05 s" in sources["period"]

"""A residual policy (``--set residual=R``: the actor corrects the case's yardstick) end to end, on
robots of every goto form the spec format allows and on a catheter: trained, its recorded evaluation
replayed exactly by the loaded policy acting on a plain environment (the training's wrapper and the
policy's own composition agree), refined, sent to a point, shipped (the weight in ``policy.json``, the
shipped policy acting as the run's), and refused by ``msr policy export`` (the actor alone is not
the policy)."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd
import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.envs.env import make_env
from elastica_magnetic_rl.runner.evaluation import EVAL_SEED, evaluate
from elastica_magnetic_rl.shipping import policy_runs
from elastica_magnetic_rl.shipping.policy_files import resolve_policy
from elastica_magnetic_rl.shipping.policy_runs import run_policy
from hypothesis import HealthCheck, Phase, given, settings
from smoke import SMOKE, run_msr
from spec_matrix import user_specs

from elastica_magnetic.cli import main as msr
from elastica_magnetic.specfile import dumps

RESIDUAL = ["--set", "residual=0.5", "--set", "yardstick_warmup=0", "--set", "yardstick_dagger=0"]
#: s: a drawn robot's evaluations.
SHORT_EVAL_S = 0.3
#: A drawn robot's run: 28 updates after a 20-step warm-up and two evaluations of 0.3 s (a drawn robot
#: may need thousands of sub-steps an action: the smoke settings' 0.8 s episodes were most of the time).
SHORT = ["--set", "learning_starts=20", "--set", "batch_size=16", "--set", "hidden_sizes=16",
         "--episode-duration", "0.3", "--set", "checkpoint_every=24", "--set", "eval_every=24",
         "--set", f"eval_duration={SHORT_EVAL_S}", "--no-progress"]
DRAWN = settings(max_examples=2, derandomize=True, database=None, deadline=None, phases=[Phase.generate],
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def _replayed(seed: Path, case) -> None:
    """The run's last recorded evaluation equals the loaded policy's return on a plain environment."""
    policy = resolve_policy(seed)
    assert policy.residual == 0.5
    recorded = pd.read_csv(seed / "evaluations.csv")["mean_return"].iloc[-1]
    replay = evaluate(policy, lambda: make_env(case, "training", "zero", SHORT_EVAL_S), 1, EVAL_SEED)
    assert replay.mean_return == pytest.approx(recorded, rel=1e-9, abs=1e-12)


@DRAWN
@given(spec=user_specs(task="goto"))
def test_a_residual_goto_policy_on_a_drawn_robot(spec, capsys):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = folder / "drawn.toml"
        path.write_text(dumps(spec))
        runs = folder / "runs"
        assert msr(["train", "--case", str(path), "--seeds", "1", "--workers", "1", "--steps", "48",
                    "--out", str(runs), *SHORT, *RESIDUAL]) == 0
        seed = runs / "drawn" / "seed0"
        _replayed(seed, load_case(path))
        assert msr(["refine", str(seed), "--checkpoint", "final", "--steps", "3", "--episode-duration",
                    "0.02", "--physics", "training", "--no-progress"]) == 0
        assert resolve_policy(seed / "refined").residual == 0.5  # refined as corrections, played as such
        point = run_msr(capsys, "policy", "generate", str(seed), "--checkpoint", "final", "--target",
                        "0,0.005", "--duration", "0.2", "--physics", "training", "--out",
                        str(folder / "point"), "--no-figures", "--no-progress")
        assert np.isfinite(point["final_distance_to_target_m"])
        capsys.readouterr()
        # refused before the run's two actors are evaluated (10 s each in the accurate physics)
        with mock.patch.object(policy_runs, "evaluate_run", side_effect=AssertionError("evaluated")):
            assert msr(["policy", "export", str(seed), "--out", str(folder / "exp"), "--no-progress"]) != 0
        assert "a residual policy (residual 0.5)" in capsys.readouterr().err
        assert not (folder / "exp").exists()


def test_a_shipped_residual_policy_acts_as_its_run(tmp_path, monkeypatch):
    from elastica_magnetic_rl.shipping import ship as ship_module
    from elastica_magnetic_rl.shipping.goto import evaluate_ring

    spec, text = tmp_path / "goto-quick.toml", load_case("m1-4mT-goto").toml()
    spec.write_text(text.replace("episode_duration = 30.0", "episode_duration = 0.1"))
    runs = tmp_path / "runs"
    assert msr(["train", "--case", str(spec), "--seeds", "1", "--steps", "40", "--out", str(runs), "--set",
                "learning_starts=10", "--set", "batch_size=8", "--set", "hidden_sizes=8", *RESIDUAL,
                "--no-progress"]) == 0
    monkeypatch.setattr(ship_module, "evaluate_ring", lambda policy, duration, physics, **kw: evaluate_ring(
        policy, 0.2, "training", n_targets=2, paths=kw.get("paths")))
    ship_module.ship(runs / "goto-quick" / "seed0", "goto-residual", dest=tmp_path / "shipped", duration=0.2,
                     progress=False)
    info = json.loads((tmp_path / "shipped" / "goto-residual" / "policy.json").read_text())
    assert info["architecture"]["residual"] == 0.5
    card = (tmp_path / "shipped" / "goto-residual" / "MODEL_CARD.md").read_text()
    assert "A residual policy: the action played is the case's yardstick's command plus 0.5 x" in card
    assert "msr policy export goto-residual --out" not in card
    shipped = resolve_policy(tmp_path / "shipped" / "goto-residual")
    run = resolve_policy(runs / "goto-quick" / "seed0")
    assert shipped.residual == run.residual == 0.5
    one, two = (run_policy(p, 0.3, "training", progress=False, target=(0.0, 0.01)) for p in (shipped, run))
    np.testing.assert_array_equal(one.actions, two.actions)
    assert np.abs(one.actions).max() > 0.0
    # a policy that has acted goes to worker processes (its yardsticks stay here): the same ring
    here, there = (evaluate_ring(shipped, 0.2, "training", n_targets=2, workers=w) for w in (1, 2))
    assert [r["final_distance_to_target_m"] for r in here] == [r["final_distance_to_target_m"] for r in there]


def test_a_residual_catheter_policy_is_sent_to_a_point(tmp_path, capsys):
    runs = tmp_path / "runs"
    assert msr(["train", "--case", "catheter-magnet-reach", "--seeds", "1", "--workers", "1", "--steps",
                "160", "--out", str(runs), *SMOKE, *RESIDUAL]) == 0
    seed = runs / "catheter-magnet-reach" / "seed0"
    assert resolve_policy(seed).residual == 0.5
    result = run_msr(capsys, "policy", "generate", str(seed), "--target", "0.03,0.01,0", "--duration", "0.3",
                     "--physics", "training", "--out", str(tmp_path / "gen"), "--no-progress")
    assert np.isfinite(result["tip_error_m"])


def test_a_residual_tip_reach_policy_s_card_says_how_it_acts():
    """The catheter's card said nothing of the yardstick its actor corrects (the goto card did), so
    a reader took the actor for the policy and ``msr policy export`` for the way to run it."""
    from elastica_magnetic_rl.shipping.model_card import NOTES_SECTION
    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR
    from elastica_magnetic_rl.shipping.tip_reach_card import tip_reach_card

    info = json.loads((POLICIES_DIR / "catheter-coils-reach" / "policy.json").read_text())
    info["architecture"]["residual"] = 0.5
    case = load_case("catheter-coils-reach")
    line = "A residual policy: the action played is the case's yardstick's command plus 0.5 x"
    assert line in tip_reach_card(info, case, NOTES_SECTION)
    info["architecture"]["residual"] = 0.0
    assert "A residual policy" not in tip_reach_card(info, case, NOTES_SECTION)


@pytest.mark.parametrize(("argv", "message"), [
    (["--case", "hu2018-crawl"], "--set residual=0.5: the actor learns a correction of the case's "
                                 "hand-designed controller, and case(s) hu2018-crawl have none"),
    # the case's [training.td3] trains a residual learner, and a clone is asked for
    (["--case", "m1-10mT-goto", "--set", "yardstick_warmup=100"],
     "yardstick_warmup must be 0, got 100 (to learn the correction where a case's [training.td3] sets a "
     "warm-up: --set yardstick_warmup=0 --set yardstick_dagger=0; to clone the yardstick where it sets "
     "residual: --set residual=0, and --set correction_penalty=0 where it sets that too)"),
])
def test_a_residual_training_that_cannot_run_is_refused_before_any_work(tmp_path, capsys, argv, message):
    extra = ["--set", "residual=0.5"] if "--case" in argv and "hu2018-crawl" in argv else []
    assert msr(["train", *argv, *extra, "--seeds", "1", "--steps", "50", "--set", "learning_starts=10",
                "--out", str(tmp_path / "t"), "--no-progress"]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "t").exists()


def test_a_critic_warmup_longer_than_the_run_is_warned(tmp_path, capsys):
    assert msr(["train", "--case", "m1-4mT-goto", "--seeds", "1", "--steps", "30", "--episode-duration",
                "0.1", "--out", str(tmp_path / "t"), "--set", "learning_starts=10", "--set", "batch_size=8",
                "--set", "hidden_sizes=8", "--set", "eval_duration=0.1", *RESIDUAL, "--set",
                "critic_warmup=100", "--no-progress"]) == 0
    err = capsys.readouterr().err
    # the case's one update per step after learning_starts 10: 20 updates
    assert ("--set critic_warmup=100 holds the actor for the run's first 100 updates, and --steps 30 makes "
            "20: the actor never learns (a residual learner plays its yardstick unchanged)") in err, err

"""Tests of the run diagnostics (rl/reports/diagnostics.py, ``msr policy diagnose``): discounted
returns against hand computations, episode ends from the stored transitions, and the two verdicts on
runs whose critic or actor were made to fail."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
import torch
from elastica_magnetic_rl.reports.diagnostics import (
    discounted_returns,
    episode_ends,
    health_figure,
    run_health,
)
from elastica_magnetic_rl.runfiles.checkpoint import save_checkpoint
from elastica_magnetic_rl.runner.loop import train
from elastica_magnetic_rl.td3.config import TD3Config

from elastica_magnetic.cli import main as msr


def test_discounted_returns_by_hand():
    rewards = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    terminated = np.array([False, True, False, False, False, False])
    ends = np.array([False, True, False, False, True, True])  # episodes [0,1], [2,4], [5]
    g, complete = discounted_returns(rewards, terminated, ends, gamma=0.5)
    np.testing.assert_allclose(g, [1 + 0.5 * 2, 2, 3 + 0.5 * 4 + 0.25 * 5, 4 + 0.5 * 5, 5, 6])
    # gamma 0.5: 7 steps carry 99 % of the weight; a terminated episode's returns are exact
    assert complete.tolist() == [True, True, False, False, False, False]
    g, complete = discounted_returns(np.ones(20), np.zeros(20, bool), np.eye(20, dtype=bool)[19],
                                     gamma=0.5)
    assert complete.tolist() == [True] * 14 + [False] * 6  # 7 or more steps to the end
    assert g[0] == pytest.approx(2 * (1 - 0.5**20))


def test_episode_ends_from_the_stored_transitions():
    obs = np.array([[0.0], [1.0], [2.0], [10.0], [11.0]])
    next_obs = np.array([[1.0], [2.0], [3.0], [11.0], [12.0]])  # an episode ends after row 2
    assert episode_ends(obs, next_obs).tolist() == [False, False, True, False, True]


class Drift(gym.Env):
    """1-D: reward = position, the action moves it; 100-step episodes (truncated)."""

    observation_space = gym.spaces.Box(-np.inf, np.inf, (2,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.x, self.t = 0.0, 0
        return np.array([self.x, 0.0], np.float32), {}

    def step(self, action):
        self.x = float(np.clip(self.x + 0.1 * float(action[0]), -1, 1))
        self.t += 1
        return (np.array([self.x, self.t / 100], np.float32), self.x, False, self.t >= 100, {})


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("diag") / "run"
    cfg = TD3Config(hidden_sizes=(16, 16), batch_size=16, learning_starts=50, gamma=0.9,
                    checkpoint_every=400, seed=0)
    train(Drift, cfg, 400, out, progress=False)
    return out


def _tampered(run, tmp_path, layer_bias: str, shift: float):
    """A copy of ``run`` whose network's last-layer bias ``layer_bias`` is shifted."""
    import shutil

    copy = tmp_path / "tampered"
    shutil.copytree(run, copy)
    ckpt = torch.load(copy / "checkpoint.pt", weights_only=False)
    net, key = layer_bias.split("/")
    for name in [key] if net == "actor" else [f"q1_net.{key}", f"q2_net.{key}"]:
        ckpt["agent"][net][name] = ckpt["agent"][net][name] + shift
    save_checkpoint(copy / "checkpoint.pt", ckpt)
    return copy


def test_healthy_run_and_the_two_failures(small_run, tmp_path):
    health = run_health(small_run, recent=300)
    assert health["global_step"] == 400 and health["transitions"] == 300
    # 100-step truncated episodes, gamma 0.9 (44 steps to 1 %): steps 0-56 of each are complete
    assert health["complete_returns"] == 3 * 57
    assert not health["actor_saturated"]
    # a critic shifted by +1000 overestimates; the same run unshifted does not by that much
    over = run_health(_tampered(small_run, tmp_path / "a", "critic/4.bias", 1000.0), recent=300)
    assert over["critic_overestimates"] and over["overestimation"] > 900
    assert over["q_data_mean"] == pytest.approx(health["q_data_mean"] + 1000, rel=1e-3)
    # an actor whose outputs before tanh are pushed to +100 is saturated everywhere
    sat = run_health(_tampered(small_run, tmp_path / "b", "actor/net.4.bias", 100.0), recent=300)
    assert sat["actor_saturated"] and sat["saturated_fraction"] == [1.0]
    assert health_figure(sat, tmp_path / "fig" / "h.png").stat().st_size > 10_000


def test_msr_diagnose(small_run, tmp_path, capsys):
    assert msr(["policy", "diagnose", str(small_run), "--recent", "300", "--figure", str(tmp_path / "f"),
                "--json"]) == 0
    row = json.loads(capsys.readouterr().out)["runs"][0]
    assert row["global_step"] == 400 and "_samples" not in row
    assert (tmp_path / "f" / f"health_{small_run.parent.name}_run.png").is_file()
    assert msr(["policy", "diagnose", str(tmp_path / "nothing")]) == 2
    assert "nothing: no such run directory" in capsys.readouterr().err
    assert msr(["policy", "diagnose", str(small_run), "--recent", "1"]) == 2
    assert "--recent must be >= 2" in capsys.readouterr().err


def test_the_interleaving_of_a_vector_runs_buffer_is_found():
    from elastica_magnetic_rl.reports.diagnostics import interleave_stride

    rng = np.random.default_rng(0)
    for n in (1, 3):  # n environments, 50 steps each, stored step by step
        trajectories = rng.normal(size=(n, 51, 4))
        obs = trajectories[:, :-1].transpose(1, 0, 2).reshape(-1, 4)
        next_obs = trajectories[:, 1:].transpose(1, 0, 2).reshape(-1, 4)
        assert interleave_stride(obs, next_obs) == n
        ends = episode_ends(obs[n - 1::n], next_obs[n - 1::n])
        assert ends.tolist() == [False] * 49 + [True]


def _with_gamma(run, tmp_path, gamma: float, episode_duration_s: float):
    """A copy of ``run`` whose config says ``gamma`` and whose record says its episode length."""
    import shutil

    copy = tmp_path / "regamma"
    shutil.copytree(run, copy)
    ckpt = torch.load(copy / "checkpoint.pt", weights_only=False)
    ckpt["config"]["gamma"] = gamma
    ckpt["metadata"] = {**(ckpt.get("metadata") or {}), "episode_duration_s": episode_duration_s}
    save_checkpoint(copy / "checkpoint.pt", ckpt)
    return copy


def test_no_complete_return_names_the_horizon_the_episodes_and_a_fix_that_acts(
        small_run, tmp_path, capsys):
    """Tries p15/p15b (issue 48): "use a larger --recent" was the advice even when no --recent
    could help (episodes shorter than the discount horizon). Now: the horizon (steps and s), the
    episode length and the transition count, and the change that acts."""
    # gamma 0.9: 44 steps; the last complete return is 44 rows before the end (row 356 of 400)
    with pytest.raises(ValueError) as info:
        run_health(small_run, recent=10)
    assert str(info.value) == (
        f"{small_run}: none of the last 10 of its 400 transitions has a complete discounted "
        "return (the discount horizon is 44 steps, 0.44 s, gamma 0.9: gamma^H < 0.01); give "
        "--recent 44 or more")
    assert run_health(small_run, recent=44)["complete_returns"] == 1
    # gamma 0.999: 4603 steps, the 100-step episodes can never give a complete return
    short = _with_gamma(small_run, tmp_path, 0.999, 1.0)
    capsys.readouterr()
    assert msr(["policy", "diagnose", str(short), "--recent", "1000000"]) == 2
    err = capsys.readouterr().err
    assert (f"msr policy diagnose: error: {short}: none of its 400 transitions has a complete discounted "
            "return: its episodes (longest stored: 100 steps, 1 s; the run's episode length 1 s) "
            "are shorter than the discount horizon of 4603 steps, 46.03 s (gamma 0.999: gamma^H "
            "< 0.01); a larger --recent cannot help: train with episodes of at least 4603 steps, "
            "46.03 s (msr train --episode-duration, or the spec's [task] episode_duration)") in err
    assert "use a larger --recent" not in err


def test_diagnose_figures_interrupted_leave_the_earlier_ones(fault_server, small_run, tmp_path,
                                                             capsys):
    """Issue 48's fault-injection suite: the figures go in together or not at all, and an earlier
    figure is replaced only with --force."""
    import os

    from faults import Fault

    figures = tmp_path / "health"
    figures.mkdir()
    argv = ["policy", "diagnose", str(small_run), "--recent", "300", "--figure", str(figures)]
    assert msr(argv) == 0
    capsys.readouterr()
    before = {p.name: p.read_bytes() for p in figures.iterdir()}
    assert msr(argv) == 2 and "pass --force" in capsys.readouterr().err
    done = fault_server.run([*argv, "--force"], Fault("open", r"\.msr-files-", "SIGINT", nth=1))
    assert done.returncode == 130, done.stderr
    assert {p.name: p.read_bytes() for p in figures.iterdir()} == before
    assert sorted(os.listdir(tmp_path)) == ["health"]


def test_a_run_younger_than_the_horizon_is_told_to_train_longer_not_to_lengthen_episodes(small_run, tmp_path):
    """Round 20 S: a run 200 steps into 20 s episodes was told its episodes are shorter than the
    459-step horizon and to train with longer ones: it was the run that was young."""
    young = _with_gamma(small_run, tmp_path, 0.999, 60.0)  # 6000-step episodes, 4603-step horizon
    with pytest.raises(ValueError) as info:
        run_health(young, recent=1000000)
    text = str(info.value)
    assert "the run has only 400 steps, fewer than the discount horizon of 4603 steps" in text, text
    assert "its episodes last 60 s, 6000 steps); train it longer" in text
    assert "train with episodes of at least" not in text

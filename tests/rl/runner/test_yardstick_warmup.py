"""A training that starts from the case's yardstick (``yardstick_warmup``, rl/runner/group.py): the
warm-up is the controller's actions plus the exploration noise, the actor clones them before TD3's
first update, the seed is evaluated at its next episode boundary, and a killed run resumes exactly."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.runner.loop import train
from elastica_magnetic_rl.td3.config import TD3Config
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from state_compare import assert_state_equal
from toy_env import Killed, ToyEnv, toy_config

torch.set_num_threads(1)
WARM_UP = 120


class Toward:
    """A controller of the toy task: toward the target at up to full speed, the second action at
    its best value (normalised 0: the middle of [0, 2]); it counts its steps (a state to keep)."""

    obs_dim, act_dim = 3, 2

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.steps = 0

    def state(self) -> dict:
        return {"steps": self.steps}

    def set_state(self, state: dict) -> None:
        self.steps = int(state["steps"])

    def act(self, obs: np.ndarray) -> np.ndarray:
        self.steps += 1
        return np.array([np.clip(5.0 * (obs[1] - obs[0]), -1.0, 1.0), 0.0], dtype=np.float32)


class Alternating(Toward):
    """Its second action alternates every 7 steps: what it remembers decides what it does."""

    def act(self, obs: np.ndarray) -> np.ndarray:
        action = super().act(obs)
        action[1] = 0.2 if (self.steps // 7) % 2 else -0.2
        return action


def _fixed() -> ToyEnv:
    return ToyEnv(p_terminate=0.0)  # 20-step episodes


def _config(**kw) -> TD3Config:
    base = dict(learning_starts=WARM_UP, yardstick_warmup=1500, exploration_noise=0.1, batch_size=32,
                hidden_sizes=(32, 32), checkpoint_every=40, eval_every=1000, seed=3)
    return toy_config(**{**base, **kw})


def _warm_up_rows(run_dir):
    buffer = load_checkpoint(run_dir)["buffer"]
    obs = np.asarray(buffer["obs"])[:WARM_UP]
    return obs, np.asarray(buffer["actions"])[:WARM_UP]


def test_the_warm_up_is_the_yardstick_plus_noise_and_the_actor_starts_as_its_clone(tmp_path):
    steps = WARM_UP + 20
    agent = train(_fixed, _config(), steps, tmp_path / "warm", progress=False, yardstick_fn=Toward,
                  eval_env_fn=_fixed)
    obs, actions = _warm_up_rows(tmp_path / "warm")
    toward = Toward()
    shown = []
    for o in obs:
        if o[2] == 0.0:  # an episode's first observation
            toward.reset()
        shown.append(toward.act(o))
    shown = np.array(shown)
    residual = actions - shown
    free = np.abs(shown) < 0.7  # away from the clip at +-1
    assert abs(float(residual[free].mean())) < 0.03
    assert float(residual[free].std()) == pytest.approx(0.1, rel=0.25)
    with torch.no_grad():
        acted = torch.tanh(agent.actor.net(torch.as_tensor(obs))).numpy()
    assert float(np.abs(acted - shown).mean()) < 0.1  # the clone, 20 TD3 updates later

    # the seed was evaluated at once after the cloning (not at 1000 steps), and at the end
    evaluations = (tmp_path / "warm" / "evaluations.csv").read_text().splitlines()
    assert [row.split(",")[0] for row in evaluations[1:]] == [str(WARM_UP + 1), str(WARM_UP + 20)]
    assert (tmp_path / "warm" / "best.pt").exists()

    # without the setting: uniform random actions, and an actor far from the controller
    plain = train(_fixed, _config(yardstick_warmup=0), steps, tmp_path / "plain", progress=False)
    obs, actions = _warm_up_rows(tmp_path / "plain")
    assert float(np.abs(actions - shown).mean()) > 0.3
    with torch.no_grad():
        acted = torch.tanh(plain.actor.net(torch.as_tensor(obs))).numpy()
    assert float(np.abs(acted - shown).mean()) > 0.2


@pytest.mark.parametrize("kill_at", [60, WARM_UP + 10, WARM_UP + 40])  # inside the warm-up, its
# checkpoint at its end (round 17: the clone made twice), after the cloning
def test_a_run_killed_and_resumed_ends_as_one_uninterrupted(tmp_path, kill_at):
    steps, config = WARM_UP + 80, _config(yardstick_warmup=200)  # a rough clone is enough here
    full = train(_fixed, config, steps, tmp_path / "full", progress=False, yardstick_fn=Toward)

    def kill(row):
        if row["global_step"] >= kill_at:
            raise Killed

    with pytest.raises(Killed):
        train(_fixed, config, steps, tmp_path / "cut", progress=False, yardstick_fn=Toward, log_fn=kill)
    assert load_checkpoint(tmp_path / "cut")["global_step"] < kill_at
    resumed = train(_fixed, config, steps, tmp_path / "cut", resume=True, progress=False,
                    yardstick_fn=Toward)
    assert_state_equal(full.state_dict(), resumed.state_dict())
    a, b = load_checkpoint(tmp_path / "full"), load_checkpoint(tmp_path / "cut")
    for key in ("agent", "buffer", "global_step", "episode"):
        assert_state_equal(a[key], b[key], key)


class SavingVectorEnv(SyncVectorEnv):
    """The toy environments as a vector environment that saves its state (so that checkpoints
    fall inside episodes, with the controllers' state beside the environments')."""

    def get_state(self) -> list:
        return [{"pos": float(e.pos), "target": float(e.target), "t": int(e.t),
                 "rng": json.dumps(e.np_random.bit_generator.state)} for e in self.envs]

    def set_state(self, state: list) -> None:
        for e, s in zip(self.envs, state, strict=True):
            e.pos, e.target, e.t = float(s["pos"]), float(s["target"]), int(s["t"])
            e.np_random.bit_generator.state = json.loads(s["rng"])


def test_a_checkpoint_inside_an_episode_of_the_warm_up_keeps_the_controllers_state(tmp_path):
    from elastica_magnetic_rl.runner.loop import train_seeds

    def run(name, **kw):
        return train_seeds(lambda k: SavingVectorEnv([_fixed] * k, autoreset_mode=AutoresetMode.SAME_STEP),
                           [_config(yardstick_warmup=200, checkpoint_every=50)], WARM_UP + 40,
                           [tmp_path / name], progress=False, yardstick_fn=Alternating, **kw)

    full = run("full")

    def kill(row):
        if row["global_step"] >= 60:
            raise Killed

    with pytest.raises(Killed):
        run("cut", log_fn=kill)
    ckpt = load_checkpoint(tmp_path / "cut")
    assert ckpt["global_step"] == 50 and not ckpt["at_episode_boundary"]
    assert ckpt["vector"]["yardsticks"] == [{"steps": 10}]  # 10 steps into its third episode
    resumed = run("cut", resume=True)
    assert_state_equal(full.seed_state(0), resumed.seed_state(0))
    a, b = load_checkpoint(tmp_path / "full"), load_checkpoint(tmp_path / "cut")
    assert_state_equal(a["buffer"], b["buffer"], "buffer")


def test_a_warm_up_without_a_yardstick_or_with_another_shape_is_refused(tmp_path):
    with pytest.raises(ValueError, match="the warm-up is played by the case's yardstick, and none was given"):
        train(_fixed, _config(), WARM_UP + 20, tmp_path / "none", progress=False)

    class Wide(Toward):
        obs_dim = 5

    with pytest.raises(ValueError, match="reads 5 observation entries .* the environment has 3"):
        train(_fixed, _config(), WARM_UP + 20, tmp_path / "wide", progress=False, yardstick_fn=Wide)
    assert not (tmp_path / "none").exists() and not (tmp_path / "wide").exists()


def _distance_to_controller(agent, run_dir) -> float:
    """Mean |actor - controller| of the first action over the warm-up's states."""
    obs, _ = _warm_up_rows(run_dir)
    toward, shown = Toward(), []
    for o in obs:
        if o[2] == 0.0:  # an episode's first observation
            toward.reset()
        shown.append(toward.act(o))
    with torch.no_grad():
        acted = torch.tanh(agent.actor.net(torch.as_tensor(obs))).numpy()
    return float(np.abs(acted - np.array(shown))[:, 0].mean())


def test_a_run_held_near_its_warm_up_trains_and_keeps_the_clone(tmp_path):
    """``yardstick_regularization``: the run samples its warm-up rows at every actor step and stays
    nearer the controller than the same run without it; a buffer that would overwrite those rows
    is refused before any step."""
    steps = WARM_UP + 200
    distances = {}
    for beta in (0.0, 4.0):
        run_dir = tmp_path / f"beta{beta:g}"
        agent = train(_fixed, _config(yardstick_regularization=beta), steps, run_dir, progress=False,
                      yardstick_fn=Toward, eval_env_fn=_fixed)
        assert load_checkpoint(run_dir)["config"]["yardstick_regularization"] == beta
        distances[beta] = _distance_to_controller(agent, run_dir)
    assert distances[4.0] < 0.5 * distances[0.0], distances  # measured: 0.18 against 0.78
    with pytest.raises(ValueError, match=r"buffer_size \(200\) must hold the run's 320 steps"):
        train(_fixed, _config(yardstick_regularization=0.4, buffer_size=200), steps, tmp_path / "ring",
              progress=False, yardstick_fn=Toward)
    assert not (tmp_path / "ring").exists()


def test_no_periodic_evaluation_falls_in_the_warm_up(tmp_path):
    """An evaluation inside a warm-up the yardstick plays judged the untrained actor, which could
    then stay best.pt over its clone (measured: a coil catheter's seed whose best.pt was the
    untrained actor, 0 of 20 held-out targets, its clone 30.9 against 34.8 on the one evaluation
    target). The first periodic evaluation now comes after the clone's."""
    steps = WARM_UP + 120
    train(_fixed, _config(eval_every=100, yardstick_warmup=200), steps, tmp_path / "warm", progress=False,
          yardstick_fn=Toward, eval_env_fn=_fixed)
    rows = (tmp_path / "warm" / "evaluations.csv").read_text().splitlines()[1:]
    evaluated = [int(row.split(",")[0]) for row in rows]
    assert evaluated[0] == WARM_UP + 1 and all(step > WARM_UP for step in evaluated), evaluated
    assert len(evaluated) >= 2  # the clone's, then the periodic ones after the warm-up
    assert load_checkpoint(tmp_path / "warm" / "best.pt")["global_step"] > WARM_UP

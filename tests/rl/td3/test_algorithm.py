"""Tests of the TD3 agent (rl/td3/algorithm.py): hand-computed update, truncation vs termination, exact
resume, per-dimension exploration noise, a Pendulum smoke run and the replay buffer sizing."""

from __future__ import annotations

import csv
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.runner.evaluation import ActorPolicy, evaluate
from elastica_magnetic_rl.runner.loop import train
from elastica_magnetic_rl.td3.agent import TD3Agent
from elastica_magnetic_rl.td3.algorithm import TD3Config
from elastica_magnetic_rl.td3.replay_buffer import Batch, ReplayBuffer
from state_compare import assert_state_equal

torch.set_num_threads(1)


class ToyEnv(gym.Env):
    """Tiny 1-D reaching task: obs (position, target, t/T); two action dims with asymmetric
    bounds; terminates at random (through ``self.np_random``) and is truncated after T steps."""

    metadata = {"render_modes": []}

    def __init__(self, max_steps: int = 20, p_terminate: float = 0.06) -> None:
        self.max_steps, self.p_terminate = max_steps, p_terminate
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (3,), np.float32)
        self.action_space = gym.spaces.Box(
            np.array([-1.0, 0.0], np.float32), np.array([1.0, 2.0], np.float32)
        )

    def _obs(self) -> np.ndarray:
        return np.array([self.pos, self.target, self.t / self.max_steps], np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.pos = float(self.np_random.uniform(-0.5, 0.5))
        self.target = float(self.np_random.uniform(-1.0, 1.0))
        self.t = 0
        return self._obs(), {}

    def step(self, action):
        action = np.asarray(action, dtype=np.float64)
        self.pos += 0.1 * action[0]
        self.t += 1
        reward = -((self.pos - self.target) ** 2) - 0.01 * (action[1] - 1.0) ** 2
        terminated = self.t < self.max_steps and bool(self.np_random.random() < self.p_terminate)
        truncated = self.t >= self.max_steps and not terminated
        return self._obs(), float(reward), terminated, truncated, {}


def toy_config(**kw) -> TD3Config:
    base = dict(hidden_sizes=(16, 16), batch_size=16, learning_starts=30, checkpoint_every=40,
                log_every=10)
    base.update(kw)
    return TD3Config(**base)


# ----------------------------------------------------------------------------------------------
# (1) one critic update and one (delayed) actor update against a hand computation in numpy
# ----------------------------------------------------------------------------------------------
def _params(seq: torch.nn.Sequential) -> list[np.ndarray]:
    return [p.detach().numpy().astype(np.float64).copy() for p in seq.parameters()]


def _last_grads(net) -> list[np.ndarray]:
    """The last gradients of member 0 of a stacked network, in ``nn.Linear`` order and layout."""
    out = []
    for w, b in zip(net.weights, net.biases, strict=True):
        out += [w.grad[0].T.numpy().astype(np.float64), b.grad[0, 0].numpy().astype(np.float64)]
    return out


def _fwd(p: list[np.ndarray], x: np.ndarray):
    """One-hidden-layer ReLU MLP: returns output and the cache for backprop."""
    w0, b0, w1, b1 = p
    pre = x @ w0.T + b0
    h = np.maximum(pre, 0.0)
    return h @ w1.T + b1, (x, pre, h)


def _bwd(p: list[np.ndarray], cache, dout: np.ndarray):
    """Gradients of the parameters [w0, b0, w1, b1] and of the input."""
    w0, _, w1, _ = p
    x, pre, h = cache
    dh = (dout @ w1) * (pre > 0)
    return [dh.T @ x, dh.sum(0), dout.T @ h, dout.sum(0)], dh @ w0


class _Adam:
    """Adam (Kingma & Ba) with PyTorch's defaults, written out."""

    def __init__(self, params, lr, b1=0.9, b2=0.999, eps=1e-8):
        self.lr, self.b1, self.b2, self.eps = lr, b1, b2, eps
        self.m = [np.zeros_like(q) for q in params]
        self.v = [np.zeros_like(q) for q in params]
        self.t = 0

    def step(self, params, grads):
        self.t += 1
        out = []
        for i, (q, g) in enumerate(zip(params, grads, strict=True)):
            self.m[i] = self.b1 * self.m[i] + (1 - self.b1) * g
            self.v[i] = self.b2 * self.v[i] + (1 - self.b2) * g * g
            m_hat = self.m[i] / (1 - self.b1**self.t)
            v_hat = self.v[i] / (1 - self.b2**self.t)
            out.append(q - self.lr * m_hat / (np.sqrt(v_hat) + self.eps))
        return out


def test_update_matches_hand_computation():
    obs_dim, act_dim, n = 3, 2, 5
    cfg = TD3Config(hidden_sizes=(3,), actor_lr=0.01, critic_lr=0.02, gamma=0.9, tau=0.1,
                    policy_noise=0.3, target_noise_clip=0.2, policy_delay=2, seed=3)
    agent = TD3Agent(obs_dim, act_dim, -np.ones(act_dim), np.ones(act_dim), cfg)
    rng = np.random.default_rng(0)

    def batch():
        return Batch(
            rng.normal(size=(n, obs_dim)).astype(np.float32),
            rng.uniform(-1, 1, size=(n, act_dim)).astype(np.float32),
            rng.normal(size=n).astype(np.float32),
            rng.normal(size=(n, obs_dim)).astype(np.float32),
            np.array([0, 1, 0, 0, 1], np.float32),
        )

    batches = [batch(), batch()]

    # reference state, copied from the agent before any update
    actor = _params(agent.actor.net)
    q1, q2 = _params(agent.critic.q1_net), _params(agent.critic.q2_net)
    actor_t, q1_t, q2_t = actor, q1, q2  # targets start as copies
    assert all(np.array_equal(a, b) for a, b in zip(actor_t, _params(agent.actor_target.net),
                                                    strict=True))
    opt_q, opt_a = _Adam(q1 + q2, cfg.critic_lr), _Adam(actor, cfg.actor_lr)
    noise_gen = torch.Generator()
    noise_gen.set_state(agent.torch_rng.get_state())  # replay the agent's target-noise draws

    def critic_step(b: Batch):
        nonlocal q1, q2
        s, a, r, s2, d = (np.asarray(x, np.float64) for x in b)
        eps = torch.randn((n, act_dim), generator=noise_gen).numpy().astype(np.float64)
        eps = np.clip(cfg.policy_noise * eps, -cfg.target_noise_clip, cfg.target_noise_clip)
        a2 = np.clip(np.tanh(_fwd(actor_t, s2)[0]) + eps, -1, 1)
        sa2 = np.concatenate([s2, a2], 1)
        q_next = np.minimum(_fwd(q1_t, sa2)[0], _fwd(q2_t, sa2)[0])[:, 0]
        y = r + cfg.gamma * (1 - d) * q_next
        sa = np.concatenate([s, a], 1)
        out1, c1 = _fwd(q1, sa)
        out2, c2 = _fwd(q2, sa)
        loss = np.mean((out1[:, 0] - y) ** 2) + np.mean((out2[:, 0] - y) ** 2)
        g1, _ = _bwd(q1, c1, 2 * (out1 - y[:, None]) / n)
        g2, _ = _bwd(q2, c2, 2 * (out2 - y[:, None]) / n)
        new = opt_q.step(q1 + q2, g1 + g2)
        q1, q2 = new[:4], new[4:]
        return loss

    # update 1: critics only (policy delay 2)
    loss1 = critic_step(batches[0])
    info1 = agent.update(batches[0])
    assert "actor_loss" not in info1
    assert info1["critic_loss"] == pytest.approx(loss1, rel=1e-5)
    for ref, net in ((q1, agent.critic.q1_net), (q2, agent.critic.q2_net)):
        for a, b in zip(ref, _params(net), strict=True):
            np.testing.assert_allclose(b, a, rtol=1e-5, atol=1e-6)
    for a, b in zip(actor, _params(agent.actor.net), strict=True):
        np.testing.assert_array_equal(b, a)  # actor untouched
    for a, b in zip(q1_t, _params(agent.critic_target.q1_net), strict=True):
        np.testing.assert_array_equal(b, a)  # targets untouched

    # update 2: critics (second Adam step), then actor on the new Q1, then Polyak targets
    loss2 = critic_step(batches[1])
    s = batches[1].obs.astype(np.float64)
    pre_a, ca = _fwd(actor, s)
    mu = np.tanh(pre_a)
    qa, cq = _fwd(q1, np.concatenate([s, mu], 1))
    actor_loss = -qa.mean()
    _, d_in = _bwd(q1, cq, -np.ones_like(qa) / n)
    grads_a, _ = _bwd(actor, ca, d_in[:, obs_dim:] * (1 - mu**2))
    actor = opt_a.step(actor, grads_a)
    q1_t = [cfg.tau * p + (1 - cfg.tau) * pt for p, pt in zip(q1, q1_t, strict=True)]
    q2_t = [cfg.tau * p + (1 - cfg.tau) * pt for p, pt in zip(q2, q2_t, strict=True)]
    actor_t = [cfg.tau * p + (1 - cfg.tau) * pt for p, pt in zip(actor, actor_t, strict=True)]

    info2 = agent.update(batches[1])
    assert info2["critic_loss"] == pytest.approx(loss2, rel=1e-5)
    assert info2["actor_loss"] == pytest.approx(actor_loss, rel=1e-5)
    for g_ref, g in zip(grads_a, _last_grads(agent.actor_net), strict=True):
        np.testing.assert_allclose(g, g_ref, rtol=1e-4, atol=1e-7)
    pairs = [
        (q1, agent.critic.q1_net), (q2, agent.critic.q2_net), (actor, agent.actor.net),
        (q1_t, agent.critic_target.q1_net), (q2_t, agent.critic_target.q2_net),
        (actor_t, agent.actor_target.net),
    ]
    for ref, net in pairs:
        for a, b in zip(ref, _params(net), strict=True):
            np.testing.assert_allclose(b, a, rtol=1e-5, atol=1e-6)
    # the reference parameters did move (the comparison is not vacuous)
    assert not np.allclose(actor[0], _params(agent.actor_target.net)[0])


# ----------------------------------------------------------------------------------------------
# (2) terminated vs truncated
# ----------------------------------------------------------------------------------------------
def test_target_bootstraps_on_truncation_not_on_termination():
    cfg = TD3Config(hidden_sizes=(8,), policy_noise=0.0, gamma=0.97)
    agent = TD3Agent(3, 2, -np.ones(2), np.ones(2), cfg)
    s2 = torch.tensor([[0.3, -1.2, 0.5], [0.3, -1.2, 0.5]])
    r = torch.tensor([[0.7], [0.7]])
    term = torch.tensor([[0.0], [1.0]])  # row 0: truncated / ongoing, row 1: terminated
    y = agent.compute_target(r, s2, term)
    with torch.no_grad():
        q1, q2 = agent.critic_target(s2, agent.actor_target(s2))
        q_next = torch.min(q1, q2)
    assert abs(q_next[0].item()) > 1e-3
    assert y[0].item() == pytest.approx(0.7 + 0.97 * q_next[0].item(), rel=1e-6)
    assert y[1].item() == pytest.approx(0.7, abs=1e-7)


def test_training_loop_stores_terminated_not_done(tmp_path):
    # no learning needed: learning_starts beyond the run
    train(ToyEnv, toy_config(learning_starts=10_000), 150, tmp_path, progress=False)
    ckpt = load_checkpoint(tmp_path)
    buf = ckpt["buffer"]
    next_obs, term = buf["next_obs"].numpy(), buf["terminated"].numpy()
    with open(tmp_path / "episodes.csv") as f:
        rows = list(csv.DictReader(f))
    n_trunc = sum(int(r["truncated"]) for r in rows)
    n_term = sum(int(r["terminated"]) for r in rows)
    assert n_trunc > 0 and n_term > 0  # both kinds occurred
    # truncated steps: the stored s' is the real final observation (t/T == 1), not the reset one,
    # and terminated = 0 so the target bootstraps
    at_limit = np.isclose(next_obs[:, 2], 1.0)
    assert at_limit.sum() == n_trunc
    assert np.all(term[at_limit] == 0.0)
    assert term.sum() == n_term


# ----------------------------------------------------------------------------------------------
# (3) resume determinism
# ----------------------------------------------------------------------------------------------
class _Killed(Exception):
    pass


def test_killed_and_resumed_run_is_bit_identical(tmp_path):
    steps, cfg = 200, toy_config(seed=7)
    full = train(ToyEnv, cfg, steps, tmp_path / "full", progress=False)

    def kill_late(row):
        if row["global_step"] >= 130:
            raise _Killed

    with pytest.raises(_Killed):
        train(ToyEnv, cfg, steps, tmp_path / "killed", progress=False, log_fn=kill_late)
    ckpt = load_checkpoint(tmp_path / "killed")
    assert cfg.learning_starts < ckpt["global_step"] < 130 and ckpt["at_episode_boundary"]
    assert ckpt["agent"]["num_updates"] > 0
    del ckpt
    with pytest.raises(FileExistsError):
        train(ToyEnv, cfg, steps, tmp_path / "killed", progress=False)
    resumed = train(ToyEnv, cfg, steps, tmp_path / "killed", resume=True, progress=False)

    assert_state_equal(full.state_dict(), resumed.state_dict())
    a, b = load_checkpoint(tmp_path / "full"), load_checkpoint(tmp_path / "killed")
    for key in ("agent", "buffer", "global_step", "episode", "python_rng", "torch_cpu_rng"):
        assert_state_equal(a[key], b[key], key)

    def log(run):
        with open(tmp_path / run / "episodes.csv") as f:
            return [{k: v for k, v in r.items() if k != "wall_time_s"} for r in csv.DictReader(f)]

    assert log("full") == log("killed")
    # and the run was not trivially deterministic: another seed learns different weights
    other = TD3Agent.for_env(ToyEnv(), toy_config(seed=8))
    assert not torch.equal(other.actor.net[0].weight, full.actor.net[0].weight)


# ----------------------------------------------------------------------------------------------
# (4) exploration noise per action dimension
# ----------------------------------------------------------------------------------------------
def test_exploration_noise_is_drawn_per_dimension():
    agent = TD3Agent.for_env(ToyEnv(), TD3Config(hidden_sizes=(8,), exploration_noise=0.2))
    with torch.no_grad():  # mu(s) = 0: the explored action is pure noise
        agent.actor_net.weights[-1].zero_()
        agent.actor_net.biases[-1].zero_()
    obs = np.zeros(3, np.float32)
    noise = np.stack([agent.select_action(obs, explore=True) for _ in range(4000)])
    assert np.all(noise[:, 0] != noise[:, 1])
    np.testing.assert_allclose(noise.std(0), [0.2, 0.2], rtol=0.06)
    assert abs(np.corrcoef(noise.T)[0, 1]) < 0.06
    np.testing.assert_array_equal(agent.select_action(obs, explore=False), [0.0, 0.0])
    # in environment units the noise scales with each half-range (both are 1 here) around center
    env_actions = np.stack([agent.act(obs, explore=True) for _ in range(2000)])
    np.testing.assert_allclose(env_actions.mean(0), [0.0, 1.0], atol=0.02)
    assert np.all(env_actions[:, 1] >= 0.0) and np.all(env_actions[:, 1] <= 2.0)


# ----------------------------------------------------------------------------------------------
# (5) smoke training on Pendulum-v1
# ----------------------------------------------------------------------------------------------
def test_pendulum_smoke_writes_log_tensorboard_and_checkpoint(tmp_path):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    cfg = TD3Config(hidden_sizes=(32, 32), batch_size=32, learning_starts=100, log_every=50)
    agent = train(lambda: gym.make("Pendulum-v1"), cfg, 300, tmp_path, progress=False)

    with open(tmp_path / "episodes.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1
    assert rows[0]["episode"] == "0" and rows[0]["global_step"] == "200"
    assert rows[0]["length"] == "200" and rows[0]["truncated"] == "1"
    assert rows[0]["terminated"] == "0" and float(rows[0]["return"]) < 0

    events = list(tmp_path.glob("events.out.tfevents.*"))
    assert events
    acc = EventAccumulator(str(tmp_path))
    acc.Reload()
    tags = acc.Tags()["scalars"]
    assert "charts/episodic_return" in tags and "losses/critic_loss" in tags
    assert "losses/actor_loss" in tags

    ckpt = load_checkpoint(tmp_path / "checkpoint.pt")
    assert ckpt["global_step"] == 300 and not ckpt["at_episode_boundary"]
    assert ckpt["agent"]["num_updates"] == 200
    restored = TD3Agent.from_checkpoint(tmp_path)
    obs = np.array([0.1, -0.5, 0.3], np.float32)
    np.testing.assert_array_equal(restored.act(obs), agent.act(obs))
    assert np.all(np.abs(agent.act(obs)) <= 2.0)
    policy = agent.policy_module()  # standalone obs -> env action module (for export)
    with torch.no_grad():
        np.testing.assert_allclose(policy(torch.from_numpy(obs)[None])[0].numpy(),
                                   agent.act(obs), rtol=1e-6)

    res = evaluate(agent, lambda: gym.make("Pendulum-v1"), episodes=1, seed=5)
    assert res.lengths == [200] and np.isfinite(res.mean_return)
    assert evaluate(agent, lambda: gym.make("Pendulum-v1"), 1, 5).returns == res.returns

    # (6) the replay buffer is sized to the run, not to buffer_size = 1e6
    assert cfg.buffer_size == 1_000_000
    assert ckpt["buffer"]["capacity"] == 300 and ckpt["buffer"]["obs"].shape == (300, 3)


# ----------------------------------------------------------------------------------------------
# (6) replay buffer
# ----------------------------------------------------------------------------------------------
def test_buffer_capacity_is_min_of_buffer_size_and_run(tmp_path):
    train(ToyEnv, toy_config(buffer_size=50, learning_starts=1000), 80, tmp_path, progress=False)
    buf = load_checkpoint(tmp_path)["buffer"]
    assert buf["capacity"] == 50 and buf["size"] == 50 and buf["ptr"] == 30


def test_replay_buffer_ring_dtype_and_state_roundtrip():
    buf = ReplayBuffer(4, obs_dim=2, act_dim=1)
    assert buf.obs.dtype == np.float32 and buf.obs.nbytes == 4 * 2 * 4
    for i in range(6):
        buf.add(np.full(2, i, np.float64), np.array([i / 10]), float(i), np.full(2, i + 1),
                terminated=(i == 5))
    assert len(buf) == 4 and buf.ptr == 2
    assert sorted(buf.rewards.tolist()) == [2.0, 3.0, 4.0, 5.0]
    assert buf.obs.dtype == np.float32 and buf.terminated[1] == 1.0  # i=5 went to slot 1
    batch = buf.sample(64, np.random.default_rng(0))
    np.testing.assert_array_equal(batch.next_obs[:, 0], batch.obs[:, 0] + 1)
    np.testing.assert_array_equal(batch.terminated, (batch.rewards == 5.0).astype(np.float32))

    same = ReplayBuffer(4, 2, 1)
    same.load_state_dict(buf.state_dict())
    assert (same.ptr, same.size) == (buf.ptr, buf.size)
    np.testing.assert_array_equal(same.obs, buf.obs)
    bigger = ReplayBuffer(10, 2, 1)  # into another capacity: chronological, oldest first
    bigger.load_state_dict(buf.state_dict())
    assert bigger.rewards[:4].tolist() == [2.0, 3.0, 4.0, 5.0] and bigger.ptr == 4
    smaller = ReplayBuffer(3, 2, 1)  # keeps the newest
    smaller.load_state_dict(buf.state_dict())
    assert smaller.rewards.tolist() == [3.0, 4.0, 5.0] and smaller.ptr == 0


def test_init_from_continues_without_new_warmup(tmp_path):
    """Refinement: start from another run's checkpoint (agent, buffer, counters) in a new dir."""
    train(ToyEnv, toy_config(), 100, tmp_path / "base", progress=False)
    base = load_checkpoint(tmp_path / "base")
    agent = train(ToyEnv, None, 130, tmp_path / "refine", progress=False,
                  init_from=tmp_path / "base")
    ckpt = load_checkpoint(tmp_path / "refine")
    assert ckpt["global_step"] == 130
    assert agent.num_updates == base["agent"]["num_updates"] + 30  # learning from the first step
    assert ckpt["buffer"]["capacity"] == 130 and ckpt["buffer"]["size"] == 130
    torch.testing.assert_close(ckpt["buffer"]["obs"][:100], base["buffer"]["obs"])
    with open(tmp_path / "refine" / "episodes.csv") as f:
        rows = list(csv.DictReader(f))
    assert rows and int(rows[0]["episode"]) >= base["episode"]


# ----------------------------------------------------------------------------------------------
# evaluation during training: best actor kept, training unchanged, exact across a resume
# ----------------------------------------------------------------------------------------------
def _evaluations(run_dir) -> list[dict[str, float]]:
    with open(run_dir / "evaluations.csv") as f:
        return [{k: float(v) for k, v in r.items() if k != "wall_time_s"} for r in csv.DictReader(f)]


def test_periodic_evaluation_keeps_the_best_and_leaves_training_unchanged(tmp_path):
    steps = 200
    plain = train(ToyEnv, toy_config(seed=7), steps, tmp_path / "plain", progress=False)
    cfg = toy_config(seed=7, eval_every=50, eval_episodes=3)
    agent = train(ToyEnv, cfg, steps, tmp_path / "eval", progress=False, eval_env_fn=ToyEnv)
    assert_state_equal(plain.state_dict(), agent.state_dict())  # evaluation draws no training RNG

    rows = _evaluations(tmp_path / "eval")
    episode_ends = [int(r["global_step"]) for r in csv.DictReader(open(tmp_path / "eval" / "episodes.csv"))]
    expected = [next(g for g in episode_ends if g >= m) for m in (50, 100, 150)]
    assert [int(r["global_step"]) for r in rows] == [*expected, steps]  # + one at the end
    best = np.maximum.accumulate([r["mean_return"] for r in rows])
    assert [r["best_mean_return"] for r in rows] == best.tolist()
    assert len(set(r["mean_return"] for r in rows)) > 1  # the policy did change between them

    ckpt = load_checkpoint(tmp_path / "eval" / "best.pt")
    i_best = int(np.argmax([r["mean_return"] for r in rows]))
    assert ckpt["kind"] == "best" and ckpt["global_step"] == rows[i_best]["global_step"]
    assert ckpt["evaluation"]["mean_return"] == rows[i_best]["mean_return"]
    # the saved networks reproduce the recorded evaluation
    space = ToyEnv().action_space
    replay = ActorPolicy(ckpt["agent"]["actor"], 3, 2, cfg.hidden_sizes, space.low, space.high)
    again = evaluate(replay, ToyEnv, episodes=3, seed=ckpt["evaluation"]["seed"])
    assert again.mean_return == rows[i_best]["mean_return"]
    # networks only: not a starting point for training
    with pytest.raises(ValueError, match="best evaluation"):
        TD3Agent.from_checkpoint(tmp_path / "eval" / "best.pt")
    with pytest.raises(ValueError, match="best evaluation"):
        train(ToyEnv, None, 250, tmp_path / "from_best", progress=False,
              init_from=tmp_path / "eval" / "best.pt")


def test_evaluation_survives_a_kill_and_resume(tmp_path):
    steps, cfg = 200, toy_config(seed=3, eval_every=10)
    train(ToyEnv, cfg, steps, tmp_path / "full", progress=False, eval_env_fn=ToyEnv)

    def kill_late(row):
        if row["global_step"] >= 150:
            raise _Killed

    with pytest.raises(_Killed):
        train(ToyEnv, cfg, steps, tmp_path / "killed", progress=False, log_fn=kill_late,
              eval_env_fn=ToyEnv)
    # the killed run evaluated after its last checkpoint: the resume must drop those rows
    resumed_from = load_checkpoint(tmp_path / "killed")["global_step"]
    assert _evaluations(tmp_path / "killed")[-1]["global_step"] > resumed_from
    train(ToyEnv, cfg, steps, tmp_path / "killed", resume=True, progress=False, eval_env_fn=ToyEnv)
    assert _evaluations(tmp_path / "full") == _evaluations(tmp_path / "killed")
    a, b = load_checkpoint(tmp_path / "full" / "best.pt"), load_checkpoint(tmp_path / "killed" / "best.pt")
    assert a["global_step"] == b["global_step"]
    assert_state_equal(a["agent"], b["agent"])


def test_resume_may_switch_on_evaluation_but_not_change_hyperparameters(tmp_path):
    """Run settings (checkpoint/log/eval cadence) follow the config passed on resume; the
    hyperparameters stay the checkpoint's; the weights equal an uninterrupted run's."""
    straight = train(ToyEnv, toy_config(seed=5), 200, tmp_path / "straight", progress=False)

    def kill_late(row):
        if row["global_step"] >= 130:
            raise _Killed

    with pytest.raises(_Killed):  # killed after a checkpoint at an episode boundary
        train(ToyEnv, toy_config(seed=5), 200, tmp_path / "run", progress=False, log_fn=kill_late)
    start = load_checkpoint(tmp_path / "run")["global_step"]
    resumed = train(ToyEnv, toy_config(seed=5, eval_every=40), 200, tmp_path / "run", resume=True,
                    progress=False, eval_env_fn=ToyEnv)
    assert_state_equal(straight.state_dict(), resumed.state_dict())
    steps = [r["global_step"] for r in _evaluations(tmp_path / "run")]
    assert steps and all(start < s <= 200 for s in steps) and steps[-1] == 200
    assert load_checkpoint(tmp_path / "run")["config"]["eval_every"] == 40
    with pytest.warns(UserWarning, match="hyperparameters"):
        again = train(ToyEnv, toy_config(seed=5, tau=0.5), 220, tmp_path / "run", resume=True,
                      progress=False)
    assert again.config.tau == toy_config().tau


# ----------------------------------------------------------------------------------------------
# K seeds side by side (their stacked update: tests/rl/td3/test_stacked.py)
# ----------------------------------------------------------------------------------------------
def test_seeds_trained_together_equal_their_runs_alone(tmp_path):
    from elastica_magnetic_rl.runner.loop import train_seeds

    configs = [toy_config(seed=s) for s in (2, 5)]
    train_seeds(lambda k: _sync(ToyEnv, k), configs, 150, [tmp_path / "g2", tmp_path / "g5"],
                progress=False)
    for s in (2, 5):
        train(ToyEnv, toy_config(seed=s), 150, tmp_path / f"alone{s}", progress=False)
        a, b = load_checkpoint(tmp_path / f"g{s}"), load_checkpoint(tmp_path / f"alone{s}")
        for key in ("agent", "buffer", "global_step", "episode"):
            assert_state_equal(a[key], b[key], key)


def _sync(env_fn, n):
    from gymnasium.vector import AutoresetMode, SyncVectorEnv

    return SyncVectorEnv([env_fn] * n, autoreset_mode=AutoresetMode.SAME_STEP)


def test_checkpoints_append_only_the_new_transitions(tmp_path):
    """The replay buffer goes to replay.bin, each checkpoint appending the rows since the last."""
    train(ToyEnv, toy_config(seed=1), 100, tmp_path, progress=False)
    ckpt = torch.load(tmp_path / "checkpoint.pt", weights_only=True)
    assert ckpt["buffer"]["file"] == "replay.bin" and "obs" not in ckpt["buffer"]
    width = 2 * 3 + 2 + 2
    assert (tmp_path / "replay.bin").stat().st_size == ckpt["buffer"]["rows"] * width * 4
    assert ckpt["buffer"]["rows"] == ckpt["buffer"]["size"] == 100
    first = load_checkpoint(tmp_path)["buffer"]
    # stray rows of a run killed between an append and its checkpoint are cut on resume
    with open(tmp_path / "replay.bin", "ab") as f:
        f.write(np.ones(width * 3, np.float32).tobytes())
    train(ToyEnv, toy_config(seed=1), 120, tmp_path, resume=True, progress=False)
    full = load_checkpoint(tmp_path)
    assert full["buffer"]["size"] == 120
    assert (tmp_path / "replay.bin").stat().st_size == 120 * width * 4
    for key in ("obs", "actions", "rewards", "next_obs", "terminated"):
        torch.testing.assert_close(full["buffer"][key][:100], first[key], rtol=0, atol=0)


def test_resume_without_checkpoint_refuses_and_keeps_the_log(tmp_path):
    train(ToyEnv, toy_config(seed=1), 60, tmp_path / "run", progress=False)
    (tmp_path / "run" / "checkpoint.pt").unlink()
    log = (tmp_path / "run" / "episodes.csv").read_text()
    with pytest.raises(FileNotFoundError, match="checkpoint.pt does not exist"):
        train(ToyEnv, toy_config(seed=1), 80, tmp_path / "run", resume=True, progress=False)
    assert (tmp_path / "run" / "episodes.csv").read_text() == log


# ----------------------------------------------------------------------------------------------
# colored exploration noise
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("beta", [0.0, 1.0, 2.0])
def test_colored_noise_has_the_power_law_spectrum_and_unit_variance(beta):
    from elastica_magnetic_rl.td3.exploration import colored_noise

    rng = np.random.default_rng(0)
    # (draws, steps, dims); red noise needs many draws: its variance sits in a few low frequencies
    x = np.stack([colored_noise(beta, 1000, 2, rng) for _ in range(2000)])
    assert x.shape == (2000, 1000, 2)
    assert np.abs(x.mean(axis=1)).max() < 1e-12  # every sequence has zero mean
    assert abs(np.mean(x**2) - 1.0) < 0.05
    power = (np.abs(np.fft.rfft(x, axis=1)) ** 2).mean(axis=(0, 2))
    freqs = np.fft.rfftfreq(1000)
    band = (freqs > 0.005) & (freqs < 0.4)
    slope = np.polyfit(np.log(freqs[band]), np.log(power[band]), 1)[0]
    assert slope == pytest.approx(-beta, abs=0.05)
    again = colored_noise(beta, 1000, 2, np.random.default_rng(0))
    np.testing.assert_array_equal(again, x[0])  # a function of the generator only
    with pytest.raises(ValueError, match="beta"):
        colored_noise(-1.0, 10, 1, rng)


def test_pink_exploration_is_correlated_in_time_and_trains_reproducibly(tmp_path):
    from elastica_magnetic_rl.runner.loop import train_seeds
    from elastica_magnetic_rl.runner.seed_run import SeedRun

    def lag1(cfg):
        run = SeedRun(0, cfg, 100, tmp_path / f"probe{cfg.noise_color}", False, None, None, 3, 2, 1)
        rng = np.random.default_rng(0)
        run.draw_noise(0, rng)
        x = np.stack([run.exploration(0, rng)[0] for _ in range(3000)])  # crosses used-up sequences
        return np.mean(x[1:] * x[:-1]) / np.mean(x * x), x.std()

    white, pink = lag1(toy_config(noise_color=0.0)), lag1(toy_config(noise_color=1.0, noise_horizon=500))
    assert abs(white[0]) < 0.05 and pink[0] > 0.5
    assert white[1] == pytest.approx(0.2, rel=0.1) and pink[1] == pytest.approx(0.2, rel=0.2)

    # with pink noise (sequences shorter than the run, so some run out mid-episode), a seed beside
    # another equals its run alone, and a killed run resumes bit-identically
    configs = [toy_config(seed=s, noise_color=1.0, noise_horizon=8) for s in (2, 5)]
    train_seeds(lambda k: _sync(ToyEnv, k), configs, 150, [tmp_path / "g2", tmp_path / "g5"],
                progress=False)
    alone = train(ToyEnv, configs[0], 150, tmp_path / "alone", progress=False)
    assert_state_equal(load_checkpoint(tmp_path / "g2")["agent"], alone.state_dict())

    def kill_late(row):
        if row["global_step"] >= 130:
            raise _Killed

    with pytest.raises(_Killed):
        train(ToyEnv, configs[0], 150, tmp_path / "killed", progress=False, log_fn=kill_late)
    resumed = train(ToyEnv, configs[0], 150, tmp_path / "killed", resume=True, progress=False)
    assert_state_equal(alone.state_dict(), resumed.state_dict())
    white_run = load_checkpoint(tmp_path / "g2")
    assert white_run["config"]["noise_color"] == 1.0


def test_seeds_evaluated_together_log_what_each_alone_logs(tmp_path):
    """Evaluations of a group's seeds in one vector environment record the same returns (and keep
    the same best.pt) as each seed evaluated alone in a single environment."""
    from elastica_magnetic_rl.runner.loop import train_seeds

    configs = [toy_config(seed=s, eval_every=40, eval_episodes=2) for s in (2, 5)]
    train_seeds(lambda k: _sync(ToyEnv, k), configs, 150, [tmp_path / "g2", tmp_path / "g5"],
                progress=False, eval_env_fn=ToyEnv, eval_vec_env_fn=lambda k: _sync(ToyEnv, k))
    for s in (2, 5):
        train(ToyEnv, toy_config(seed=s, eval_every=40, eval_episodes=2), 150, tmp_path / f"alone{s}",
              progress=False, eval_env_fn=ToyEnv)
        together, alone = _evaluations(tmp_path / f"g{s}"), _evaluations(tmp_path / f"alone{s}")
        assert together == alone and len(alone) >= 3
        a = load_checkpoint(tmp_path / f"g{s}" / "best.pt")
        assert_state_equal(a["agent"], load_checkpoint(tmp_path / f"alone{s}" / "best.pt")["agent"])


_FAULTS_SCRIPT = """
import resource, sys
import numpy as np, torch
from elastica_magnetic_rl.runner.allocator import retain_freed_memory
from elastica_magnetic_rl.td3.replay_buffer import ReplayBuffer
from elastica_magnetic_rl.td3.algorithm import TD3, TD3Config
torch.set_num_threads(1)
retained = retain_freed_memory()
configs = [TD3Config(seed=s, batch_size=256, hidden_sizes=(256, 256)) for s in range(2)]
learner = TD3(260, 2, -np.ones(2), np.ones(2), configs)
buffer, rng = ReplayBuffer(1000, 260, 2), np.random.default_rng(0)
for _ in range(1000):
    buffer.add(rng.normal(size=260), rng.uniform(-1, 1, 2), 0.0, rng.normal(size=260), False)
def update():
    learner.update([buffer.sample(256, learner.rngs[k]) for k in range(2)])
for _ in range(4):
    update()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(10):
    update()
print(retained, (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 10)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc malloc settings")
def test_retained_memory_stops_the_updates_page_faulting():
    """With :func:`retain_freed_memory` (as every training process sets it), a TD3 update of the
    paper's network sizes reuses its temporaries instead of page-faulting fresh ones in: an update
    of 2 stacked seeds faulted ~500 pages in without it (measured on Linux x86-64, glibc), and
    faults fewer than 200 with it."""
    out = subprocess.run([sys.executable, "-c", _FAULTS_SCRIPT], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[0] == "True"
    assert float(out[1]) < 200, f"{out[1]} minor page faults per update"

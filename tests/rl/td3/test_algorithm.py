"""Tests of the algorithm (rl/td3/algorithm.py): one update against a hand computation, the TD target
on truncation and termination, exploration noise per action dimension."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.td3.agent import TD3Agent
from elastica_magnetic_rl.td3.config import TD3Config
from elastica_magnetic_rl.td3.replay_buffer import Batch
from toy_env import ToyEnv

torch.set_num_threads(1)


# ----------------------------------------------------------------------------------------------
# (1) one critic update and one (delayed) actor update against a hand computation in numpy
# ----------------------------------------------------------------------------------------------
def _params(seq: torch.nn.Sequential) -> list[np.ndarray]:
    return [p.detach().numpy().astype(np.float64).copy() for p in seq.parameters()]


def _last_grads(net) -> list[np.ndarray]:
    """The last gradients of member 0 of a stacked network, in ``nn.Linear`` order and layout
    (without the padding of each member's block, ``StackedMLP``)."""
    out = []
    for i, (w, b) in enumerate(zip(net.weights, net.biases, strict=True)):
        width = net.sizes[i + 1]
        out += [w.grad[0, :, :width].T.numpy().astype(np.float64),
                b.grad[0, 0, :width].numpy().astype(np.float64)]
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

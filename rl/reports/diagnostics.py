"""Health of a training run's networks, read from its checkpoint (``msr policy diagnose RUN``): is the
critic calibrated, is the actor saturated?

Two ways a TD3 seed stops learning show here (benchmarks/results/LOG.md, "Why seeds fail"):

* **critic overestimation**: the critic's ``Q(s, a)`` on the run's recent transitions far above
  their discounted return, computed from the stored rewards (Monte-Carlo). The actor climbs the
  critic, so it follows the overestimate instead of the data.
* **actor saturation**: the actor's outputs before its ``tanh`` far beyond ``tanh``'s working
  range (``|x| > 3``: ``tanh`` above 0.995), where the gradient that trains the actor vanishes:
  the actor then commands the same field increment at the edge of the action box whatever it
  observes, and stays there.

Both are measured on the last ``recent`` transitions of the replay buffer (the states the current
policy visits), the return only on transitions far enough from a truncated episode end for the
discounted sum to be complete to 1 % (``gamma^H < 0.01``).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import torch

from elastica_magnetic.io import atomic_save
from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..runfiles.checkpoint import load_checkpoint, refuse_networks_only
from ..td3.config import SATURATION_PREACTIVATION
from ..td3.networks import networks_from_state

#: Fraction of recent states with a saturated output (any action dimension) that flags the actor.
SATURATED_FRACTION_FLAG = 0.9


def episode_ends(obs: np.ndarray, next_obs: np.ndarray) -> np.ndarray:
    """``(T,)`` bool: transition ``t`` is the last stored one of its episode (its ``next_obs`` is
    not the next transition's ``obs``); the last transition counts as an end. ``obs``,
    ``next_obs``: ``(T, obs_dim)`` of one environment, in the order they were collected."""
    ends = np.ones(len(obs), dtype=bool)
    if len(obs) > 1:
        ends[:-1] = np.any(next_obs[:-1] != obs[1:], axis=1)
    return ends


def discounted_returns(rewards: np.ndarray, terminated: np.ndarray, ends: np.ndarray,
                       gamma: float) -> tuple[np.ndarray, np.ndarray]:
    """Monte-Carlo discounted returns ``G_t = r_t + gamma G_{t+1}`` within each episode, ``(T,)``,
    and ``(T,)`` bool ``complete``: ``G_t`` misses less than 1 % of the discount weight (the
    episode terminated, or ends at least ``H`` steps later with ``gamma^H < 0.01``:
    :func:`discount_horizon`)."""
    horizon = discount_horizon(gamma)
    n = len(rewards)
    returns = np.zeros(n, dtype=np.float64)
    complete = np.zeros(n, dtype=bool)
    g, to_end, exact = 0.0, 0, False
    for t in range(n - 1, -1, -1):
        if ends[t] or terminated[t]:
            g, to_end, exact = 0.0, 0, bool(terminated[t])
        g = float(rewards[t]) + gamma * g
        to_end += 1
        returns[t] = g
        complete[t] = exact or to_end >= horizon
    return returns, complete


def discount_horizon(gamma: float) -> float:
    """The steps ``H`` a discounted return needs to miss less than 1 % of its weight
    (``gamma^H < 0.01``): 1 for ``gamma <= 0``, ``inf`` for ``gamma >= 1``."""
    if gamma <= 0.0:
        return 1.0
    if gamma >= 1.0:
        return math.inf
    return float(math.ceil(math.log(0.01) / math.log(gamma)))


def interleave_stride(obs: np.ndarray, next_obs: np.ndarray, most: int = 64) -> int:
    """How many environments' transitions a replay buffer interleaves (a vector run stores each
    step's ``N`` transitions one after the other): the smallest ``N`` for which a transition's
    ``next_obs`` is, nearly always, the ``obs`` of the transition ``N`` rows later (1 when none
    fits). ``obs``, ``next_obs``: ``(T, obs_dim)`` in storage order."""
    rows = slice(max(0, len(obs) - 4000), len(obs))  # the recent rows are enough
    obs, next_obs = obs[rows], next_obs[rows]
    for n in range(1, min(most, len(obs) - 1) + 1):
        if np.mean(np.all(next_obs[:-n] == obs[n:], axis=1)) > 0.5:
            return n
    return 1


def _chronological(buffer: dict[str, Any]) -> dict[str, np.ndarray]:
    keys = ("obs", "actions", "rewards", "next_obs", "terminated")
    data = {k: buffer[k].numpy() for k in keys}
    size, capacity = int(buffer["size"]), int(buffer["capacity"])
    if size == capacity and int(buffer.get("total_added", size)) > capacity:
        order = (int(buffer["ptr"]) + np.arange(size)) % capacity
        data = {k: v[order] for k, v in data.items()}
    return data


def run_health(run: str | os.PathLike, recent: int = 20_000) -> dict[str, Any]:
    """Critic calibration and actor saturation of a run (a run directory or its
    ``checkpoint.pt``) on its last ``recent`` transitions.

    Returns a JSON-ready dict: ``global_step``; ``environments`` (sub-environments whose
    transitions the buffer interleaves: :func:`interleave_stride`); ``transitions`` used and
    ``complete_returns``
    (those with a complete discounted return); ``q_data_mean`` (mean of ``(Q1 + Q2) / 2`` at the
    stored actions, on the transitions with a complete return), ``q_policy_mean`` (``Q1(s, mu(s))``, what the
    actor ascends) and ``return_mean`` / ``return_std`` (the Monte-Carlo discounted returns, reward
    units x steps); ``overestimation`` = ``q_data_mean - return_mean``; per action dimension
    ``preactivation_mean_abs`` and ``saturated_fraction``; and the verdicts
    ``critic_overestimates`` (the gap exceeds ``|return_mean| + return_std``: more than double the
    return, beyond its spread) and ``actor_saturated`` (a saturated output in more than
    :data:`SATURATED_FRACTION_FLAG` of the states).
    """
    if recent < 2:
        raise ValueError(f"recent must be >= 2 transitions, got {recent}")
    ckpt, actor, critic, data = _health_inputs(run)
    cfg, gamma = ckpt["config"], float(ckpt["config"]["gamma"])
    # a vector run stores its sub-environments' transitions interleaved, step by step
    envs = interleave_stride(data["obs"], data["next_obs"])
    g_all, c_all = _interleaved_returns(data, envs, gamma)
    start = max(0, len(data["rewards"]) - int(recent))
    g, c = g_all[start:], c_all[start:]
    pre, q_data, q_policy = _critic_and_actor_outputs(actor, critic, data, start)
    saturated = (pre.abs() > SATURATION_PREACTIVATION).numpy()
    if not c.any():
        raise ValueError(_no_complete_return(run, c_all, start, gamma, _longest_episode(data, envs),
                                             ckpt.get("metadata") or {}))
    q_mean, g_mean, g_std = float(q_data[c].mean()), float(g[c].mean()), float(g[c].std())
    gap = q_mean - g_mean
    meta = ckpt.get("metadata") or {}
    label = " ".join(str(x) for x in (meta.get("case"), f"seed {meta.get('seed')}",
                                       meta.get("recipe")) if x is not None)
    return {
        "run": str(run),
        "label": label,
        "global_step": int(ckpt["global_step"]),
        "gamma": gamma,
        "critic_layer_norm": bool(cfg.get("critic_layer_norm", False)),
        "environments": envs,
        "transitions": int(len(g)),
        "complete_returns": int(c.sum()),
        "q_data_mean": q_mean,
        "q_policy_mean": float(q_policy.mean()),
        "return_mean": g_mean,
        "return_std": g_std,
        "overestimation": gap,
        "critic_overestimates": bool(gap > abs(g_mean) + g_std),
        "preactivation_mean_abs": [float(x) for x in pre.abs().mean(dim=0)],
        "saturated_fraction": [float(x) for x in saturated.mean(axis=0)],
        "actor_saturated": bool(saturated.any(axis=1).mean() > SATURATED_FRACTION_FLAG),
        "_samples": {"q": q_data[c], "g": g[c], "pre": pre.numpy()},
    }


def _health_inputs(run: str | os.PathLike) -> tuple[dict[str, Any], Any, Any, dict[str, np.ndarray]]:
    """A run's checkpoint, its actor and critic, and its replay buffer in the order the
    transitions were collected; refuses a networks-only checkpoint or a buffer of fewer than two
    transitions."""
    ckpt = load_checkpoint(run)
    refuse_networks_only(ckpt, run)
    cfg, agent = ckpt["config"], ckpt["agent"]
    obs_dim, act_dim, hidden = int(ckpt["obs_dim"]), int(ckpt["act_dim"]), tuple(cfg["hidden_sizes"])
    actor, critic = networks_from_state(obs_dim, act_dim, tuple(cfg.get("actor_hidden_sizes") or hidden),
                                        agent["actor"], agent["critic"], Path(run),
                                        bool(cfg.get("critic_layer_norm", False)), hidden)
    data = _chronological(ckpt["buffer"])
    if len(data["rewards"]) < 2:
        raise ValueError(f"{run}: its replay buffer holds {len(data['rewards'])} transitions; "
                         "diagnose a run that has trained")
    return ckpt, actor, critic, data


def _interleaved_returns(data: dict[str, np.ndarray], envs: int,
                         gamma: float) -> tuple[np.ndarray, np.ndarray]:
    """The discounted return of every stored transition and whether it is complete (both shape
    ``(transitions,)``, in buffer order), each of the ``envs`` interleaved sub-environments'
    episodes followed on its own."""
    returns, complete, rows = [], [], []
    total = len(data["rewards"])
    for j in range(envs):
        idx = np.arange(j, total, envs)
        ends = episode_ends(data["obs"][idx], data["next_obs"][idx])
        g, c = discounted_returns(data["rewards"][idx], data["terminated"][idx] > 0.5, ends, gamma)
        returns.append(g)
        complete.append(c)
        rows.append(idx)
    order = np.argsort(np.concatenate(rows))
    return np.concatenate(returns)[order], np.concatenate(complete)[order]


def _longest_episode(data: dict[str, np.ndarray], envs: int) -> int:
    """Transitions in the longest episode the buffer holds (of any of its ``envs`` interleaved
    sub-environments; the first and last may be cut by the buffer's ends)."""
    longest, total = 1, len(data["rewards"])
    for j in range(envs):
        idx = np.arange(j, total, envs)
        ends = np.flatnonzero(episode_ends(data["obs"][idx], data["next_obs"][idx]))
        longest = max(longest, int(np.diff(ends, prepend=-1).max()))
    return longest


def _steps(n: float) -> str:
    """``n`` transitions and their time at one control step each (the crawler's)."""
    if math.isinf(n):
        return "infinite (gamma 1)"
    return f"{int(n)} steps, {n * ACTION_PERIOD:g} s"


def _no_complete_return(run: str | os.PathLike, complete: np.ndarray, start: int, gamma: float,
                        longest: int, meta: dict[str, Any]) -> str:
    """Why no transition from ``start`` on has a complete discounted return (``complete``: every
    stored transition's), with the change that would give one: a larger ``--recent`` when older
    transitions have one, else longer training episodes (no ``--recent`` can help)."""
    total, horizon = len(complete), discount_horizon(gamma)
    if complete.any():
        needed = total - int(np.flatnonzero(complete)[-1])
        return (f"{run}: none of the last {total - start} of its {total} transitions has a "
                f"complete discounted return (the discount horizon is {_steps(horizon)}, gamma "
                f"{gamma:g}: gamma^H < 0.01); give --recent {needed} or more")
    where = f"the discount horizon of {_steps(horizon)} (gamma {gamma:g}: gamma^H < 0.01)"
    duration = meta.get("episode_duration_s")
    if isinstance(duration, (int, float)) and duration / ACTION_PERIOD >= horizon and total >= horizon:
        # steps enough, in pieces: a run resumed after it ended starts new episodes there
        return (f"{run}: none of its {total} transitions has a complete discounted return: its longest "
                f"stretch of one episode is {_steps(longest)}, shorter than {where} (its episodes last "
                f"up to {duration:g} s, but those stored were cut short: ended early, or cut where the run "
                "was resumed after it had ended, which starts new episodes); train it on (msr train "
                f"--resume with at least {int(horizon)} more --steps) to compare the critic with returns")
    if isinstance(duration, (int, float)) and duration / ACTION_PERIOD >= horizon:
        # the run's episodes are long enough: it is the run that is young
        return (f"{run}: none of its {total} transitions has a complete discounted return: the run has "
                f"only {total} steps, fewer than {where} (its episodes last {duration:g} s, "
                f"{int(round(duration / ACTION_PERIOD))} steps); train it longer (msr train --resume with "
                "more --steps, or wait for a training still running) to compare the critic with returns")
    length = f"longest stored: {_steps(longest)}" + (
        f"; the run's episode length {duration:g} s" if isinstance(duration, (int, float)) else "")
    return (f"{run}: none of its {total} transitions has a complete discounted return: its "
            f"episodes ({length}) are shorter than {where}; a larger --recent cannot help: train "
            f"with episodes of at least {_steps(horizon)} (msr train --episode-duration, or the "
            "spec's [task] episode_duration) to compare the critic with returns")


def _critic_and_actor_outputs(actor: Any, critic: Any, data: dict[str, np.ndarray],
                              start: int) -> tuple[torch.Tensor, np.ndarray, np.ndarray]:
    """On the transitions from ``start`` on: the actor's pre-``tanh`` outputs ``(n, act_dim)``,
    ``(Q1 + Q2) / 2`` at the stored actions and ``Q1(s, mu(s))`` (both ``(n,)``)."""
    obs = torch.as_tensor(data["obs"][start:], dtype=torch.float32)
    actions = torch.as_tensor(data["actions"][start:], dtype=torch.float32)
    with torch.no_grad():
        pre = actor.net(obs)
        q1, q2 = critic(obs, actions)
        q_data = (0.5 * (q1 + q2))[:, 0].double().numpy()
        q_policy = critic.q1(obs, torch.tanh(pre))[:, 0].double().numpy()
    return pre, q_data, q_policy


def health_figure(health: dict[str, Any], path: str | os.PathLike) -> Path:
    """Two panels for one run: critic ``Q(s, a)`` against the discounted return of the same
    transitions (a calibrated critic lies on the diagonal), and the histogram of the actor's
    pre-``tanh`` outputs per action dimension (saturation beyond the shaded band ``|x| <= 3``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    samples = health["_samples"]
    q, g, pre = samples["q"], samples["g"], samples["pre"]
    rng = np.random.default_rng(0)
    pick = rng.choice(len(q), size=min(len(q), 3000), replace=False)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    ax1.scatter(g[pick], q[pick], s=3, alpha=0.4)
    lo, hi = float(min(g.min(), q.min())), float(max(g.max(), q.max()))
    ax1.plot([lo, hi], [lo, hi], "k--", lw=1, label="calibrated")
    ax1.set_xlabel("discounted return of the transition (Monte-Carlo)")
    ax1.set_ylabel("critic Q(s, a)")
    ax1.set_title(f"critic: mean Q {health['q_data_mean']:.3g} vs return {health['return_mean']:.3g}")
    ax1.legend(loc="upper left")
    limit = max(10.0, float(np.percentile(np.abs(pre), 99)))
    bins = np.linspace(-limit, limit, 81)
    for d in range(pre.shape[1]):
        ax2.hist(np.clip(pre[:, d], -limit, limit), bins=bins, alpha=0.5, label=f"action {d}")
    ax2.axvspan(-SATURATION_PREACTIVATION, SATURATION_PREACTIVATION, color="0.85", zorder=0,
                label="tanh working range")
    ax2.set_xlabel("actor output before tanh")
    ax2.set_ylabel("states")
    ax2.set_title("actor: saturated in " + ", ".join(f"{100 * f:.0f} %"
                                                    for f in health["saturated_fraction"]))
    ax2.legend(loc="upper right")
    fig.suptitle(f"{health['label'] or health['run']} at step {health['global_step']}", fontsize=9)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        return atomic_save(path, lambda tmp: fig.savefig(tmp, dpi=110))
    finally:
        plt.close(fig)


def public(health: dict[str, Any]) -> dict[str, Any]:
    """``health`` without its raw samples (for JSON)."""
    return {k: v for k, v in health.items() if not k.startswith("_")}

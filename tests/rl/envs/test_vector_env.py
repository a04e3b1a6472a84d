"""The vector environment (N crawlers in one batched simulator) and TD3 training with it.

Checks: sub-environment ``i`` reproduces a single ``MagneticCrawlerEnv`` seeded with ``seed + i``
exactly (observations, rewards, flags, final observations across autoresets); SAME_STEP autoreset
(no transition across a reset reaches the replay buffer; the stored next observation of an ended
episode is its real final observation); a blow-up in one robot terminates only that one; state
save/restore; bit-identical resume of ``train_vector``; ``msr train --envs 4`` smoke run.
"""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.envs.env import OBSERVATION_LAYOUT, MagneticCrawlerEnv
from elastica_magnetic_rl.envs.vector_env import MagneticCrawlerVectorEnv
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.runner.loop import train_vector
from elastica_magnetic_rl.td3.config import TD3Config
from gymnasium.vector import AutoresetMode, VectorEnv

from elastica_magnetic.cli import main as msr

DURATION = 0.05  # s: 5 steps per episode, so short runs cross several autoresets


def _actions(steps: int, n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (steps, n, 2)).astype(np.float32)


def test_spaces_and_autoreset_mode():
    env = MagneticCrawlerVectorEnv(3, duration=DURATION)
    assert isinstance(env, VectorEnv)
    assert env.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    assert env.observation_space.shape == (3, 260) and env.observation_space.dtype == np.float32
    assert env.action_space.shape == (3, 2) and env.action_space.dtype == np.float32
    assert env.single_observation_space == MagneticCrawlerEnv().observation_space
    obs, info = env.reset(seed=0)
    assert obs.dtype == np.float32 and obs in env.observation_space
    assert info["field_T"].shape == (3, 3)


def test_each_sub_env_equals_a_single_env_seeded_seed_plus_i():
    n, steps, seed = 3, 12, 5
    env = MagneticCrawlerVectorEnv(n, duration=DURATION)
    obs0, _ = env.reset(seed=seed)
    actions = _actions(steps, n)
    results = [env.step(actions[k]) for k in range(steps)]
    # reproducible: the same seed gives the same first observations
    assert np.array_equal(MagneticCrawlerVectorEnv(n, duration=DURATION).reset(seed=seed)[0], obs0)
    for i in range(n):
        single = MagneticCrawlerEnv(duration=DURATION)
        obs, _ = single.reset(seed=seed + i)
        assert np.array_equal(obs, obs0[i])
        for k in range(steps):
            obs, reward, terminated, truncated, info = single.step(actions[k, i])
            v_obs, v_rew, v_term, v_trunc, v_info = results[k]
            assert v_rew[i] == reward and v_term[i] == terminated and v_trunc[i] == truncated
            if terminated or truncated:
                assert v_info["_final_obs"][i]
                assert np.array_equal(v_info["final_obs"][i], obs)  # the true final observation
                assert v_info["final_info"]["time_s"][i] == pytest.approx(info["time_s"])
                obs, _ = single.reset()  # no seed: continues the sub-env's generator
            else:
                assert "_final_obs" not in v_info or not v_info["_final_obs"][i]
            assert np.array_equal(v_obs[i], obs), (i, k)  # after an end: the new episode's obs
    # truncation at the time limit (5 steps), never termination
    flags = np.array([r[3] for r in results])
    assert flags[4].all() and flags[9].all() and flags.sum() == 2 * n
    assert not np.array([r[2] for r in results]).any()


def test_blow_up_terminates_only_that_sub_env():
    n = 3
    ref = MagneticCrawlerVectorEnv(n, duration=1.0)
    env = MagneticCrawlerVectorEnv(n, duration=1.0)
    ref.reset(seed=1)
    env.reset(seed=1)
    a = np.full((n, 2), 0.5, dtype=np.float32)
    ref.step(a)
    last, _, _, _, _ = env.step(a)
    env.robots.rods[1].velocity_collection[1, 10] = 1e3  # m/s: a numerical blow-up of robot 1
    obs, rew, term, trunc, info = env.step(a)
    r_obs, r_rew, _, _, _ = ref.step(a)
    assert term.tolist() == [False, True, False] and not trunc.any()
    assert rew[1] == env.divergence_penalty
    assert np.array_equal(info["final_obs"][1], last[1])  # the last finite observation
    assert info["final_info"]["_divergence"].tolist() == [False, True, False]
    assert not np.isnan(obs).any()
    for i in (0, 2):  # the other robots are untouched, bit for bit
        assert np.array_equal(obs[i], r_obs[i]) and rew[i] == r_rew[i]
    obs, _, term, _, _ = env.step(a)
    r_obs, _, _, _, _ = ref.step(a)
    assert not term.any() and np.array_equal(obs[[0, 2]], r_obs[[0, 2]])


def test_state_roundtrip_continues_bit_for_bit():
    n, actions = 2, _actions(6, 2, seed=3)
    env = MagneticCrawlerVectorEnv(n, duration=0.04)
    env.reset(seed=9)
    for k in range(3):
        env.step(actions[k])
    state = env.get_state()
    expected = [env.step(actions[k]) for k in range(3, 6)]  # crosses an autoreset (new field draw)
    other = MagneticCrawlerVectorEnv(n, duration=0.04)
    other.reset(seed=123)
    other.set_state(state)
    for k, exp in zip(range(3, 6), expected, strict=True):
        got = other.step(actions[k])
        for a, b in zip(got[:4], exp[:4], strict=True):
            assert np.array_equal(a, b)


def _tiny_config(**kw) -> TD3Config:
    return TD3Config(**{"hidden_sizes": (32, 32), "batch_size": 16, "learning_starts": 24,
                        "checkpoint_every": 40, "seed": 3, "target_noise_clip": 0.8, **kw})


def test_no_reset_transition_reaches_the_buffer(tmp_path):
    n, steps = 2, 24  # 12 vector steps, episodes of 4 steps: 3 episodes per sub-env
    fn = functools.partial(MagneticCrawlerVectorEnv, n, duration=0.04)
    train_vector(fn, _tiny_config(learning_starts=100), steps, tmp_path / "run", progress=False)
    buf = load_checkpoint(tmp_path / "run")["buffer"]
    obs, next_obs = buf["obs"].numpy(), buf["next_obs"].numpy()
    assert buf["size"] == steps and not buf["terminated"].numpy().any()
    omega = OBSERVATION_LAYOUT["angular_velocity"]
    # the first observation of an episode (robot at rest) appears only as an obs, never as s'
    is_reset = np.all(obs[:, omega] == 0.0, axis=1)
    assert is_reset.sum() == 3 * n and not np.all(next_obs[:, omega] == 0.0, axis=1).any()
    for t in range(steps // n - 1):
        for i in range(n):
            row, nxt = t * n + i, (t + 1) * n + i  # transitions are stored in sub-env order
            if is_reset[nxt]:  # the episode ended at step t: s' is its own final obs
                assert not np.array_equal(next_obs[row], obs[nxt])
            else:
                assert np.array_equal(next_obs[row], obs[nxt])


class _Killed(Exception):
    pass


@pytest.fixture
def one_thread():
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


@pytest.mark.parametrize("noise_color", [0.0, 1.0])
def test_train_vector_killed_and_resumed_is_bit_identical(tmp_path, one_thread, noise_color):
    fn = functools.partial(MagneticCrawlerVectorEnv, 4, duration=0.1)
    # checkpoints every 30 transitions fall inside the 40-transition episodes: the environments'
    # state (and the pink noise sequences) go into the checkpoint
    cfg, steps = _tiny_config(checkpoint_every=30, noise_color=noise_color, noise_horizon=7), 120
    full = train_vector(fn, cfg, steps, tmp_path / "full", progress=False)

    def kill(row):
        if row["global_step"] >= 80:
            raise _Killed

    with pytest.raises(_Killed):
        train_vector(fn, cfg, steps, tmp_path / "killed", progress=False, log_fn=kill)
    ckpt = load_checkpoint(tmp_path / "killed")
    assert cfg.learning_starts < ckpt["global_step"] < 80 and ckpt["vector"]["num_envs"] == 4
    resumed = train_vector(fn, cfg, steps, tmp_path / "killed", resume=True, progress=False)
    for key, value in full.state_dict()["actor"].items():
        assert torch.equal(value, resumed.state_dict()["actor"][key])
    a, b = load_checkpoint(tmp_path / "full"), load_checkpoint(tmp_path / "killed")
    assert a["global_step"] == b["global_step"] == steps
    for key in ("obs", "next_obs", "rewards"):
        assert torch.equal(a["buffer"][key], b["buffer"][key])
    assert a["agent"]["num_updates"] == b["agent"]["num_updates"] == steps - cfg.learning_starts

    def log(run):
        return [line.rsplit(",", 1)[0] for line in (tmp_path / run / "episodes.csv").read_text().splitlines()]

    assert log("full") == log("killed")


def test_msr_train_envs_4_smoke(tmp_path, capsys):
    capsys.readouterr()
    status = msr(["train", "--case", "m1-4mT", "--seeds", "1", "--envs", "4", "--steps", "240",
                  "--out", str(tmp_path), "--set", "learning_starts=60", "--set", "batch_size=32",
                  "--set", "hidden_sizes=32,32", "--episode-duration", "0.2",
                  "--set", "eval_duration=0.2", "--set", "checkpoint_every=100",
                  "--threads", "1", "--no-progress", "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert status == 0 and not summary["failed"] and summary["envs_per_seed"] == 4
    run = tmp_path / "m1-4mT" / "seed0"
    assert json.loads((run / "run.json").read_text())["envs"] == 4
    assert summary["seeds"][0]["episodes"] == 12  # 240 transitions / 20-step episodes
    ckpt = load_checkpoint(run)
    assert ckpt["global_step"] == 240 and ckpt["buffer"]["size"] == 240
    assert ckpt["agent"]["num_updates"] == 240 - 60


def _episodes_without_wall_time(run_dir) -> list[str]:
    lines = (run_dir / "episodes.csv").read_text().splitlines()
    return [line.rsplit(",", 1)[0] for line in lines]


def test_train_shared_seeds_equal_separate_single_env_runs(tmp_path):
    """Seeds 3 and 7 trained side by side in one simulator (``train_shared``; the second half after
    a resume) end bit-identical to two separate ``train`` runs with single environments: same
    episodes, weights, optimisers and buffers. Only the simulation is shared."""
    from elastica_magnetic_rl.envs.env import make_env
    from elastica_magnetic_rl.envs.vector_env import make_vector_env
    from elastica_magnetic_rl.runner.loop import train, train_shared

    duration, steps = 0.1, 40  # 10-step episodes; updates from step 20
    configs = [TD3Config(seed=s, learning_starts=20, batch_size=16, hidden_sizes=(16,),
                         checkpoint_every=10) for s in (3, 7)]
    vec_env_fn = functools.partial(make_vector_env, "m1-4mT", duration=duration)
    shared = [tmp_path / "shared" / f"seed{c.seed}" for c in configs]
    train_shared(vec_env_fn, configs, steps // 2, shared, progress=False)
    train_shared(vec_env_fn, configs, steps, shared, resume=True, progress=False)
    for config, run in zip(configs, shared, strict=True):
        single = tmp_path / "single" / f"seed{config.seed}"
        train(functools.partial(make_env, "m1-4mT", duration=duration), config, steps, single,
              progress=False)
        assert _episodes_without_wall_time(run) == _episodes_without_wall_time(single)
        a, b = load_checkpoint(run), load_checkpoint(single)
        assert a["global_step"] == b["global_step"] == steps and a["episode"] == b["episode"] == 4
        for part in ("actor", "critic", "actor_target", "critic_target"):
            for name, tensor in a["agent"][part].items():
                assert torch.equal(tensor, b["agent"][part][name]), (config.seed, part, name)
        assert a["agent"]["numpy_rng"] == b["agent"]["numpy_rng"]
        for key in ("obs", "next_obs", "actions", "rewards", "terminated"):
            assert torch.equal(torch.as_tensor(a["buffer"][key]), torch.as_tensor(b["buffer"][key]))
    w3 = load_checkpoint(shared[0])["agent"]["actor"]["net.0.weight"]
    assert not torch.equal(w3, load_checkpoint(shared[1])["agent"]["actor"]["net.0.weight"])


def test_train_shared_rejects_shared_run_dirs(tmp_path):
    from elastica_magnetic_rl.envs.vector_env import make_vector_env
    from elastica_magnetic_rl.runner.loop import train_shared

    configs = [TD3Config(seed=0), TD3Config(seed=1)]
    with pytest.raises(ValueError, match="own run_dir"):
        train_shared(functools.partial(make_vector_env, "m1-4mT"), configs, 10,
                     [tmp_path / "a", tmp_path / "a"], progress=False)


def test_policies_evaluated_together_equal_each_alone():
    """elastica_magnetic_rl.runner.evaluation.evaluate_many on the crawler's vector environment returns, for
    each policy, what elastica_magnetic_rl.runner.evaluation.evaluate returns with a single environment (the
    evaluation during training)."""
    from elastica_magnetic_rl.envs.env import make_env
    from elastica_magnetic_rl.envs.vector_env import make_vector_env
    from elastica_magnetic_rl.runner.evaluation import ActorPolicy, evaluate, evaluate_many
    from elastica_magnetic_rl.td3.algorithm import TD3

    learner = TD3(260, 2, -np.ones(2), np.ones(2), [TD3Config(seed=s, hidden_sizes=(16,)) for s in (0, 1)])
    policies = [ActorPolicy.of_seed(learner, k) for k in range(2)]
    together = evaluate_many(policies, functools.partial(make_vector_env, "m1-4mT", initial_field="zero",
                                                         duration=0.05), episodes=2, seed=7)
    for policy, result in zip(policies, together, strict=True):
        alone = evaluate(policy, functools.partial(make_env, "m1-4mT", "training", "zero", 0.05), 2, 7)
        assert result.returns == alone.returns and result.lengths == alone.lengths == [5, 5]
    assert together[0].returns != together[1].returns

"""The training loop (rl/runner/loop.py): terminated stored (not done), exact resume after a kill, a
Pendulum smoke run, buffer sizing, init_from, seeds together equal to alone, coloured exploration
reproducible."""

from __future__ import annotations

import csv

import gymnasium as gym
import numpy as np
import pytest
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.runner.evaluation import evaluate
from elastica_magnetic_rl.runner.loop import train
from elastica_magnetic_rl.td3.agent import TD3Agent
from elastica_magnetic_rl.td3.config import TD3Config
from state_compare import assert_state_equal
from toy_env import Killed, ToyEnv, sync_vector_env, toy_config

torch.set_num_threads(1)


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


def test_killed_and_resumed_run_is_bit_identical(tmp_path):
    steps, cfg = 200, toy_config(seed=7)
    full = train(ToyEnv, cfg, steps, tmp_path / "full", progress=False)

    def kill_late(row):
        if row["global_step"] >= 130:
            raise Killed

    with pytest.raises(Killed):
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


def test_a_start_over_removes_the_discarded_start_s_tensorboard_log(tmp_path):
    """Round 17, D: a run stopped before its first checkpoint, then started over (the same command,
    no --resume), left the discarded start's TensorBoard events beside the new run's, so
    TensorBoard plotted two runs as one seed."""
    from elastica_magnetic_rl.runfiles.rundir import RunDir

    def kill_at_once(row):
        raise Killed

    with pytest.raises(Killed):
        train(ToyEnv, toy_config(seed=3), 200, tmp_path, progress=False, log_fn=kill_at_once)
    assert not RunDir(tmp_path).has_checkpoint()
    discarded = set(tmp_path.glob("events.out.tfevents.*"))
    assert len(discarded) == 1
    train(ToyEnv, toy_config(seed=3), 200, tmp_path, progress=False)
    kept = set(tmp_path.glob("events.out.tfevents.*"))
    assert len(kept) == 1 and not kept & discarded


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
# K seeds side by side (their stacked update: tests/rl/td3/test_stacked.py)
# ----------------------------------------------------------------------------------------------
def test_seeds_trained_together_equal_their_runs_alone(tmp_path):
    from elastica_magnetic_rl.runner.loop import train_seeds

    configs = [toy_config(seed=s) for s in (2, 5)]
    train_seeds(lambda k: sync_vector_env(ToyEnv, k), configs, 150, [tmp_path / "g2", tmp_path / "g5"],
                progress=False)
    for s in (2, 5):
        train(ToyEnv, toy_config(seed=s), 150, tmp_path / f"alone{s}", progress=False)
        a, b = load_checkpoint(tmp_path / f"g{s}"), load_checkpoint(tmp_path / f"alone{s}")
        for key in ("agent", "buffer", "global_step", "episode"):
            assert_state_equal(a[key], b[key], key)


def test_resume_without_checkpoint_refuses_and_keeps_the_log(tmp_path):
    train(ToyEnv, toy_config(seed=1), 60, tmp_path / "run", progress=False)
    (tmp_path / "run" / "checkpoint.pt").unlink()
    log = (tmp_path / "run" / "episodes.csv").read_text()
    with pytest.raises(FileNotFoundError, match="checkpoint.pt does not exist"):
        train(ToyEnv, toy_config(seed=1), 80, tmp_path / "run", resume=True, progress=False)
    assert (tmp_path / "run" / "episodes.csv").read_text() == log


def test_pink_exploration_is_correlated_in_time_and_trains_reproducibly(tmp_path):
    from elastica_magnetic_rl.runner.loop import train_seeds
    from elastica_magnetic_rl.runner.seed_run import SeedRun

    def lag1(cfg):
        run = SeedRun(0, cfg, 100, tmp_path / f"probe{cfg.noise_color}", False, None, None, (3, 2), 1)
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
    train_seeds(lambda k: sync_vector_env(ToyEnv, k), configs, 150, [tmp_path / "g2", tmp_path / "g5"],
                progress=False)
    alone = train(ToyEnv, configs[0], 150, tmp_path / "alone", progress=False)
    assert_state_equal(load_checkpoint(tmp_path / "g2")["agent"], alone.state_dict())

    def kill_late(row):
        if row["global_step"] >= 130:
            raise Killed

    with pytest.raises(Killed):
        train(ToyEnv, configs[0], 150, tmp_path / "killed", progress=False, log_fn=kill_late)
    resumed = train(ToyEnv, configs[0], 150, tmp_path / "killed", resume=True, progress=False)
    assert_state_equal(alone.state_dict(), resumed.state_dict())
    white_run = load_checkpoint(tmp_path / "g2")
    assert white_run["config"]["noise_color"] == 1.0


# ----------------------------------------------------------------------------------------------
# Stopping seeds that have learned (rl/runner/stopping.py): a stopped seed leaves its group
# ----------------------------------------------------------------------------------------------
def _fixed_episodes():
    return ToyEnv(p_terminate=0.0)  # 20-step episodes: every seed's episodes end together


def _group(tmp_path, name, seeds, steps, rules=None, resume=False):
    from elastica_magnetic_rl.runner.loop import train_seeds

    return train_seeds(lambda k: sync_vector_env(_fixed_episodes, k),
                       [toy_config(seed=s, eval_every=40, checkpoint_every=1000) for s in seeds], steps,
                       [tmp_path / name / f"seed{s}" for s in seeds], progress=False, resume=resume,
                       eval_env_fn=_fixed_episodes, stop_rules=rules)


def test_a_stopped_seed_leaves_the_group_and_the_others_go_on_bit_identical(tmp_path):
    from elastica_magnetic_rl.runner.stopping import StopRule

    # a rule that only seed 5 has: it fires at seed 5's second evaluation (step 80)
    always = StopRule("target", threshold=-1e9, consecutive=2)
    learner = _group(tmp_path, "stop", (2, 5, 7), 200, [None, always, None])
    _group(tmp_path, "ref", (2, 7), 200)
    for s in (2, 7):  # the others: as if seed 5 had never been there
        a, b = load_checkpoint(tmp_path / "stop" / f"seed{s}"), load_checkpoint(tmp_path / "ref" / f"seed{s}")
        for key in ("agent", "buffer", "global_step", "episode"):
            assert_state_equal(a[key], b[key], key)
        assert a["stopped"] is None and a["global_step"] == 200
    stopped = load_checkpoint(tmp_path / "stop" / "seed5")
    assert stopped["global_step"] == 80
    assert stopped["stopped"]["step"] == 80 and stopped["stopped"]["reason"].startswith("target")
    assert stopped["stopped"]["rule"] == always.to_dict() == stopped["stop_rule"]
    with open(tmp_path / "stop" / "seed5" / "episodes.csv") as f:
        assert max(int(r["global_step"]) for r in csv.DictReader(f)) == 80
    # the stopped seed is the same seed trained alone to its stop
    _group(tmp_path, "alone", (5,), 80)
    assert_state_equal(stopped["agent"], load_checkpoint(tmp_path / "alone" / "seed5")["agent"])
    # the learner returned holds every seed at its end, in order
    assert learner.n_seeds == 3
    assert_state_equal(learner.seed_state(1)["actor"], stopped["agent"]["actor"])

    # resume after a stop: the stopped seed is not trained further, the others continue exactly
    before = (tmp_path / "stop" / "seed5" / "checkpoint.pt").read_bytes()
    _group(tmp_path, "stop", (2, 5, 7), 260, [None, always, None], resume=True)
    _group(tmp_path, "ref", (2, 7), 260, resume=True)
    assert (tmp_path / "stop" / "seed5" / "checkpoint.pt").read_bytes() == before
    for s in (2, 7):
        a, b = load_checkpoint(tmp_path / "stop" / f"seed{s}"), load_checkpoint(tmp_path / "ref" / f"seed{s}")
        assert a["global_step"] == 260
        assert_state_equal(a["agent"], b["agent"], "agent")


def test_a_group_resumed_in_another_grouping_leaves_its_finished_seeds_as_they_are(tmp_path):
    """Seeds that trained in different groups may stand at different steps (one finished its
    budget, one was handed back earlier): resumed as one group, the finished seed is left as it is
    and the other trains on, as it would alone."""
    _group(tmp_path, "mixed", (2, 5), 60)
    _group(tmp_path, "mixed", (5,), 120, resume=True)  # seed 5 finishes alone
    before = (tmp_path / "mixed" / "seed5" / "checkpoint.pt").read_bytes()
    learner = _group(tmp_path, "mixed", (2, 5), 120, resume=True)
    assert (tmp_path / "mixed" / "seed5" / "checkpoint.pt").read_bytes() == before
    _group(tmp_path, "ref", (2,), 120)
    a, b = load_checkpoint(tmp_path / "mixed" / "seed2"), load_checkpoint(tmp_path / "ref" / "seed2")
    assert a["global_step"] == 120
    for key in ("agent", "buffer", "episode"):
        assert_state_equal(a[key], b[key], key)
    assert learner.n_seeds == 2


class _Offset(gym.Wrapper):
    """The toy environment with every reward shifted (a confirmation environment that a rule's
    threshold can pass or fail)."""

    def __init__(self, env, offset):
        super().__init__(env)
        self.offset = offset

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        return obs, reward + self.offset, terminated, truncated, info


def test_a_fired_rule_stops_the_seed_only_if_its_confirmation_passes(tmp_path):
    from elastica_magnetic_rl.runner.loop import train_seeds
    from elastica_magnetic_rl.runner.stopping import StopRule

    # fires at every evaluation from the second on (step 80): the confirmation decides
    rule = StopRule("target", threshold=-1e3, consecutive=2, confirm="accurate")

    def group(name, offset, steps=200):
        return train_seeds(lambda k: sync_vector_env(_fixed_episodes, k),
                           [toy_config(seed=s, eval_every=40, checkpoint_every=1000) for s in (2, 5)],
                           steps, [tmp_path / name / f"seed{s}" for s in (2, 5)], progress=False,
                           eval_env_fn=_fixed_episodes, stop_rules=[None, rule],
                           confirm_env_fn=lambda: _Offset(_fixed_episodes(), offset))

    group("fails", -1e3)  # 20-step episodes: a return near -2e4, below the threshold
    failed = load_checkpoint(tmp_path / "fails" / "seed5")
    assert failed["stopped"] is None and failed["global_step"] == 200  # trained on to the end
    group("passes", 0.0)
    passed = load_checkpoint(tmp_path / "passes" / "seed5")
    assert passed["global_step"] == 80 and passed["stopped"]["step"] == 80
    assert "confirmed in the accurate physics (return " in passed["stopped"]["reason"]
    # the seed beside it is untouched by either: bit-identical in both groups
    assert_state_equal(load_checkpoint(tmp_path / "fails" / "seed2")["agent"],
                       load_checkpoint(tmp_path / "passes" / "seed2")["agent"], "agent")
    with pytest.raises(ValueError, match="needs confirm_env_fn"):
        train_seeds(lambda k: sync_vector_env(_fixed_episodes, k), [toy_config(seed=1)], 10,
                    [tmp_path / "none" / "seed1"], progress=False, stop_rules=[rule])


def test_resume_refuses_another_stop_rule_naming_both(tmp_path):
    from elastica_magnetic_rl.runner.stopping import StopRule

    _group(tmp_path, "run", (3,), 60, [StopRule("plateau", patience=3)])
    with pytest.raises(ValueError, match="stop rule is .*plateau.* not none"):
        _group(tmp_path, "run", (3,), 80, [None], resume=True)


# ----------------------------------------------------------------------------------------------
# A fractional update-to-data ratio and an actor narrower than its critics
# ----------------------------------------------------------------------------------------------
def test_a_fractional_update_ratio_makes_exactly_its_updates_and_resumes_exactly(tmp_path):
    from fractions import Fraction

    from elastica_magnetic_rl.runner.loop import train_vector

    cfg = toy_config(seed=4, updates_per_step=0.5, learning_starts=31)

    def three():  # 3 transitions per vector step (credit carries over); checkpoints at step 60, 120
        return sync_vector_env(_fixed_episodes, 3)

    whole = train_vector(three, cfg, 150, tmp_path / "whole", progress=False)
    ckpt = load_checkpoint(tmp_path / "whole")
    # the learning transitions (past the warm-up, buffer >= batch) owed 0.5 update each
    learned = ckpt["global_step"] - 31  # every transition past the warm-up
    assert whole.num_updates == int(Fraction(learned, 2))
    assert Fraction(ckpt["update_credit"]) == Fraction(learned, 2) - whole.num_updates

    def kill_late(row):
        if row["global_step"] >= 100:
            raise Killed

    with pytest.raises(Killed):
        train_vector(three, cfg, 150, tmp_path / "killed", progress=False, log_fn=kill_late)
    assert Fraction(load_checkpoint(tmp_path / "killed")["update_credit"]) == Fraction(1, 2)  # 29 x 0.5
    resumed = train_vector(three, cfg, 150, tmp_path / "killed", resume=True, progress=False)
    assert_state_equal(whole.state_dict(), resumed.state_dict())
    with pytest.raises(ValueError, match=r"updates_per_step must be a finite number in \(0, 64\]"):
        toy_config(updates_per_step=0)
    assert toy_config(updates_per_step=2.0).updates_per_step == 2  # an integer stays one


def test_a_narrower_actor_than_critics(tmp_path):
    from elastica_magnetic_rl.shipping.policy_files import build_networks

    cfg = toy_config(seed=1, hidden_sizes=(16, 16), actor_hidden_sizes=(4,))
    agent = train(ToyEnv, cfg, 60, tmp_path / "run", progress=False)
    assert agent.actor.net[0].out_features == 4 and agent.critic.q1_net[0].out_features == 16
    again = TD3Agent.from_checkpoint(tmp_path / "run")
    assert_state_equal(again.state_dict(), agent.state_dict())
    ckpt = load_checkpoint(tmp_path / "run")
    actor, critic = build_networks(3, 2, (4,), ckpt["agent"]["actor"], ckpt["agent"]["critic"],
                                   critic_hidden=(16, 16))
    assert actor.net[0].out_features == 4 and critic.q1_net[0].out_features == 16
    # a checkpoint written before the key existed: the actor as wide as the critics
    old = toy_config(seed=1).to_dict()
    del old["actor_hidden_sizes"]
    assert TD3Config.from_dict(old).actor_widths == (16, 16)


def test_a_crawler_that_stops_leaves_the_batched_simulator_and_the_other_goes_on_exactly(tmp_path):
    """The crawler's vector environment (one batched simulator): a seed that stops leaves it and
    the other seed goes on as if alone."""
    import functools

    from elastica_magnetic_rl.envs.env import make_env
    from elastica_magnetic_rl.envs.vector_env import make_vector_env
    from elastica_magnetic_rl.runner.loop import train_seeds
    from elastica_magnetic_rl.runner.stopping import StopRule

    vec = functools.partial(make_vector_env, "m1-4mT", physics="training", initial_field="random",
                            duration=0.05)
    evaluation = functools.partial(make_env, "m1-4mT", "training", "zero", 0.05)

    def run(name, seeds, rules):
        cfgs = [toy_config(seed=s, learning_starts=10, batch_size=8, hidden_sizes=(8,), eval_every=10)
                for s in seeds]
        train_seeds(vec, cfgs, 30, [tmp_path / name / f"seed{s}" for s in seeds], envs_per_seed=2,
                    progress=False, eval_env_fn=evaluation, stop_rules=rules)

    run("group", (0, 1), [None, StopRule("target", threshold=-1e9, consecutive=1)])
    run("alone", (0,), None)
    a, b = load_checkpoint(tmp_path / "group" / "seed0"), load_checkpoint(tmp_path / "alone" / "seed0")
    for key in ("agent", "buffer", "global_step", "episode"):
        assert_state_equal(a[key], b[key], key)
    assert load_checkpoint(tmp_path / "group" / "seed1")["stopped"]["step"] == 10


# ----------------------------------------------------------------------------------------------
# Handing seeds back (rl/sweep/rebalance.py moves them onto an idle worker)
# ----------------------------------------------------------------------------------------------
def _asked_from(calls: int):
    """A ``hand_back`` that says yes from its ``calls``-th question on (one question per common
    episode boundary: every 20 steps of the fixed episodes)."""
    asked = []

    def hand_back() -> bool:
        asked.append(1)
        return len(asked) >= calls

    return hand_back


def test_a_group_hands_its_seeds_back_and_they_end_bit_identical_in_other_groups(tmp_path):
    from elastica_magnetic_rl.runner.loop import train_seeds

    def group(name, seeds, steps, resume=False, hand_back=None):
        return train_seeds(lambda k: sync_vector_env(_fixed_episodes, k),
                           [toy_config(seed=s, eval_every=40, checkpoint_every=1000) for s in seeds],
                           steps, [tmp_path / name / f"seed{s}" for s in seeds], progress=False,
                           resume=resume, eval_env_fn=_fixed_episodes, hand_back=hand_back)

    group("moved", (2, 5, 7), 200, hand_back=_asked_from(3))  # handed back at step 60
    for s in (2, 5, 7):
        ckpt = load_checkpoint(tmp_path / "moved" / f"seed{s}")
        assert ckpt["global_step"] == 60 and ckpt["at_episode_boundary"] and ckpt["stopped"] is None
    group("moved", (2, 5), 200, resume=True)  # the seeds go on in two other groups
    group("moved", (7,), 200, resume=True)
    group("ref", (2, 5, 7), 200)  # never moved
    for s in (2, 5, 7):
        a = load_checkpoint(tmp_path / "moved" / f"seed{s}")
        b = load_checkpoint(tmp_path / "ref" / f"seed{s}")
        for key in ("agent", "buffer", "global_step", "episode", "evaluation"):
            assert_state_equal(a[key], b[key], key)
        for log in ("episodes.csv", "evaluations.csv"):
            rows = [[{k: v for k, v in r.items() if k != "wall_time_s"} for r in
                     csv.DictReader(open(tmp_path / run / f"seed{s}" / log))] for run in ("moved", "ref")]
            assert rows[0] == rows[1], log

    # one seed still training has nowhere better to go: it is not handed back
    group("alone", (2,), 100, hand_back=lambda: True)
    assert load_checkpoint(tmp_path / "alone" / "seed2")["global_step"] == 100


def test_a_lone_seed_is_evaluated_and_confirmed_on_the_batched_simulator_with_the_same_returns(tmp_path):
    """One seed's evaluations (``eval_vec_env_fn``) and its rule's confirmation
    (``confirm_vec_env_fn``) on one crawler of the batched simulator give what the single
    environments give: the same evaluation log, the same stop and weights."""
    import functools

    from elastica_magnetic_rl.envs.env import make_env
    from elastica_magnetic_rl.envs.vector_env import make_vector_env
    from elastica_magnetic_rl.runner.loop import train_seeds
    from elastica_magnetic_rl.runner.stopping import StopRule

    vec = functools.partial(make_vector_env, "m1-4mT", physics="training", initial_field="random",
                            duration=0.05)
    rule = StopRule("target", threshold=-1e9, consecutive=2, confirm="accurate")

    def run(name, batched):
        kw = (dict(eval_vec_env_fn=functools.partial(make_vector_env, "m1-4mT", physics="training",
                                                     initial_field="zero", duration=0.05),
                   confirm_vec_env_fn=functools.partial(make_vector_env, "m1-4mT",
                                                        physics="accurate", initial_field="zero",
                                                        duration=0.05))
              if batched else
              dict(confirm_env_fn=functools.partial(make_env, "m1-4mT", "accurate", "zero", 0.05)))
        cfg = toy_config(seed=3, learning_starts=10, batch_size=8, hidden_sizes=(8,), eval_every=10)
        train_seeds(vec, [cfg], 40, [tmp_path / name / "seed3"], progress=False,
                    eval_env_fn=functools.partial(make_env, "m1-4mT", "training", "zero", 0.05),
                    stop_rules=[rule], **kw)
        rows = [{k: v for k, v in r.items() if k != "wall_time_s"}
                for r in csv.DictReader(open(tmp_path / name / "seed3" / "evaluations.csv"))]
        return rows, load_checkpoint(tmp_path / name / "seed3")

    (rows_a, a), (rows_b, b) = run("single", False), run("batched", True)
    assert rows_a == rows_b and len(rows_a) == 2
    assert a["stopped"] == b["stopped"] and a["stopped"]["step"] == 20
    assert "confirmed in the accurate physics" in a["stopped"]["reason"]
    assert_state_equal(a["agent"], b["agent"], "agent")

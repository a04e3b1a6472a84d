"""Check of the TD3 agent itself (a benchmark, not a test): TD3 on Pendulum-v1.

Trains ``elastica_magnetic_rl.td3`` for ``--steps`` environment steps (default 20k) on each of ``--seeds``
seeds with
the paper's defaults (256-256, Adam 3e-4, batch 256, 2500 warm-up steps, sigma 0.2, ...), the seeds
side by side in one process (``elastica_magnetic_rl.runner.loop.train_seeds``; each seed as it would train
alone), once per
``--precision`` (``fp32``, and ``bf16``: bfloat16 matrix products on float32 weights), and reports
the mean deterministic evaluation return; the target is -200 or better. If
``stable_baselines3`` is importable, its TD3 is trained side by side with the same budget and
comparable hyperparameters (same network sizes, learning rates, noise, warm-up, delays) and
evaluated on the same evaluation episodes.

    python benchmarks/td3_pendulum.py                      # 3 seeds x 20k steps, table
    python benchmarks/td3_pendulum.py --seeds 1 --json     # quick check, JSON on stdout
    python benchmarks/td3_pendulum.py --precision fp32 bf16 --no-sb3   # is bf16 safe?
    python benchmarks/td3_pendulum.py --recipe paper pink             # the recipes side by side
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from elastica_magnetic_rl.cases.recipes import RECIPES  # noqa: E402
from elastica_magnetic_rl.runner.evaluation import ActorPolicy, evaluate  # noqa: E402
from elastica_magnetic_rl.runner.loop import train_seeds  # noqa: E402
from elastica_magnetic_rl.td3.config import TD3Config  # noqa: E402

ENV_ID = "Pendulum-v1"
TARGET = -200.0
EVAL_SEED = 10_000


def make_env() -> gym.Env:
    return gym.make(ENV_ID)


def run_ours(seeds: list[int], steps: int, eval_episodes: int, out: Path, progress: bool,
             precision: str = "fp32", recipe: str = "paper") -> list[dict]:
    """Train ``seeds`` side by side (one stacked TD3), evaluate each seed's final actor. ``recipe``:
    the crawler's recipe changes (:data:`~elastica_magnetic_rl.cases.recipes.RECIPES`, e.g. ``pink``
    exploration noise) on TD3's defaults."""
    from gymnasium.vector import AutoresetMode, SyncVectorEnv

    configs = [TD3Config(seed=s, checkpoint_every=max(steps, 1), precision=precision,
                         **RECIPES[recipe]) for s in seeds]
    t0 = time.time()
    learner = train_seeds(
        lambda k: SyncVectorEnv([make_env] * k, autoreset_mode=AutoresetMode.SAME_STEP), configs,
        steps, [out / f"rl_td3_{recipe}_{precision}_seed{s}" for s in seeds], progress=progress,
        progress_desc=f"elastica_magnetic_rl.td3 {precision}")
    wall = time.time() - t0
    results = []
    for k, seed in enumerate(seeds):
        res = evaluate(ActorPolicy.of_seed(learner, k), make_env, episodes=eval_episodes, seed=EVAL_SEED)
        results.append({"seed": seed, "eval_mean": res.mean_return, "eval_std": res.std_return,
                        "train_wall_s": wall / len(seeds)})
    return results


def _eval_callable(policy: Callable[[np.ndarray], np.ndarray], episodes: int) -> list[float]:
    env = make_env()
    returns = []
    for i in range(episodes):
        obs, _ = env.reset(seed=EVAL_SEED + i)
        done, ret = False, 0.0
        while not done:
            obs, r, term, trunc, _ = env.step(policy(obs))
            ret += float(r)
            done = term or trunc
        returns.append(ret)
    env.close()
    return returns


def run_sb3(seed: int, steps: int, eval_episodes: int, progress: bool) -> dict:
    from stable_baselines3 import TD3
    from stable_baselines3.common.noise import NormalActionNoise

    env = make_env()
    act_dim = env.action_space.shape[0]
    # SB3 works in normalised action units like elastica_magnetic_rl.td3: sigma 0.2 of the half-range.
    model = TD3(
        "MlpPolicy", env, learning_rate=3e-4, buffer_size=steps, learning_starts=2500,
        batch_size=256, tau=0.005, gamma=0.99, train_freq=1, gradient_steps=1,
        action_noise=NormalActionNoise(np.zeros(act_dim), 0.2 * np.ones(act_dim)),
        policy_delay=2, target_policy_noise=0.2, target_noise_clip=0.5,
        policy_kwargs={"net_arch": [256, 256]}, seed=seed, device="cpu", verbose=0,
    )
    t0 = time.time()
    model.learn(total_timesteps=steps, progress_bar=progress)
    wall = time.time() - t0
    returns = _eval_callable(lambda o: model.predict(o, deterministic=True)[0], eval_episodes)
    return {"seed": seed, "eval_mean": float(np.mean(returns)), "eval_std": float(np.std(returns)),
            "train_wall_s": wall}


def summarise(per_seed: list[dict]) -> dict:
    means = [r["eval_mean"] for r in per_seed]
    return {
        "per_seed": per_seed,
        "mean_eval_return": float(np.mean(means)),
        "std_over_seeds": float(np.std(means)),
        "mean_train_wall_s": float(np.mean([r["train_wall_s"] for r in per_seed])),
        "reaches_target": bool(np.mean(means) >= TARGET),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20_000)
    ap.add_argument("--seeds", type=int, default=3, help="number of seeds (0, 1, ...)")
    ap.add_argument("--eval-episodes", type=int, default=10)
    ap.add_argument("--threads", type=int, default=1, help="torch threads")
    ap.add_argument("--precision", nargs="+", choices=("fp32", "bf16"), default=["fp32"],
                    help="one run of ours per precision (default fp32)")
    ap.add_argument("--recipe", nargs="+", choices=tuple(RECIPES), default=["paper"],
                    help="one run of ours per recipe (default paper; pink: temporally correlated "
                         "exploration noise)")
    ap.add_argument("--out", type=Path, default=None, help="run directory (default: temporary)")
    ap.add_argument("--no-sb3", action="store_true", help="skip Stable-Baselines3")
    ap.add_argument("--progress", action="store_true", help="progress bars")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)

    tmp = None
    if args.out is None:
        tmp = tempfile.TemporaryDirectory(prefix="td3_pendulum_")
        out = Path(tmp.name)
    else:
        out = args.out
        out.mkdir(parents=True, exist_ok=True)
    seeds = list(range(args.seeds))

    results: dict[str, dict] = {}
    for recipe in args.recipe:
        for precision in args.precision:
            name = "elastica_magnetic_rl.td3" + ("" if recipe == "paper" else f"-{recipe}") + \
                ("" if precision == "fp32" else f"-{precision}")
            results[name] = summarise(run_ours(seeds, args.steps, args.eval_episodes, out,
                                               args.progress, precision, recipe))
    if args.no_sb3:
        results["sb3"] = {"skipped": "--no-sb3"}
    else:
        try:
            import stable_baselines3  # noqa: F401
        except ImportError:
            results["sb3"] = {"skipped": "stable_baselines3 is not installed"}
        else:
            results["sb3"] = summarise(
                [run_sb3(s, args.steps, args.eval_episodes, args.progress) for s in seeds])
    if tmp is not None:
        tmp.cleanup()

    report = {"env": ENV_ID, "steps": args.steps, "seeds": seeds,
              "eval_episodes": args.eval_episodes, "target": TARGET, "results": results}
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print(f"{ENV_ID}, {args.steps} steps, seeds {seeds}, {args.eval_episodes} eval episodes "
              f"(deterministic), target >= {TARGET:g}")
        print(f"{'agent':<12} {'seed':>5} {'eval mean':>10} {'eval std':>9} {'train s':>8}")
        for name, res in results.items():
            if "skipped" in res:
                print(f"{name:<12} skipped: {res['skipped']}")
                continue
            for r in res["per_seed"]:
                print(f"{name:<12} {r['seed']:>5} {r['eval_mean']:>10.1f} {r['eval_std']:>9.1f} "
                      f"{r['train_wall_s']:>8.1f}")
            print(f"{name:<12} {'mean':>5} {res['mean_eval_return']:>10.1f} "
                  f"{res['std_over_seeds']:>9.1f} {res['mean_train_wall_s']:>8.1f}  "
                  f"{'PASS' if res['reaches_target'] else 'FAIL'}")
    return 0 if all(r.get("reaches_target", True) for r in results.values()) else 1


if __name__ == "__main__":
    sys.exit(main())

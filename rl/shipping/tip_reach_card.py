"""The model card of a shipped tip-reach policy (a catheter steered by a magnet on an arm or by
fixed coils): what it does and how to use it, its training, and its judgement on the case's 20
held-out targets beside the case's steering yardstick. Lengths in the card are mm, times s."""

from __future__ import annotations

from typing import Any

from ..cases.case import Case
from .policy_files import TIP_PATHS_PNG
from .residual_card import residual_use_lines

__all__ = ["tip_reach_card"]


def _box_mm(box: Any) -> str:
    """A target box ``((xmin, ymin, zmin), (xmax, ymax, zmax))`` m, in mm."""
    return " to ".join("(" + ", ".join(f"{1e3 * v:g}" for v in corner) + ")" for corner in box)


def _summary_row(name: str, result: dict[str, Any]) -> str:
    times = [t for t in result["time_to_target_s"] if t is not None]
    mean = f"{sum(times) / len(times):.2f}" if times else "-"
    finals = [1e3 * d for d in result["final_distance_m"] if d is not None]
    largest = f"{max(finals):.2f}" if finals else "-"
    return (f"| {name} | {result['successes']} of {len(result['targets_m'])} | {mean} | {largest} |")


def tip_reach_card(info: dict[str, Any], case: Case, notes_section: str) -> str:
    """The card (Markdown) of the tip-reach policy described by ``info`` (its ``policy.json``);
    ``notes_section``: the heading of its notes (the crawlers' cards use the same)."""
    task, tr = case.task, info["training"]
    tolerance_mm = 1e3 * task.tolerance
    lines = [
        f"# Model card: `{info['name']}`",
        "",
        f"TD3 actor (case `{case.name}`) that steers the tip of the clamped catheter "
        f"`{case.robot.name}` to a target in the box {_box_mm(task.target_box)} mm and holds it within "
        f"{tolerance_mm:g} mm, by {info['action']['meaning']}.",
        "",
        *([case.description, ""] if case.description else []),
        "## Use",
        "",
        f"- `msr policy generate {info['name']} --target X,Y,Z --json`: steers to that target (m, in "
        "the spec's frame: the base at the origin, the rod along +x) in the accurate physics and "
        "reports `tip_error_m`; without `--target`, the case's 20 held-out targets.",
        *residual_use_lines(info),
        f"- Input: {info['architecture']['obs_dim']} float32 observations (blocks and scales in "
        f"`policy.json`); output: {info['architecture']['act_dim']} actions in [-1, 1] every 0.01 s.",
        "",
        "## Training",
        "",
        f"- seed: {tr['seed']}; training steps: {tr['training_steps']}; checkpoint: `{tr['source']}` "
        f"(global step {tr['global_step']}"
        + ("; the best of the evaluations during training" if tr.get("best_evaluation") else "") + ")",
    ]
    config = tr.get("config") or {}
    if config.get("yardstick_warmup"):
        lines.append(f"- started from the yardstick: {config.get('learning_starts')} warm-up transitions "
                     f"of the steering law (exploration noise {config.get('exploration_noise')}), cloned "
                     f"in {config['yardstick_warmup']} steps")
    evaluation = (info.get("evaluation") or {}).get("tip_reach")
    lines += ["", "## Evaluation", ""]
    if evaluation is None:
        lines.append("Not measured (`--no-measure`): `msr policy generate` on the held-out targets "
                     "judges it.")
    else:
        seconds = info["evaluation"]["duration_s"]
        lines += [f"The case's 20 held-out targets (a seed training never uses), {seconds:g} s each "
                  f"from the start pose, accurate physics; success: within {tolerance_mm:g} mm at the end.",
                  "",
                  "| controller | within the tolerance at the end | mean time to it (s) | largest final "
                  "distance (mm) |",
                  "|---|---|---|---|",
                  _summary_row("this policy", evaluation["policy"]),
                  _summary_row("the steering yardstick", evaluation["yardstick"]),
                  "",
                  f"![The tip's paths to the held-out targets, this policy's and the yardstick's: green "
                  f"reached, red missed]({TIP_PATHS_PNG})"]
    if info.get("notes"):
        lines += ["", notes_section, "", info["notes"].strip()]
    lines += ["", "## Limitations", "",
              "Judged in simulation only, on the nominal catheter; `msr real robustness POLICY` plays it "
              "on varied catheters beside the yardstick."]
    return "\n".join(lines)

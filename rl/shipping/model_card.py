"""The model card of a shipped policy (``MODEL_CARD.md``): what it does, how it was trained, how far
it goes against its target, every seed of its case, and its limits."""

from __future__ import annotations

from typing import Any

from ..cases.case import Case
from ..cases.training_tables import randomize_table
from .policy_files import RING_PNG
from .residual_card import residual_use_lines

__all__ = ["model_card", "seed_meets_target", "card_section", "replace_card_section", "NOTES_SECTION"]

#: The card's section rendered from ``policy.json``'s ``notes`` (their one home is policy.json).
NOTES_SECTION = "## Notes"


def seed_meets_target(evaluation: dict[str, Any], case: Case) -> bool | None:
    """A seed succeeds when its final actor or its best evaluated one reaches the target
    (``evaluation``: an entry of
    :func:`~elastica_magnetic_rl.shipping.policy_runs.evaluate_seeds`). ``None``, no verdict, for
    a case without a yardstick (whatever an older file stored) and where neither actor has one
    (not a 10 s evaluation)."""
    if not case.has_yardstick:
        return None
    verdicts = [e.get("meets_target") for e in (evaluation, evaluation.get("best") or {})]
    verdicts = [v for v in verdicts if isinstance(v, bool)]
    return any(verdicts) if verdicts else None


def model_card(info: dict[str, Any], summary: dict[str, Any] | None, case: Case) -> str:
    """The card (Markdown) of the policy described by ``info`` (its ``policy.json``), with the
    case's training ``summary`` (``summary.json``; ``None`` when not found): what it does and how
    to use it, its training, every seed of its case, its evaluation, notes and limitations. A
    tip-reach policy's card: :func:`~.tip_reach_card.tip_reach_card`."""
    if not case.field_actuated:
        from .tip_reach_card import tip_reach_card

        return tip_reach_card(info, case, NOTES_SECTION)
    lines = [*_use_section(info, case), *_training_section(info, summary, case),
             *_seeds_section(info, case), *_evaluation_section(info, case)]
    if info.get("notes"):
        lines += ["", NOTES_SECTION, "", info["notes"].strip()]
    lines += _limitations_section(case)
    return "\n".join(lines)


def _task_in_words(case: Case) -> str:
    """What the policy makes the robot do, for the card's first line."""
    task = case.task
    if task.kind == "crawl":
        return "crawl forward"
    if task.kind == "goto":
        return (f"go to a point on the floor {1e3 * task.distance:g} mm away in any direction and "
                f"stay within {1e3 * task.tolerance:g} mm of it")
    return f"reach {1e3 * task.target:+.1f} mm and stay there"


def _use_section(info: dict[str, Any], case: Case) -> list[str]:
    increment = 1e3 * case.actuation.max_increment
    what = _task_in_words(case)
    goto = case.task.kind == "goto"
    generate = (f"- `msr policy generate {info['name']} --target FORWARD,LEFT --duration "
                f"{case.task.episode_duration:g} --out DIR`: the field CSV (mT, 100 Hz) that sends "
                "the robot to that point (m from the start, in its start frame: +x ahead, LEFT to "
                "its left), from a zero field in the accurate physics, open loop; `--ring` runs a "
                "ring of 12 targets, `--waypoints F1,L1:F2,L2:...` a path and `--heading RAD` a "
                "heading to crawl along. Closed around a tracker: `run_closed_loop` (docs: Steering "
                "in 3D)."
                if goto else
                f"- `msr policy generate {info['name']} --duration 10 --out DIR`: field CSV (mT, "
                "100 Hz) from a zero field in the accurate physics, trajectory, figures, GIF.")
    return [
        f"# Model card: `{info['name']}`",
        "",
        f"TD3 actor that makes the robot `{case.robot.name}` {what} (case `{case.name}`), "
        f"magnetization `{info['magnetization']}`, field limit {1e3 * case.field_limit:g} mT.",
        "",
        *( [case.description, ""] if case.description else [] ),
        "## Use",
        "",
        generate,
        *_export_line(info),
        f"- Input: {info['architecture']['obs_dim']} float32 observations (layout and scales in "
        f"`policy.json`); output: {info['architecture']['act_dim']} actions in [-1, 1] "
        f"(dB_{', dB_'.join(case.actuation.axes)}), x {increment:g} mT = field increment per "
        "0.01 s.",
        *_steering_line(info),
        "",
    ]


def _export_line(info: dict[str, Any]) -> list[str]:
    """How the policy leaves the package: exported, or, for a residual policy (the case's yardstick
    corrected by the actor), played through the package, which composes the two."""
    return residual_use_lines(info) or [
        f"- `msr policy export {info['name']} --out DIR`: TorchScript + observation/action JSON."]


def _steering_line(info: dict[str, Any]) -> list[str]:
    """A steering actor's card says what it reads of the observation and how it answers."""
    if info["architecture"].get("actor_input", "observation") != "steering":
        return []
    return ["- The actor reads the steering state of the observation in the robot's own frame (the field "
            "along forward, up and left, the target's offset and distance, the clock) and its command "
            "along forward, up and left is turned into dB_x, dB_y, dB_z by the observed heading "
            "(`actor_input = \"steering\"`, docs/training.md)"
            + ("." if info["architecture"].get("residual") else "; the exported module does the same.")
            + (" It is mirror-symmetric: its command for a state's mirror image (z -> -z) is the mirror "
               "image of its command, and where the robot, the field and the target are symmetric it "
               "commands no left field (`actor_mirror = true`)."
               if info["architecture"].get("actor_mirror") else "")]


def _training_section(info: dict[str, Any], summary: dict[str, Any] | None, case: Case) -> list[str]:
    tr = info["training"]
    training_dt = case.robot.tables["physics"]["training"]["dt"]
    refine_physics = tr.get("refine_physics", "accurate")  # older files: refinements were accurate
    refine_dt = case.robot.tables["physics"][refine_physics]["dt"]
    lines = [
        "## Training",
        "",
        f"- seed: {tr['seed']}",
        f"- training steps (mass-scaled training physics, dt {training_dt:g} s): {tr['training_steps']}",
        f"- refinement steps ({refine_physics} physics, dt {refine_dt:g} s): {tr['refine_steps']}",
        f"- checkpoint: `{tr['source']}` (global step {tr['global_step']}"
        + ("; the best of the evaluations during training" if tr.get("best_evaluation") else "")
        + ")",
    ]
    if tr.get("precision"):  # what the run's updates ran in, which a seed's result depends on
        asked = (tr.get("config") or {}).get("precision")
        fell_back = ("" if asked in (None, tr["precision"])
                     else f" ({asked} asked; this CPU had no bfloat16 units)")
        lines.append(f"- recipe `{tr.get('recipe', 'unrecorded')}`, updates in {tr['precision']}{fell_back}")
    counted = _seed_count(summary, info)
    if counted is None:
        lines.append("- seeds that succeeded: unknown (no summary.json found next to the run)")
    elif counted[2] is not None:
        lines.append(f"- seeds that succeeded: {counted[0]} of {counted[1]} (final mean episode return >= "
                     f"{counted[2]:.0f}, half the yardstick's distance rate)")
    return lines


def _seed_count(summary: dict[str, Any] | None, info: dict[str, Any]) -> tuple[Any, int, Any] | None:
    """``(succeeded, total, threshold return)`` of the run's seeds: from the case's ``summary``,
    else as ``policy.json`` recorded them when the policy was shipped (a card written again from
    it); ``None`` when neither says."""
    if summary:
        return (summary.get("succeeded"), len(summary.get("seeds", [])),
                summary.get("success_threshold_return"))
    seeds = info.get("seeds") or {}
    if seeds.get("total"):
        return seeds.get("succeeded"), int(seeds["total"]), seeds.get("success_threshold_return")
    return None


def _seeds_section(info: dict[str, Any], case: Case) -> list[str]:
    evaluations = (info.get("seeds") or {}).get("evaluations")
    if not evaluations:
        return []
    meeting = info["seeds"].get("meeting_target") if case.has_yardstick else None
    best_actor = ("the best actor of their evaluations during training (`best.pt`, where the run "
                  "has one)")
    count = (f"{meeting} of {len(evaluations)} seeds reach the target ({case.target_label}) with "
             f"their final actor or with {best_actor}." if meeting is not None else
             f"Each seed's distance with its final actor and with {best_actor}; no seed is judged "
             f"(target: {case.target_label}).")
    lines = [
        "",
        "## Every seed of the case (accurate physics, field from zero)",
        "",
        count,
        "",
        "| seed | training steps | distance, final actor (mm) | best.pt: step, distance (mm) "
        "| meets the target |",
        "|---|---|---|---|---|",
    ]
    for e in evaluations:
        best = e.get("best")
        met = seed_meets_target(e, case)
        verdict = "n/a" if met is None else ("yes" if met else "no")
        for entry in (e, best):
            if entry and entry["diverged"]:
                verdict += f" (diverged: {entry['diverged']})"
        best_cell = (f"{best['global_step']}, {1e3 * best['mid_dx_m']:+.1f}" if best else "-")
        lines.append(f"| {e['seed']} | {e['global_step']} | {1e3 * e['mid_dx_m']:+.1f} "
                     f"(in {e['duration_s']:g} s) | {best_cell} | {verdict} |")
    return lines


def _evaluation_section(info: dict[str, Any], case: Case) -> list[str]:
    ev, target = info["evaluation"], case.target_label
    lines = ["", "## Evaluation (accurate physics, field from zero, deterministic)", ""]
    if not ev:
        return [*lines, f"- not measured (target: {target})"]
    met = case.meets_yardstick(ev["mid_dx_m"], ev.get("node_dx_m", ev["mid_dx_m"]),
                               ev["duration_s"], ev["diverged"])
    verdict = {True: "meets the target", False: "falls short of the target",
               None: "not comparable: the target is for 10 s" if case.has_yardstick
               else "not judged"}[met]
    lines.append(
        f"- middle of the robot moved {1e3 * ev['mid_dx_m']:+.1f} mm in {ev['duration_s']:g} s; "
        f"target: {target}"
        + (f" ({case.yardstick.source})" if case.yardstick.source else "") + f": {verdict}"
        + (f"; DIVERGED: {ev['diverged']}" if ev["diverged"] else "")
    )
    if ev.get("ring"):
        lines += _ring_lines(ev["ring"], ev.get("yardstick_ring"))
    if ev.get("reach"):
        r = ev["reach"]
        settle = "never settles" if r["settle_time_s"] is None else \
            f"settles within the tolerance after {r['settle_time_s']:.2f} s"
        lines.append(f"- final position error {1e3 * r['final_error_m']:+.2f} mm; {settle}")
    return lines


def _ring_lines(ring: dict[str, Any], yardstick: dict[str, Any] | None) -> list[str]:
    """The goto judge: the ring's success count and mean time to target, the steering yardstick's
    beside it, and one row per target."""
    def summary(r: dict[str, Any]) -> str:
        mean = r["mean_time_to_target_s"]
        return (f"{r['successes']} of {r['targets']} targets, mean time to target "
                + ("n/a" if mean is None else f"{mean:.1f} s"))

    lines = ["", f"Ring of {ring['targets']} targets ({ring['physics']} physics, "
             f"{ring['duration_s']:g} s each from a zero field): **{summary(ring)}**"
             + (f"; the steering yardstick: {summary(yardstick)}." if yardstick else "."), "",
             "| target (forward, left; mm) | final distance (mm) | time to target (s) | yardstick: "
             "final distance (mm), time (s) |", "|---|---|---|---|"]
    theirs = (yardstick or {}).get("targets_table") or [None] * len(ring["targets_table"])
    for row, other in zip(ring["targets_table"], theirs, strict=False):
        def cells(r: dict[str, Any] | None) -> str:
            if r is None:
                return "-"
            time = "never" if r["time_to_target_s"] is None else f"{r['time_to_target_s']:.2f}"
            mark = "" if r["success"] else " (missed)"
            return f"{1e3 * r['final_distance_to_target_m']:.2f}{mark} | {time}"
        lines.append(f"| {1e3 * row['target_forward_m']:+.1f}, {1e3 * row['target_left_m']:+.1f} "
                     f"| {cells(row)} | {cells(other).replace(' | ', ', ')} |")
    if yardstick:  # ship draws both rings' paths, seen from above
        lines += ["", f"![The middle's paths to the ring's targets seen from above, this policy's and the "
                      f"steering yardstick's: green reached, red missed]({RING_PNG})"]
    return lines


def _limitations_section(case: Case) -> list[str]:
    robot = case.robot.tables["robot"]
    size = (f"{1e3 * robot['length']:g} x {1e3 * robot['width']:g} x {1e3 * robot['thickness']:g} mm"
            if "thickness" in robot else
            f"{1e3 * robot['length']:g} mm long, radius {1e3 * robot['radius']:g} mm")
    ground = robot.get("ground") or {}
    design = (f"{size}, {robot['youngs_modulus'] / 1e3:g} kPa, "
              f"magnetization `{robot['magnetization']['kind']}`")
    friction = f"{ground.get('static_mu', float('nan')):g}/{ground.get('kinetic_mu', float('nan')):g}"
    randomized = randomize_table(case.training.randomize)
    trained_for = (
        f"- Trained on robots drawn per episode around one design ({design}; a flat ground with "
        f"friction {friction}), its values varied by these factors: "
        + ", ".join(f"{k} {v}" for k, v in randomized.items()) + "; other designs need retraining."
        if randomized else
        f"- Trained for one robot ({design}) on a flat ground with friction {friction}; other "
        "robots need retraining."
    )
    return [
        "",
        "## Limitations",
        "",
        "- Simulation only: the model's rotational over-damping makes the simulated robot respond "
        "~0.3 s slower than the real one (Yao et al. 2023, for their robot); check the waveform on "
        "hardware at low amplitude first.",
        trained_for,
        "",
    ]


def _section_bounds(lines: list[str], heading: str) -> tuple[int, int] | None:
    """First and one-past-last line of the ``heading`` section (up to the next "## " heading)."""
    if heading not in lines:
        return None
    start = lines.index(heading)
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
    return start, end


#: Levels a heading inside a section's body is moved down, so that it never ends the section
#: (a section ends at the next "## " heading): "## Bench" in a lab's notes is "#### Bench" there.
SUB_HEADING_SHIFT = "##"


def _demoted(body: str) -> str:
    return "\n".join(SUB_HEADING_SHIFT + line if line.startswith("#") else line
                     for line in body.split("\n"))


def _restored(body: str) -> str:
    shift = len(SUB_HEADING_SHIFT)
    return "\n".join(line[shift:] if line.startswith("#" * (shift + 1)) else line
                     for line in body.split("\n"))


def card_section(text: str, heading: str) -> str | None:
    """The body of a card's section ``heading`` (e.g. ``"## Notes"``), stripped, its headings as
    written (see :func:`replace_card_section`); None without it."""
    lines = text.split("\n")
    bounds = _section_bounds(lines, heading)
    return None if bounds is None else _restored("\n".join(lines[bounds[0] + 1:bounds[1]]).strip())


def replace_card_section(text: str, heading: str, body: str | None, before: str) -> str:
    """``text`` with its section ``heading`` holding ``body`` (Markdown): replaced where the card
    has the section, else inserted before the first heading starting with ``before`` (or at the
    end); ``body`` None or blank removes the section. Headings inside ``body`` are moved two levels
    down (``## Bench`` is ``#### Bench`` in the card), so none of them ends the section early: the
    next replacement takes all of it (:func:`card_section` gives them back as written)."""
    lines = text.split("\n")
    bounds = _section_bounds(lines, heading)
    section = [] if not (body and body.strip()) else [heading, "", _demoted(body.strip()), ""]
    if bounds is not None:
        lines = lines[:bounds[0]] + section + lines[bounds[1]:]
    elif section:
        anchor = next((i for i, line in enumerate(lines) if line.startswith(before)), None)
        if anchor is None:
            lines = [*text.rstrip("\n").split("\n"), "", *section]
        else:
            lines = lines[:anchor] + section + lines[anchor:]
    return "\n".join(lines).rstrip("\n") + "\n"

"""The steps of ``msr loop``, one function each, as library calls of the commands a user runs by
hand (``docs/own_robot.md``, ``docs/sim_to_real.md``): ``msr case check``, ``msr field baseline
--set-yardstick``, ``msr train --recipe fast``, ``msr policy export-seeds``' evaluations, ``msr
policy generate``, ``msr real robustness``, ``msr refine --physics training --randomize default``, ``msr
real robustness`` again and ``msr real firmware``.

Each step writes its own subfolder of the loop's folder through the package's result mechanisms
(a result folder replaced whole, or the run folders of train and refine) and returns a small
JSON-able summary that ``loop.json`` records and later steps read (paths in it are relative to
the loop's folder)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from elastica_magnetic.io import atomic_write_json, atomic_write_text, read_json
from elastica_magnetic.results import remove_tree, result_folder

from ..cases.case import Case, load_case
from .settings import LoopSettings
from .state import LoopError, LoopState

__all__ = ["STEP_FUNCTIONS", "LoopContext", "step_folder"]


@dataclass
class LoopContext:
    """What every step reads: the loop's ``folder``, the ``case`` of SPEC, the ``settings``, the
    ``state`` (earlier steps' summaries) and whether to show progress bars."""

    folder: Path
    case: Case
    settings: LoopSettings
    state: LoopState
    progress: bool

    def path(self, relative: str) -> Path:
        return self.folder / relative

    def relative(self, path: str | Path) -> str:
        """``path`` relative to the loop's folder (as summaries store it)."""
        return Path(path).resolve().relative_to(self.folder.resolve()).as_posix()


def step_folder(ctx: LoopContext, step: str) -> Path:
    return ctx.folder / step


# -- check ----------------------------------------------------------------------------------------


def check_step(ctx: LoopContext) -> dict[str, Any]:
    """``msr case check SPEC`` into ``check/`` (``check.json``, ``check.txt``); an error in the
    spec stops the loop (:class:`LoopError` with the check's lines)."""
    from elastica_magnetic.spec_check import format_check

    from ..cases.check import check_case

    check = check_case(ctx.case, sag=ctx.settings.check_sag)
    text = format_check(check)
    with result_folder(step_folder(ctx, "check"), kind="case check", subject=f"case {ctx.case.name}",
                       force=True) as folder:
        atomic_write_json(folder.path / "check.json", check.to_dict())
        atomic_write_text(folder.path / "check.txt", text + "\n")
    if check.has_errors:
        raise LoopError(f"the spec check found errors (check/check.txt):\n{text}")
    warnings = [line.strip() for line in text.splitlines() if line.strip().startswith("warning")]
    return {"text": text, "warnings": warnings, "check_txt": "check/check.txt"}


# -- yardstick ------------------------------------------------------------------------------------


def yardstick_step(ctx: LoopContext) -> dict[str, Any]:
    """``msr field baseline --case SPEC --set-yardstick`` into ``yardstick/``: the rotating-field sweep
    and the spec copy carrying the best distance as its yardstick (``<case>.toml`` in the loop's
    folder: named after the case, so the copy keeps its name), the spec the loop trains on."""
    from ..shipping.baseline_sweep import sweep_baseline, yardstick_spec

    s = ctx.settings
    result = sweep_baseline(ctx.case, s.yardstick_periods, s.yardstick_duration, s.yardstick_physics,
                            step_folder(ctx, "yardstick"), s.workers, ctx.progress, True, s.gif,
                            force=True)
    best = result["best"]
    stand_in = None
    if best["mid_dx_m"] <= 0.0:  # a yardstick must be a forward distance (the spec refuses others)
        moved = (f"the best rotating field moved {ctx.case.name} {1e3 * best['mid_dx_m']:+.3g} mm "
                 f"in {result['duration_s']:g} s of the {result['physics']} physics "
                 "(yardstick/sweep.csv): no forward distance to make a yardstick of")
        own = ctx.case.yardstick.distance_10s
        if not s.yardstick_is_the_definition() and own > 0.0:  # a smoke run: the spec's own stands in
            stand_in = (f"{moved}; the spec's own [yardstick] distance_10s ({1e3 * own:+.1f} mm) "
                        "stands in for this smoke run's")
            best = {**best, "mid_dx_m": own}
        elif not s.yardstick_is_the_definition():  # --quick or a shortened sweep: too short to judge
            raise LoopError(
                f"{moved}; this sweep ({len(s.yardstick_periods)} period(s), {s.yardstick_duration:g} s"
                f", {s.yardstick_physics} physics{', --quick' if s.quick else ''}) is too short to "
                "judge the robot: run the loop without --quick (the yardstick is swept over 10 s "
                "of the accurate physics), or see the full sweep with msr field baseline --case")
        else:
            raise LoopError(
                f"{moved}; check the magnetization and the field limit (msr case check), or train "
                "without the loop's yardstick (msr train --case)")
    spec_file = yardstick_spec(ctx.case, best, ctx.path(f"{ctx.case.name}.toml"), force=True,
                               physics=s.yardstick_physics, duration=s.yardstick_duration,
                               source=None if stand_in is None else
                               f"{ctx.case.yardstick.source} (standing in for a smoke run)")
    return {"distance_m": best["mid_dx_m"], "swept_m": result["best"]["mid_dx_m"],
            "period_s": best["period_s"],
            "clockwise": best["clockwise"], "period_achieved_s": best["period_achieved_s"],
            "physics": result["physics"], "duration_s": result["duration_s"],
            "is_the_yardstick": s.yardstick_is_the_definition(), "stand_in": stand_in,
            "runs": [{k: r[k] for k in ("period_s", "clockwise", "mid_dx_m", "diverged")}
                     for r in result["runs"]],
            "spec_file": ctx.relative(spec_file), "figure": "yardstick/sweep.png"}


def trained_case(ctx: LoopContext) -> Case:
    """The case the loop trains: the yardstick step's spec copy, with the spec's ``[training]`` as
    it is now (a loop whose training settings changed trains again on the sweep it has)."""
    copy = load_case(ctx.path(ctx.state.summary("yardstick")["spec_file"]))
    return dataclasses.replace(copy, training=ctx.case.training)


# -- train ----------------------------------------------------------------------------------------


def _resumable(case_dir: Path, seeds: int) -> bool | None:
    """Whether the seeds in ``case_dir`` can be resumed (every one has a checkpoint: ``True``),
    must start afresh (none or only some have one: ``False``, the partial folders removed), or
    there is nothing yet (``None``)."""
    from ..runfiles.rundir import CaseDir

    if not case_dir.exists():
        return None
    held = [CaseDir(case_dir).seed(s).checkpoint.exists() for s in range(seeds)]
    if all(held):
        return True
    remove_tree(case_dir)  # a seed killed before its first checkpoint: nothing to resume
    return False


def train_step(ctx: LoopContext) -> dict[str, Any]:
    """``msr train --case <yardstick spec> --recipe fast --seeds N`` into ``train/`` (resuming an
    interrupted training, as ``--resume`` does), then each seed's distance in the accurate physics (a
    smoke run's: the training physics)
    from a zero field (``msr policy export-seeds``' evaluation: the farther of its final actor and
    ``best.pt``); the best seed is the farthest."""
    from ..sweep.training import train_cases

    s = ctx.settings
    case = trained_case(ctx)
    out = step_folder(ctx, "train")
    resume = _resumable(out / case.name, s.seeds)
    try:
        summaries = train_cases([case], seeds=s.seeds, steps=s.steps, workers=s.workers, out=out,
                                resume=bool(resume), config_overrides=dict(s.train_overrides),
                                episode_duration=s.episode_duration, progress=ctx.progress,
                                recipe=s.recipe, stop_when=s.stop_when)
        summary = summaries[case.name]
    except ValueError as exc:  # killed after the training, before loop.json: nothing left to train
        if not (resume and str(exc).startswith("nothing to train")):
            raise
        summary = read_json(out / case.name / "summary.json")
    failed = [r for r in summary["seeds"] if r.get("error")]
    if failed:
        raise LoopError(f"training failed: {'; '.join(str(r['error']) for r in failed)}")
    return {"case": case.name, "resumed": bool(resume), "recipe": s.recipe,
            "steps": summary.get("steps"), "wall_s_training": summary.get("wall_s"),
            **_seed_distances(ctx, out / case.name)}


def _seed_distances(ctx: LoopContext, case_dir: Path) -> dict[str, Any]:
    """Each seed's distance (the farther of its two actors, the settings' evaluation physics and
    duration, field from zero) and the best seed."""
    from ..shipping.policy_runs import evaluate_seeds, prefer_best

    case = trained_case(ctx)
    seeds = []
    physics = ctx.settings.evaluation_physics
    for r in evaluate_seeds(case_dir, ctx.settings.evaluation_duration, ctx.progress, physics=physics):
        best = r["best"]
        chosen = best if prefer_best(case, r, best) else r
        seeds.append({"seed": r["seed"], "actor": "best.pt" if chosen is best else "final",
                      "global_step": chosen["global_step"], "distance_m": chosen["mid_dx_m"],
                      "diverged": chosen["diverged"], "meets_target": chosen.get("meets_target")})
    moving = [r for r in seeds if not r["diverged"]]
    if not moving:
        raise LoopError(f"every seed's actor diverged in the {physics} physics ({case_dir})")
    best = max(moving, key=lambda r: r["distance_m"])
    return {"seeds": seeds, "best_seed": best["seed"], "best_distance_m": best["distance_m"],
            "best_run_dir": ctx.relative(case_dir / f"seed{best['seed']}"),
            "evaluation": {"physics": physics, "duration_s": ctx.settings.evaluation_duration,
                           "initial_field": "zero"}}


# -- generate -------------------------------------------------------------------------------------


def generate_step(ctx: LoopContext) -> dict[str, Any]:
    """``msr policy generate <best seed> --checkpoint auto`` into ``generate/``: the farther actor's
    waveform (fields.csv, mT), the gait and field figures."""
    from ..shipping.generate import Pictures, generate

    s = ctx.settings
    train = ctx.state.summary("train")
    run = ctx.path(train["best_run_dir"])
    checkpoint = "auto"  # the farther actor, by the accurate evaluations the training step cached
    if s.evaluation_physics != "accurate":  # auto would run them again in the accurate physics
        best = next(r for r in train["seeds"] if r["seed"] == train["best_seed"])
        checkpoint = "best" if best["actor"] == "best.pt" else "final"
    result = generate(run, duration=s.evaluation_duration, out=step_folder(ctx, "generate"),
                      physics=s.evaluation_physics, progress=ctx.progress, pictures=Pictures(gif=s.gif),
                      checkpoint=checkpoint, force=True)
    yardstick = trained_case(ctx).yardstick.distance_10s
    # a ratio only of like with like: both 10 s of the accurate physics from a zero field
    comparable = (s.yardstick_is_the_definition() and result["physics"] == "accurate"
                  and abs(result["duration_s"] - 10.0) < 1e-9 and yardstick > 0)
    choice = result.get("actor_choice") or {}
    if checkpoint != "auto":  # chosen here, by the training step's evaluations
        actor = "best.pt" if checkpoint == "best" else "the final actor (checkpoint.pt)"
        choice = {"summary": f"{actor}: the farther of the seed's two in the training step's "
                             f"{s.evaluation_physics} evaluation"}
    return {"distance_m": result["mid_dx_m"], "physics": result["physics"],
            "duration_s": result["duration_s"], "diverged": result["diverged"],
            "yardstick_m": yardstick or None,
            "of_yardstick": result["mid_dx_m"] / yardstick if comparable else None,
            "meets_target": result.get("meets_target"),
            "actor": choice.get("summary") or str(result["policy"]),
            "policy": ctx.relative(result["policy"]),
            "fields_csv": "generate/fields.csv", "figures": _figures(ctx, "generate", (
                "filmstrip.png", "field_waveforms.png", "gait.gif"))}


def _figures(ctx: LoopContext, step: str, names: tuple[str, ...]) -> list[str]:
    return [f"{step}/{n}" for n in names if (step_folder(ctx, step) / n).is_file()]


# -- robustness -----------------------------------------------------------------------------------


def _robustness(ctx: LoopContext, step: str, source: Path, fields_csv: Path | None) -> dict[str, Any]:
    """``msr real robustness SOURCE [--fields CSV]`` into ``step/``: the default variation set, open
    and closed loop, in the settings' robustness physics."""
    from ..sim2real.robustness import plan_robustness, run_robustness, write_robustness

    s = ctx.settings
    plan = plan_robustness(source, fields_csv=fields_csv, corners=s.robustness_corners,
                           physics=s.robustness_physics, duration=s.robustness_duration,
                           progress=ctx.progress)
    report = run_robustness(plan, closed_loop=True, workers=s.workers, progress=ctx.progress)
    write_robustness(report, plan, step_folder(ctx, step), force=True)
    return {"report": f"{step}/robustness.json", "figure": f"{step}/robustness.png",
            "fields_csv": f"{step}/fields.csv", "physics": report["physics"],
            "duration_s": report["duration_s"], "summary": report["summary"],
            "yardstick_comparable": report["yardstick_comparable"],
            "yardstick_m": report["yardstick_m"],
            "variants": [{"label": v["label"], **{m: v[m]["distance_m"] for m in
                                                  ("open_loop", "closed_loop") if m in v}}
                         for v in report["variants"]]}


def robustness_step(ctx: LoopContext) -> dict[str, Any]:
    """The generated waveform and its actor on varied robots (``robustness/``)."""
    generated = ctx.state.summary("generate")
    return _robustness(ctx, "robustness", ctx.path(generated["policy"]),
                       ctx.path(generated["fields_csv"]))


# -- refine ---------------------------------------------------------------------------------------


def refine_step(ctx: LoopContext) -> dict[str, Any]:
    """``msr refine <best seed> --physics training --randomize default`` into ``refine/`` (the
    actor ``msr policy generate`` chose; an interrupted refinement is resumed)."""
    from ..runfiles.rundir import RunDir
    from ..sweep.refine import refine

    s = ctx.settings
    out = step_folder(ctx, "refine")
    if out.exists() and RunDir(out).checkpoint.exists():
        result = refine(ctx.path(ctx.state.summary("train")["best_run_dir"]), out=out, resume=True,
                        progress=ctx.progress)
    else:
        if out.exists():
            remove_tree(out)  # killed before its first checkpoint
        source = (ctx.path(ctx.state.summary("generate")["policy"]) if ctx.state.done("generate")
                  else ctx.path(ctx.state.summary("train")["best_run_dir"]))
        result = refine(source, steps=s.refine_steps, out=out, progress=ctx.progress,
                        episode_duration=s.refine_episode_duration, physics=s.refine_physics,
                        randomize=s.refine_randomize)
    return {"run_dir": "refine", "source": ctx.relative(result["source"]),
            "steps": result["steps"], "physics": result["physics"],
            "randomize": s.refine_randomize, "final_mean_return": result["final_mean_return"]}


def robustness_refined_step(ctx: LoopContext) -> dict[str, Any]:
    """The refined actor on varied robots (``robustness-refined/``), its waveform generated on
    the nominal robot as ``msr policy generate`` does."""
    return _robustness(ctx, "robustness-refined", step_folder(ctx, "refine"), None)


# -- firmware -------------------------------------------------------------------------------------


def firmware_step(ctx: LoopContext) -> dict[str, Any]:
    """``msr real firmware`` into ``firmware/``, with ``--calibration`` (default
    ``stm32/calibration/default.json``): the waveform the coils will play open loop, so of the
    learned and the refined policy's waveforms the one whose open-loop robustness is better
    (:func:`_waveform_to_play`); the generated one when no robustness step ran."""
    from elastica_magnetic.hardware.calibration import default_calibration_path
    from elastica_magnetic.hardware.export import export_firmware

    calibration = ctx.settings.calibration or default_calibration_path()
    which, waveform, why = _waveform_to_play(ctx)
    try:
        summary = export_firmware(ctx.path(waveform), calibration, step_folder(ctx, "firmware"),
                                  force=True)
    except ValueError as exc:
        if "--allow-clipping" not in str(exc):
            raise
        # msr loop plays no clipped waveform: a calibration that drives it, then this step again
        raise ValueError(str(exc).split(". Lower the field")[0] + ": give --calibration a calibration "
                         "whose current limits drive it and pass --redo firmware (the other steps are "
                         "kept)") from None
    return {"waveform": waveform, "which": which, "why": why,
            "calibration_file": str(calibration),
            **{k: summary[k] for k in ("rows", "calibration", "rows_clipped", "rows_slew_limited",
                                       "warnings", "code_min", "code_max")},
            "files": [ctx.relative(summary[k]) for k in ("calibration_header", "waveform_table",
                                                         "expected_dac_codes")]}


def _waveform_to_play(ctx: LoopContext) -> tuple[str, str, str]:
    """``(which, fields.csv relative to the loop's folder, why)``: of the learned (``robustness/``)
    and refined (``robustness-refined/``) policies' waveforms, the one that goes farther open loop
    on average over the varied robots (nominal included: the distance to expect of a robot made
    with the spec's fabrication errors), then the larger nominal one. A refinement is not better by
    being later (a short one can lose the gait), nor by a worst case or a 10th percentile that
    both policies stall at (a gait lost everywhere had won by a 10th percentile of +0.1 mm against
    -11.7 mm)."""
    measured = [(name, ctx.state.summary(step)) for name, step in
                (("learned", "robustness"), ("refined", "robustness-refined"))
                if ctx.state.done(step)]
    if not measured:
        return "generated", ctx.state.summary("generate")["fields_csv"], "no robustness step ran"

    def key(item: tuple[str, dict[str, Any]]) -> tuple[float, float]:
        return open_loop_mean(item[1]), item[1]["summary"]["open_loop"]["nominal_m"]

    name, best = max(measured, key=key)
    why = "; ".join(f"{n}: open loop mean {1e3 * key((n, m))[0]:+.3g} mm over the varied robots, nominal "
                    f"{1e3 * key((n, m))[1]:+.3g} mm" for n, m in measured)
    return name, best["fields_csv"], f"the larger open-loop mean over the varied robots, then nominal ({why})"


def open_loop_mean(robustness: dict[str, Any]) -> float:
    """The mean open-loop distance (m) of a robustness step's summary over its variants, the nominal
    robot included; a variant without a distance (diverged) counts as 0 m."""
    distances = [v.get("open_loop") for v in robustness.get("variants") or ()]
    if not distances:  # a record of an earlier release, without its variants
        return float(robustness["summary"]["open_loop"]["nominal_m"])
    return float(sum(d or 0.0 for d in distances) / len(distances))


#: Each step's function, by name (:data:`~elastica_magnetic_rl.loop.state.STEPS`).
STEP_FUNCTIONS: dict[str, Callable[[LoopContext], dict[str, Any]]] = {
    "check": check_step, "yardstick": yardstick_step, "train": train_step,
    "generate": generate_step, "robustness": robustness_step, "refine": refine_step,
    "robustness-refined": robustness_refined_step, "firmware": firmware_step,
}

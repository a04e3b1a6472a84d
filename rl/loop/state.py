"""The loop's resumable state, ``DIR/loop.json``: the spec and settings it runs with, and each
step's record (``done`` with its result summary and wall time, or ``skipped``), written
atomically after every step; and the plan of a (re-)run: which steps run, which are already done,
which are skipped, checked before any work."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from elastica_magnetic.io import DamagedFileError, atomic_write_json, display_path, read_json
from elastica_magnetic.locks import utc_now
from elastica_magnetic.result_markers import read_marker

__all__ = ["LOOP_FORMAT", "LOOP_JSON", "NEEDS", "READS", "STEPS", "LoopError", "LoopPlan", "LoopState",
           "parse_steps", "plan_loop"]

LOOP_JSON = "loop.json"
LOOP_FORMAT = "msr-loop-v1"
#: The status of a step that a run planned to start afresh and that has not started yet.
AFRESH = "to start afresh"
#: The steps, in order; each writes the subfolder of the loop's folder of its name.
STEPS = ("check", "yardstick", "train", "generate", "robustness", "refine", "robustness-refined",
         "firmware")
#: Settings and spec tables that act on some steps only (dotted as recorded; a table stands for
#: every key under it): changed, those steps run again (``--redo``) and the rest of the loop is
#: kept. The spec's ``[training]`` is read by the check (its warnings) and the training alone: the
#: yardstick sweep plays fields, it trains nothing.
STEP_SETTINGS = {"settings.calibration": ("firmware",), "settings.calibration_sha256": ("firmware",),
                 "spec.training": ("check", "train"),
                 "settings.steps": ("train",),
                 "settings.robustness_physics": ("robustness", "robustness-refined")}
#: Spec keys no step reads: the loop trains with its own recipe (``LoopSettings.recipe``), so a
#: changed ``[training] recipe`` changes no result (the loop says so when it starts).
UNREAD_SPEC_KEYS = ("spec.training.recipe",)
#: ... and in a smoke run (``--quick``), which trains its own step budget, ``[training] steps``.
UNREAD_WHEN_QUICK = ("spec.training.steps",)
#: The steps each step needs (their results are its input).
NEEDS: dict[str, tuple[str, ...]] = {
    "check": (), "yardstick": (), "train": ("yardstick",), "generate": ("train",),
    "robustness": ("generate",), "refine": ("train",), "robustness-refined": ("refine",),
    "firmware": ("generate",),
}

#: Steps a step reads when they ran, without needing them: the firmware plays the waveform the
#: robustness steps judge the better (with them skipped, the generated one), so one of them that
#: runs makes it run again after it; skipping them does not hold it back.
READS: dict[str, tuple[str, ...]] = {"firmware": ("robustness", "robustness-refined")}


class LoopError(ValueError):
    """A loop that cannot run as asked (a bad step name, a skipped step another one needs, a
    changed spec); the command line prints it as one line."""


def parse_steps(text: str | None, option: str) -> tuple[str, ...]:
    """``--skip`` / ``--redo`` ``STEP,...``: known step names (:data:`STEPS`)."""
    if not text:
        return ()
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in STEPS]
    if unknown or not names:
        raise LoopError(f"{option}: unknown step {', '.join(map(repr, unknown)) or repr(text)}; "
                        f"the steps are {', '.join(STEPS)}")
    return names


def dependents(step: str) -> list[str]:
    """``step`` and every step that needs it, directly or not, in order."""
    found = {step}
    for name in STEPS:  # NEEDS point backwards, so one pass in order suffices
        if any(need in found for need in NEEDS[name]):
            found.add(name)
    return [n for n in STEPS if n in found]


@dataclass
class LoopState:
    """``loop.json``: ``spec`` (the case's complete spec), ``settings``
    (:meth:`~elastica_magnetic_rl.loop.settings.LoopSettings.recorded`) and ``steps``: by name,
    ``{"status": "done" | "skipped", "summary": {...}, "wall_s": s, "finished_utc": ...}``."""

    path: Path
    case: str
    spec: dict[str, Any]
    settings: dict[str, Any]
    steps: dict[str, dict[str, Any]] = field(default_factory=dict)

    @classmethod
    def read(cls, folder: Path) -> LoopState | None:
        """The state in ``folder`` (``None`` when it has no ``loop.json``)."""
        path = folder / LOOP_JSON
        if not path.is_file():
            return None
        fix = ("restore it (e.g. from a backup): it records the finished steps, which a new "
               "loop would run again (the training included); or choose another --out")
        try:
            data = read_json(path, fix)
        except DamagedFileError as exc:
            raise LoopError(str(exc)) from None
        try:
            if data.get("format") != LOOP_FORMAT:
                raise LoopError(f"{display_path(path)}: format {data.get('format')!r} is not one this "
                                f"msr reads ({LOOP_FORMAT}): written by another version of msr? Run "
                                "the loop with that version, or choose another --out")
            return cls(path, data["case"], data["spec"], data["settings"], dict(data["steps"]))
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            raise LoopError(f"{display_path(path)}: not a loop state this msr can read ({exc}); "
                            "choose another --out") from None

    def write(self) -> None:
        atomic_write_json(self.path, {"format": LOOP_FORMAT, "case": self.case, "spec": self.spec,
                                      "settings": self.settings, "steps": self.steps})

    def done(self, step: str) -> bool:
        return self.steps.get(step, {}).get("status") == "done"

    def summary(self, step: str) -> dict[str, Any]:
        """A done step's result summary; :class:`LoopError` naming it when it is not done."""
        if not self.done(step):
            raise LoopError(f"step {step} has no result in {display_path(self.path)}")
        return self.steps[step]["summary"]

    def record(self, step: str, status: str, summary: dict[str, Any] | None = None,
               wall_s: float | None = None) -> None:
        """Record a step as ``done`` (its summary, wall time, and its folder's marker: which
        result it wrote) or ``skipped``; written at once."""
        self.steps[step] = {"status": status, "summary": summary or {}, "wall_s": wall_s,
                            "finished_utc": utc_now()}
        marker = read_marker(self.path.parent / step) if status == "done" else None
        if marker is not None:
            self.steps[step]["result"] = _result_of(marker)
        self.write()

    def replaced_steps(self) -> list[str]:
        """Done steps whose folder no longer holds the result the loop recorded (replaced by
        another command, e.g. ``msr policy generate --out LOOP/generate --force``, or removed)."""
        replaced = []
        for step in STEPS:
            recorded = self.steps.get(step, {}).get("result")
            if self.done(step) and recorded is not None:
                marker = read_marker(self.path.parent / step)
                if marker is None or _result_of(marker) != recorded:
                    replaced.append(step)
        return replaced


def _result_of(marker: dict[str, Any]) -> dict[str, Any]:
    """What identifies a step folder's result: the command, the subject and when it was written."""
    return {k: marker.get(k) for k in ("kind", "subject", "written_utc")}


@dataclass(frozen=True)
class LoopPlan:
    """What a run of the loop does with each step: ``run`` (in order), ``done`` (finished
    earlier: left as they are), ``skip`` (recorded as skipped)."""

    run: tuple[str, ...]
    done: tuple[str, ...]
    skip: tuple[str, ...]
    redo: tuple[str, ...]
    #: Steps run again on their earlier result instead of afresh (a training given more steps
    #: resumes its seeds; its folder is kept).
    extend: tuple[str, ...] = ()


def _own_steps(key: str) -> tuple[str, ...]:
    """The steps that alone read the changed ``key`` (:data:`STEP_SETTINGS`); () when others do."""
    for setting, steps in STEP_SETTINGS.items():
        if key == setting or key.startswith(setting + "."):
            return steps
    return ()


def _changed(old: dict[str, Any], new: dict[str, Any], prefix: str = "") -> list[str]:
    """The dotted keys whose values differ between two JSON-like dicts."""
    keys = []
    for key in sorted(set(old) | set(new)):
        a, b = old.get(key), new.get(key)
        if isinstance(a, dict) and isinstance(b, dict):
            keys += _changed(a, b, f"{prefix}{key}.")
        elif json.dumps(a, default=str) != json.dumps(b, default=str):
            keys.append(f"{prefix}{key}")
    return keys


def plan_loop(state: LoopState | None, spec: dict[str, Any], settings: dict[str, Any],
              skip: tuple[str, ...], redo: tuple[str, ...], force: bool) -> LoopPlan:
    """Check a (re-)run against the recorded ``state`` and plan it, before any work:

    - a changed spec or setting is refused, naming the keys, unless ``force`` (which then redoes
      every step), or unless it acts on some steps only and ``redo`` names them;
    - ``redo`` steps and every step that needs them run again, and so do the steps that read one
      that runs (:data:`READS`);
    - a step in ``skip`` is skipped; a step that would run but needs a skipped step (skipped now,
      or recorded as skipped) is refused, naming both."""
    both = sorted(set(skip) & set(redo))
    if both:
        raise LoopError(f"--skip and --redo both name {', '.join(both)}")
    extend: tuple[str, ...] = ()
    if state is not None:  # steps an interrupted run was to start afresh still are
        pending = [s for s in STEPS if state.steps.get(s, {}).get("status") == AFRESH and s not in redo]
        redo, extend = _redo_for_changes(state, spec, settings, (*redo, *pending), force)
    redone = _redone_steps(state, skip, redo)
    done = tuple(s for s in STEPS if state is not None and state.done(s) and s not in redone)
    skipped = tuple(s for s in STEPS if s in skip and s not in done)
    run = tuple(s for s in STEPS if s not in done and s not in skipped)
    _refuse_blocked(run, done)
    redone_steps = tuple(s for s in STEPS if s in redone and s not in skip)
    return LoopPlan(run, done, skipped, redone_steps, tuple(s for s in extend if s in redone_steps))


def _redone_steps(state: LoopState | None, skip: tuple[str, ...], redo: tuple[str, ...]) -> set[str]:
    """The ``redo`` steps, every step that needs one of them, and every step that reads (:data:`READS`)
    a step that runs now (redone, or neither done nor skipped) with the steps that need it."""
    redone: set[str] = set()
    for step in redo:
        redone.update(dependents(step))
    for step in STEPS:  # in order: a step that reads another one that runs now runs again after it
        if any(r in redone or (r not in skip and not (state is not None and state.done(r)))
               for r in READS.get(step, ())):
            redone.update(dependents(step))
    return redone


def _refuse_blocked(run: tuple[str, ...], done: tuple[str, ...]) -> None:
    """A :class:`LoopError` naming every step of ``run`` that a skipped step holds back, directly or
    through another, in one advice."""
    blocked, available = [], set(done)
    for step in run:  # in order: NEEDS point backwards, so a step's needs are settled before it
        if all(n in available for n in NEEDS[step]):
            available.add(step)
        else:
            blocked.append(step)
    if blocked:
        first = blocked[0]
        need = next(n for n in NEEDS[first] if n not in available)
        raise LoopError(f"step {first} needs step {need}, which is skipped (--skip {need}, or "
                        f"skipped by an earlier run and not done): skip {', '.join(blocked)} too, "
                        f"or run {need}")


def _redo_for_changes(state: LoopState, spec: dict[str, Any], settings: dict[str, Any],
                      redo: tuple[str, ...], force: bool) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """``(redo, extend)`` for a loop re-run with ``spec`` and ``settings``: unchanged, ``redo`` as
    given; more training steps alone, the training extended; a change some steps alone read, accepted
    when ``redo`` names them; any other change refused (:class:`LoopError`) unless ``force``, which
    redoes every step."""
    extend: tuple[str, ...] = ()
    unread = (*UNREAD_SPEC_KEYS, *(UNREAD_WHEN_QUICK if settings.get("quick") else ()))
    changed = [key for key in _changed({"spec": state.spec, "settings": state.settings},
                                       {"spec": spec, "settings": settings}) if key not in unread]
    others = [key for key in changed if key != "settings.steps"]
    if ("settings.steps" in changed and not force and all(_own_steps(key) for key in others)
            and not any("train" in _own_steps(key) for key in others)):
        # more steps alone: the training goes on (with other training settings it starts over)
        extend = _longer_training(state, settings.get("steps"))
        changed, redo = others, (*redo, *extend)
    own = [_own_steps(key) for key in changed]
    if changed and not force and all(own):
        needed = [step for step in STEPS if any(step in steps for steps in own) and state.done(step)]
        covered = set().union(*(dependents(step) for step in redo))
        if any(step not in covered for step in needed):  # a setting of some steps: those again
            # all of them named, so that following the advice once is enough
            uses = f"step {needed[0]} uses" if len(needed) == 1 else f"steps {', '.join(needed)} use"
            raise LoopError(
                f"--out {display_path(state.path.parent)}: changed: {', '.join(changed)}, which only "
                f"{uses}: pass --redo {','.join(needed)} to run {'it' if len(needed) == 1 else 'them'} "
                "again with it (the other steps kept), or --force to start the loop over")
        return redo, extend
    if changed and not force:
        _refuse_changed(state, settings, changed)
    return (STEPS if changed else redo), extend


def _refuse_changed(state: LoopState, settings: dict[str, Any], changed: list[str]) -> None:
    """The :class:`LoopError` for a loop re-run with another spec or settings (``changed`` keys):
    a changed ``--quick`` named alone, as the one option behind most settings."""
    folder = display_path(state.path.parent)
    was_quick, is_quick = state.settings.get("quick"), settings.get("quick")
    if was_quick != is_quick and was_quick is not None:
        raise LoopError(
            f"--out {folder}: holds a loop made {'with' if was_quick else 'without'} --quick: "
            f"{'add' if was_quick else 'leave out'} --quick to go on with it, or pass --force "
            f"to start it over {'without' if was_quick else 'with'} --quick")
    shown = ", ".join(changed[:6]) + (f" and {len(changed) - 6} more" if len(changed) > 6 else "")
    raise LoopError(f"--out {folder}: holds a loop of another spec or other settings (changed: {shown}); "
                    "pass --force to start it over with these, or choose another --out")


def _longer_training(state: LoopState, steps: int | None) -> tuple[str, ...]:
    """``("train",)`` when ``--steps`` asks more steps per seed than the loop's training has made
    (its seeds resume to the new budget, and the steps after it run again); a budget at or below
    it, or the case's default again, is a :class:`LoopError` (a training is not shortened)."""
    trained = state.settings.get("steps")
    if state.done("train"):
        trained = state.steps["train"].get("summary", {}).get("steps", trained)
    folder = display_path(state.path.parent)
    if steps is None or trained is None or steps <= trained:
        had = "the case's step budget" if trained is None else f"{trained} steps per seed"
        asked = "the case's step budget" if steps is None else f"--steps {steps}"
        raise LoopError(f"--out {folder}: its training has {had}, and {asked} would not train it "
                        "further (a loop's training is lengthened, never shortened): give --steps "
                        f"above {trained if trained is not None else 'the budget'}, or --force to start "
                        "the loop over")
    return ("train",)

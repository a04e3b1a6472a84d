"""The recipe comparison of docs/training.md as one resumable command (hours of training per case
and recipe: a benchmark, not a test).

For every case and recipe, the seeds ``0 .. --seeds - 1`` that
``rl/policies/<case>/seeds/<recipe>/seeds.json`` does not hold yet are trained (the paper's 1e5
steps, float32, the default layout) into ``--runs/<recipe>/<case>/seed<k>/``; a seed whose run
already has a checkpoint resumes from it, a finished one is only exported. Each case and recipe is
exported there as soon as its last seed is trained (``msr policy export-seeds``, which keeps the seeds
already in the folder), and the
recipes table across the cases is printed (``msr policy seeds``). Interrupted (Ctrl-C, a session's end), it
picks up where it stopped when run again with the same arguments.

    python benchmarks/recipe_campaign.py --dry-run                 # what is missing; nothing runs
    python benchmarks/recipe_campaign.py --cases m2-4mT --recipes paper pink
    python benchmarks/recipe_campaign.py --threads 1               # beside other work on the cores
    python benchmarks/recipe_campaign.py --cases m1-10mT --recipes pink --only 2 3  # a screen
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from elastica_magnetic_rl.cases.case import load_case  # noqa: E402
from elastica_magnetic_rl.cases.recipes import RECIPES  # noqa: E402
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR  # noqa: E402

PAPER_CASES = ("m1-4mT", "m2-4mT", "m1-10mT", "m2-10mT")


@dataclass
class Batch:
    """Seeds of one case and recipe to train in one call (consecutive, all fresh or all resumed)."""

    case: str
    recipe: str
    first_seed: int
    seeds: int
    resume: bool

    def describe(self) -> str:
        last = self.first_seed + self.seeds - 1
        seeds = f"seed {last}" if self.seeds == 1 else f"seeds {self.first_seed}-{last}"
        return f"{self.case} {self.recipe}: {'resume' if self.resume else 'train'} {seeds}"


def exported_seeds(policies: Path, case: str, recipe: str) -> set[int]:
    """The seeds in ``policies/<case>/seeds/<recipe>/seeds.json`` (none when it does not exist)."""
    path = policies / case / "seeds" / recipe / "seeds.json"
    if not path.is_file():
        return set()
    try:
        return {int(entry["seed"]) for entry in json.loads(path.read_text())}
    except (ValueError, KeyError, TypeError) as exc:
        raise SystemExit(f"{path}: not a seeds.json ({exc}); move it away or repair it") from None


def run_state(run_dir: Path, steps: int) -> str:
    """``"none"`` (no checkpoint), ``"partial"`` or ``"done"`` (``steps`` reached)."""
    from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint

    if not (run_dir / "checkpoint.pt").is_file():
        return "none"
    step = int(load_checkpoint(run_dir, with_buffer=False)["global_step"])
    return "done" if step >= steps else "partial"


def plan(steps: dict[str, int], recipes: list[str], seeds: int | list[int], runs: Path,
         policies: Path) -> tuple[list[Batch], list[tuple[str, str]]]:
    """The training calls, and the (case, recipe) pairs to export afterwards, for the cases
    ``steps`` names (each with its steps per seed); ``seeds``: a count (seeds ``0 .. seeds - 1``)
    or the seeds themselves (a screen)."""
    wanted = set(range(seeds)) if isinstance(seeds, int) else set(seeds)
    batches, exports = [], []
    for case in steps:
        for recipe in recipes:
            missing = sorted(wanted - exported_seeds(policies, case, recipe))
            if not missing:
                continue
            exports.append((case, recipe))
            todo = []
            for seed in missing:
                state = run_state(runs / recipe / case / f"seed{seed}", steps[case])
                if state != "done":
                    todo.append((seed, state == "partial"))
            for seed, resume in todo:  # consecutive seeds of one kind go in one call
                last = batches[-1] if batches else None
                if (last is not None and (last.case, last.recipe, last.resume) == (case, recipe, resume)
                        and last.first_seed + last.seeds == seed):
                    last.seeds += 1
                else:
                    batches.append(Batch(case, recipe, seed, 1, resume))
    return batches, exports


def schedule(batches: list[Batch], exports: list[tuple[str, str]]) -> list[Batch | tuple[str, str]]:
    """The order of the work: each (case, recipe) export right after its last training call (first
    if it has none), so a campaign cut short has exported every pair it finished."""
    order: list[Batch | tuple[str, str]] = []
    trained = {(b.case, b.recipe) for b in batches}
    order += [pair for pair in exports if pair not in trained]
    for i, batch in enumerate(batches):
        order.append(batch)
        pair = (batch.case, batch.recipe)
        if pair in exports and all((b.case, b.recipe) != pair for b in batches[i + 1:]):
            order.append(pair)
    return order


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=list(PAPER_CASES))
    ap.add_argument("--recipes", nargs="+", choices=tuple(RECIPES), default=list(RECIPES))
    ap.add_argument("--seeds", type=int, default=8, help="seeds per case and recipe (0 .. N-1)")
    ap.add_argument("--only", type=int, nargs="+", default=None, metavar="SEED",
                    help="train and export only these seeds (a screen; instead of --seeds)")
    ap.add_argument("--runs", type=Path, default=Path("runs/campaign"), help="training output")
    ap.add_argument("--policies", type=Path, default=POLICIES_DIR,
                    help="where the seed folders go (default: the package's rl/policies)")
    ap.add_argument("--threads", type=int, default=None, help="torch threads per worker")
    ap.add_argument("--workers", type=int, default=None, help="worker processes (default: the layout's)")
    ap.add_argument("--dry-run", action="store_true", help="print the plan, run nothing")
    args = ap.parse_args(argv)
    if args.seeds < 1:
        ap.error(f"--seeds must be >= 1, got {args.seeds}")
    if args.only is not None and min(args.only) < 0:
        ap.error(f"--only takes seeds >= 0, got {min(args.only)}")
    try:  # an unknown case or a bad spec fails here, before any work
        cases = [load_case(c) for c in args.cases]
    except ValueError as exc:
        ap.error(str(exc))
    batches, exports = plan({c.name: c.training.steps for c in cases}, args.recipes,
                            args.only if args.only is not None else args.seeds, args.runs,
                            args.policies)
    print(f"{len(batches)} training calls, {len(exports)} exports")
    for batch in batches:
        print(f"  {batch.describe()}")
    if args.dry_run:
        return 0

    from elastica_magnetic_rl.shipping.seed_export import export_seeds
    from elastica_magnetic_rl.sweep.training import train_cases

    for work in schedule(batches, exports):
        if isinstance(work, Batch):
            print(f"== {work.describe()}", flush=True)
            train_cases([work.case], seeds=work.seeds, seed_offset=work.first_seed,
                        out=args.runs / work.recipe, resume=work.resume, recipe=work.recipe,
                        config_overrides={"precision": "fp32"}, threads=args.threads,
                        workers=args.workers, progress=False)
            continue
        case, recipe = work
        dest = args.policies / case / "seeds" / recipe
        # the campaign refreshes its own seeds in place: replacing them is what it is for
        result = export_seeds(args.runs / recipe / case, dest, progress=False, workers=2,
                              force=True)
        print(f"== {case} {recipe}: {result['meeting_target']} of {result['total']} meet the target "
              f"({dest})", flush=True)
    from elastica_magnetic.cli import main as msr

    return msr(["seeds", *[c.name for c in cases], "--policies", str(args.policies)])


if __name__ == "__main__":
    raise SystemExit(main())

"""Which seed's waveform keeps its distance on the robot a lab actually built (issue: robust
waveforms): every committed seed of a case and recipe (``rl/policies/<case>/seeds/<recipe>/``)
has its waveform generated on the nominal robot (as ``msr policy generate``: accurate physics, field from
zero, 10 s) and played open loop, as the coils play it, on the default variation set
(``msr real robustness``: magnetization +-15 %, moduli +-20 %, friction +-25 %, density +-10 %; one at a
time and all corners; training physics, 10 s). The seed to ship as ``<case>-robust`` is the one
whose worst open-loop distance is largest among those that reach the yardstick on the nominal robot
(``seeds.json``'s ``meets_target``). Minutes per seed: a benchmark, not a test.

    python benchmarks/robust_selection.py --case m1-10mT --recipe robust --out out/robust-selection
    python benchmarks/robust_selection.py --case m1-10mT --recipe pink-ln --out out/rs --only 0 3

Writes ``OUT/<case>-<recipe>/seed<k>/`` (each seed's robustness report, figure and waveform) and
``OUT/<case>-<recipe>/selection.json`` (the table and the choice); prints the table.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR  # noqa: E402
from elastica_magnetic_rl.sim2real.robustness import (  # noqa: E402
    plan_robustness,
    run_robustness,
    write_robustness,
)


def score_seed(folder: Path, out: Path, workers: int | None, progress: bool) -> dict:
    """One seed's open-loop robustness summary (m), its report written to ``out``."""
    plan = plan_robustness(folder, progress=progress)
    report = run_robustness(plan, closed_loop=False, workers=workers, progress=progress)
    write_robustness(report, plan, out, force=True)
    return report["summary"]["open_loop"]


def choose_seed(rows: list[dict]) -> dict | None:
    """The row with the largest worst open-loop distance among those that reach the yardstick on
    the nominal robot (``meets_target`` true); ``None`` when none does."""
    eligible = [r for r in rows if r["meets_target"] is True and r["worst_m"] is not None]
    return max(eligible, key=lambda r: r["worst_m"]) if eligible else None


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--case", required=True)
    p.add_argument("--recipe", default="robust")
    p.add_argument("--policies", type=Path, default=POLICIES_DIR)
    p.add_argument("--only", type=int, nargs="*", default=None, help="these seeds only")
    p.add_argument("--workers", type=int, default=None)
    p.add_argument("--out", type=Path, default=Path("out/robust-selection"))
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args(argv)
    folder = args.policies / args.case / "seeds" / args.recipe
    entries = json.loads((folder / "seeds.json").read_text())
    out = args.out / f"{args.case}-{args.recipe}"
    rows = []
    for entry in entries:
        if args.only is not None and entry["seed"] not in args.only:
            continue
        summary = score_seed(folder / entry["actor"], out / entry["actor"], args.workers,
                             not args.no_progress)
        rows.append({"seed": entry["seed"], "nominal_accurate_m": entry["distance_10s_m"],
                     "meets_target": entry.get("meets_target"),
                     **{k: summary[k] for k in ("nominal_m", "worst_m", "worst_variant", "p10_m",
                                                "worst_fraction", "p10_fraction")}})
        print(f"seed {entry['seed']}: nominal (accurate) {entry['distance_10s_m'] * 1e3:+.1f} mm; "
              f"open loop over the default set (training physics): nominal "
              f"{summary['nominal_m'] * 1e3:+.1f}, worst {summary['worst_m'] * 1e3:+.1f} mm "
              f"({summary['worst_variant']}), 10th percentile {summary['p10_m'] * 1e3:+.1f} mm",
              flush=True)
    choice = choose_seed(rows)
    result = {"case": args.case, "recipe": args.recipe, "seeds": rows,
              "rule": "largest worst open-loop distance among the seeds that reach the yardstick "
                      "on the nominal robot (10 s, accurate physics, from zero)",
              "chosen_seed": None if choice is None else choice["seed"]}
    out.mkdir(parents=True, exist_ok=True)
    (out / "selection.json").write_text(json.dumps(result, indent=1))
    print(f"chosen: seed {result['chosen_seed']}" if choice else "no seed reaches the yardstick")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

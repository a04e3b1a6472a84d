"""``msr validate [CASE ...] [--quick] [--out DIR] [--json]``."""

from __future__ import annotations

import argparse
import importlib
import json
import sys
from pathlib import Path

from elastica_magnetic.cli import output_path

from .report import CaseResult, shipped_verdict, write_report

#: Case name -> module with ``run(out: Path, quick: bool) -> CaseResult``.
CASES = {
    "cantilever": "elastica_magnetic_validation.cantilever_case",
    "hu2018": "elastica_magnetic_validation.hu2018_case",
    "replay-yao2023": "elastica_magnetic_validation.replay_case",
    "spatial-fields": "elastica_magnetic_validation.spatial_fields_case",
    "magnet-cantilever": "elastica_magnetic_validation.magnet_cantilever_case",
    "gradient-beam": "elastica_magnetic_validation.gradient_beam_case",
}


#: Not a comparison with a reference but a check of claims: every shipped policy, re-run for 10 s
#: in the accurate physics (``--quick``: 0.3 s), reproduces its recorded distance (and its
#: waveform, on the machine that recorded it) and reaches its target
#: (:func:`elastica_magnetic_rl.shipping.shipped.verify_shipped`). Run only when named.
SHIPPED = "shipped"


#: Every file a validation report folder may hold (recognises reports written before the result
#: marker, e.g. the published one).
REPORT_FILES = ("report.md", "results.json", "cantilever.png", "hu2018.png", "replay-yao2023.png",
                "replay-yao2023_trajectory.csv", "magnet_cantilever.png", "gradient_beam.png")


def verify_all_shipped(quick: bool) -> list[dict]:
    """:func:`elastica_magnetic_rl.shipping.shipped.verify_shipped` of every shipped policy."""
    from elastica_magnetic_rl.shipping.shipped import shipped_names, verify_shipped

    results = []
    for name in shipped_names():
        print(f"[validate] shipped policy {name}{' (quick)' if quick else ''} ...", file=sys.stderr,
              flush=True)
        results.append(verify_shipped(name, duration=0.3 if quick else 10.0, quick=quick))
    return results


def available_cases() -> list[str]:
    """Cases whose module is present in this checkout."""
    found = []
    for name, module in CASES.items():
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as exc:
            if exc.name == module:
                continue
            raise
        found.append(name)
    return found


def run_cases(names: list[str], out: Path, quick: bool) -> list[CaseResult]:
    """Run the named cases, writing figures into ``out``."""
    results = []
    for name in names:
        module = importlib.import_module(CASES[name])
        print(f"[validate] {name}{' (quick)' if quick else ''} ...", file=sys.stderr, flush=True)
        results.append(module.run(out, quick=quick))
    return results


#: The report folder of ``msr validate`` without ``--out``.
DEFAULT_OUT = "out/validation"


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "validate",
        help="compare the simulator with independent references",
        description="Run validation cases, write a Markdown report with figures into --out, and "
        "exit non-zero when any case is outside its tolerance.",
    )
    p.add_argument("cases", nargs="*", metavar="CASE", help=f"cases to run (default: all of "
                   f"{', '.join(CASES)}); '{SHIPPED}': re-run every shipped policy for 10 s and "
                   "check its recorded distance and waveform (a few minutes each)")
    p.add_argument("--quick", action="store_true", help="reduced grid (for the test suite)")
    p.add_argument("--out", type=output_path, default=None,
                   help=f"report folder (default {DEFAULT_OUT}; '{SHIPPED}' alone writes no report)")
    p.add_argument("--force", action="store_true",
                   help="replace the report of an earlier `msr validate` in --out (another "
                   "command's result or files msr did not write are never replaced)")
    p.add_argument("--json", action="store_true", help="print every compared number as JSON")
    p.set_defaults(func=validate_command)


def validate_command(args: argparse.Namespace) -> int:
    from elastica_magnetic.cli import CommandError, print_notes
    from elastica_magnetic.results import check_result_folder, result_folder

    available = available_cases()
    names = [n for n in args.cases if n != SHIPPED] if args.cases else available
    if SHIPPED in args.cases and not names and (args.out is not None or args.force):
        given = "--out" if args.out is not None else "--force"
        raise CommandError(f"{given}: msr validate {SHIPPED} alone writes no report (it re-runs the shipped "
                           "policies against their files and prints the verdicts; --json prints them as "
                           f"JSON): drop {given}, or name validation cases beside {SHIPPED}")
    unknown = [n for n in names if n not in CASES]
    if unknown:
        raise CommandError(f"unknown case(s) {', '.join(unknown)}; choose from {', '.join(CASES)}")
    missing = [n for n in names if n not in available]
    if missing:
        raise CommandError(f"case(s) {', '.join(missing)} not implemented in this checkout")
    out_dir = args.out if args.out is not None else Path(DEFAULT_OUT)
    if SHIPPED in args.cases and names:  # the report's folder before the policies' re-runs (minutes)
        check_result_folder(out_dir, kind="validate", force=args.force, known_files=REPORT_FILES)
    shipped = verify_all_shipped(args.quick) if SHIPPED in args.cases else None
    if shipped is not None and not names:
        passed = all(r["passed"] for r in shipped)
        if args.json:
            print(json.dumps({"passed": passed, "shipped": shipped}, indent=2, default=str))
        else:
            for r in shipped:
                print(shipped_verdict(r))
        return 0 if passed else 1
    command = "msr validate " + " ".join(
        [*args.cases, *(["--quick"] if args.quick else []), "--out", str(out_dir)]
    )
    # The report folder is replaced whole, or left as it was on a failure or an interruption.
    with result_folder(out_dir, kind="validate", force=args.force,
                       known_files=REPORT_FILES) as out:
        print_notes(out.notes)
        results = run_cases(names, out.path, args.quick)
        for r in results:
            r.figures = [out.final_path(f) for f in r.figures]
        report = out.final_path(write_report(results, out.path, command, final=out.final, shipped=shipped))
    passed = all(r.passed for r in results) and all(r["passed"] for r in shipped or [])
    if args.json:
        print(json.dumps(
            {"passed": passed, "report": str(report), "cases": [r.as_dict() for r in results],
             **({"shipped": shipped} if shipped is not None else {})},
            indent=2, default=str,
        ))
    else:
        for r in results:
            failed = [c.quantity for c in r.comparisons if not c.passed]
            print(f"{r.name}: {'pass' if r.passed else 'FAIL'}"
                  + (f" ({'; '.join(failed)})" if failed else ""))
        for r in shipped or []:
            print(shipped_verdict(r))
        print(f"report: {report}")
    return 0 if passed else 1

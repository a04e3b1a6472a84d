"""The loop's report, ``report.md`` and ``report.html`` in the loop's folder, rewritten after every
step (a partial loop has a partial report): per step its wall time and result, with the figures
(the yardstick sweep, the gait, the waveform, the robustness per variant). The Markdown links the
figures in their step folders; the HTML is self-contained (figures embedded as data URIs)."""

from __future__ import annotations

import base64
import html
import math
import re
from pathlib import Path
from typing import Any

from elastica_magnetic.io import atomic_write_text

from .state import AFRESH, STEPS

__all__ = ["report_markdown", "write_report"]

_MIME = {".png": "image/png", ".gif": "image/gif"}
_TITLES = {"check": "Spec check", "yardstick": "Yardstick: the best rotating field",
           "train": "Training (recipe fast)", "generate": "The learned waveform",
           "robustness": "Robustness of the learned waveform",
           "refine": "Refinement on randomized robots",
           "robustness-refined": "Robustness of the refined policy", "firmware": "Firmware export"}
_MODES = {"open_loop": "open loop", "closed_loop": "closed loop"}


def _mm(distance: float | None) -> str:
    return "diverged" if distance is None else f"{1e3 * distance:+.3g} mm"


def _wall(seconds: float | None) -> str:
    if seconds is None:
        return "?"
    return f"{seconds:.1f} s" if seconds < 60 else f"{seconds / 60:.1f} min"


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(row) + " |" for row in rows] + [""]


def _check(s: dict[str, Any]) -> list[str]:
    return ["```text", s["text"], "```", ""]


def _yardstick(s: dict[str, Any]) -> list[str]:
    kind = "the yardstick" if s["is_the_yardstick"] else "a smoke run's stand-in, not a yardstick"
    if s.get("stand_in"):  # the sweep moved nothing forward: the spec's own yardstick stood in
        return [f"{s['stand_in']}; the loop trains on `{s['spec_file']}`, the spec carrying it.", ""]
    lines = [f"Best rotating field: **{_mm(s['distance_m'])}** in {s['duration_s']:g} s of the "
             f"{s['physics']} physics from a zero field, period {s['period_s']:g} s "
             f"{'clockwise' if s['clockwise'] else 'counter-clockwise'} ({kind}); the loop trains "
             f"on `{s['spec_file']}`, the spec carrying it.", ""]
    rows = [[f"{r['period_s']:g}", "clockwise" if r["clockwise"] else "counter-clockwise",
             "diverged" if r["diverged"] else _mm(r["mid_dx_m"])] for r in s["runs"]]
    return lines + _table(["period s", "direction", "distance"], rows) + [f"![sweep]({s['figure']})", ""]


def _train(s: dict[str, Any]) -> list[str]:
    e = s["evaluation"]
    lines = [f"{len(s['seeds'])} seeds{' (resumed)' if s['resumed'] else ''}; each seed's distance "
             f"in {e['duration_s']:g} s of the {e['physics']} physics from a {e['initial_field']} "
             f"field (the farther of its final actor and best.pt). Best: seed {s['best_seed']}, "
             f"**{_mm(s['best_distance_m'])}**.", ""]
    rows = [[str(r["seed"]), r["actor"], str(r["global_step"]),
             "diverged" if r["diverged"] else _mm(r["distance_m"]),
             {True: "yes", False: "no", None: "-"}[r.get("meets_target")]] for r in s["seeds"]]
    return lines + _table(["seed", "actor", "step", "distance", "meets target"], rows)


def _generate(s: dict[str, Any]) -> list[str]:
    ratio = s["of_yardstick"]
    if ratio is not None:
        against = f", **{ratio:.3g}x** the yardstick ({_mm(s['yardstick_m'])})"
    elif s["yardstick_m"]:
        against = (f" (not compared with the yardstick step's {_mm(s['yardstick_m'])}: not both "
                   "10 s of the accurate physics)")
    else:
        against = " (the case has no yardstick)"
    lines = [f"Actor: {s['actor']}.", "",
             f"Waveform distance: **{_mm(s['distance_m'])}** in {s['duration_s']:g} s of the "
             f"{s['physics']} physics from a zero field{against}.", ""]
    return lines + [f"![{Path(f).stem}]({f})" for f in s["figures"]] + [""]


def _robustness(s: dict[str, Any]) -> list[str]:
    comparable = s["yardstick_comparable"]
    lines = [f"Default variation set, {s['duration_s']:g} s of the **{s['physics']} physics** "
             + ("(comparable with the yardstick: 10 s, accurate physics)." if comparable else
                "(not comparable with the yardstick, a 10 s distance in the accurate physics: "
                "fractions below are of the nominal robot in the same physics)."), ""]
    modes = [m for m in _MODES if m in s["summary"]]
    rows = [[v["label"], *[_mm(v.get(m)) for m in modes]] for v in s["variants"]]
    lines += _table(["variant", *[f"{_MODES[m]} ({s['physics']})" for m in modes]], rows)
    for m in modes:
        x = s["summary"][m]
        frac = x["worst_fraction"] if comparable else x.get("worst_of_nominal")
        lines.append(f"- {_MODES[m]} ({s['physics']} physics): nominal {_mm(x['nominal_m'])}, worst "
                     f"{_mm(x['worst_m'])} ({x['worst_variant']}"
                     + (f", {100 * frac:.0f} % of {'the yardstick' if comparable else 'nominal'}"
                        if frac is not None and math.isfinite(frac) else "")
                     + f"), 10th percentile {_mm(x['p10_m'])}"
                     + (f", {len(x['diverged'])} diverged" if x["diverged"] else ""))
    return lines + ["", f"![robustness]({s['figure']})", ""]


def _refine(s: dict[str, Any]) -> list[str]:
    final = s.get("final_mean_return")
    measured = (f"final mean training return {final:.4g} (not a distance)"
                if final is not None and math.isfinite(final) else "no training episode ended")
    return [f"{s['steps']} steps in the {s['physics']} physics on robots randomized "
            f"({s['randomize']}) from `{s['source']}`; {measured}.", ""]


def _firmware(s: dict[str, Any]) -> list[str]:
    lines = [f"The {s['which']} waveform `{s['waveform']}`: {s['rows']} rows, calibration "
             f"{s['calibration']} (`{s['calibration_file']}`), DAC codes {s['code_min']} to "
             f"{s['code_max']}, {s['rows_clipped']} rows clipped, {s['rows_slew_limited']} "
             "slew-limited.", ""]
    if s.get("why"):
        lines += [f"Why this waveform: {s['why']}.", ""]
    return lines + [f"- `{f}`" for f in s["files"]] + [f"- warning: {w}" for w in s["warnings"]] + [""]


_SECTIONS = {"check": _check, "yardstick": _yardstick, "train": _train, "generate": _generate,
             "robustness": _robustness, "refine": _refine, "robustness-refined": _robustness,
             "firmware": _firmware}


def report_markdown(state: Any, quick: bool = False) -> str:
    """The report as Markdown (figures linked relative to the loop's folder)."""
    lines = [f"# msr loop: {state.case}", ""]
    if quick:
        lines += ["**A smoke run (`--quick`)**: tiny step budgets and durations; no distance "
                  "below means anything.", ""]
    done = [s for s in STEPS if state.steps.get(s, {}).get("status") == "done"]
    lines += [f"{len(done)} of {len(STEPS)} steps done.", ""]
    for number, step in enumerate(STEPS, start=1):
        record = state.steps.get(step)
        lines.append(f"## {number}. {_TITLES[step]} (`{step}/`)")
        lines.append("")
        if record is None:
            lines += ["Not run yet.", ""]
        elif record["status"] == AFRESH:
            lines += ["Not run yet (to run again from the start: a step it uses changed).", ""]
        elif record["status"] == "skipped":
            lines += ["Skipped (`--skip`).", ""]
        else:
            lines += [f"Wall time: {_wall(record['wall_s'])}.", "", *_SECTIONS[step](record["summary"])]
    return "\n".join(lines)


def _data_uri(folder: Path, relative: str) -> str:
    path = folder / relative
    mime = _MIME.get(path.suffix.lower())
    if mime is None or not path.is_file():
        return html.escape(relative)
    return f"data:{mime};base64,{base64.b64encode(path.read_bytes()).decode('ascii')}"


def _html(markdown: str, folder: Path) -> str:
    """A small Markdown-to-HTML conversion of :func:`report_markdown`'s subset (headings,
    paragraphs, lists, tables, code blocks, images embedded, bold and code spans)."""
    out, table, code = [], [], False

    def inline(text: str) -> str:
        text = html.escape(text)
        text = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", text)
        return re.sub(r"`(.+?)`", r"<code>\1</code>", text)

    def flush_table() -> None:
        if table:
            rows = [[c.strip() for c in r.strip("|").split("|")] for r in table if "---" not in r]
            out.append("<table>" + "".join(
                "<tr>" + "".join(f"<{'th' if i == 0 else 'td'}>{inline(c)}</{'th' if i == 0 else 'td'}>"
                                 for c in row) + "</tr>" for i, row in enumerate(rows)) + "</table>")
            table.clear()

    for line in markdown.splitlines():
        if line.startswith("```"):
            out.append("</pre>" if code else "<pre>")
            code = not code
        elif code:
            out.append(html.escape(line))
        elif line.startswith("|"):
            table.append(line)
            continue
        elif line.startswith("!["):
            alt, src = re.match(r"!\[(.*)\]\((.*)\)", line).groups()
            out.append(f'<figure><img alt="{html.escape(alt)}" src="{_data_uri(folder, src)}">'
                       f"<figcaption>{html.escape(src)}</figcaption></figure>")
        elif line.startswith("#"):
            level = len(line) - len(line.lstrip("#"))
            out.append(f"<h{level}>{inline(line[level:].strip())}</h{level}>")
        elif line.startswith("- "):
            out.append(f"<li>{inline(line[2:])}</li>")
        elif line.strip():
            out.append(f"<p>{inline(line)}</p>")
        flush_table()
    flush_table()
    body = "\n".join(out).replace("</li>\n<li>", "</li><li>")
    body = re.sub(r"((?:<li>.*?</li>)+)", r"<ul>\1</ul>", body)
    style = ("body{font-family:sans-serif;max-width:60em;margin:2em auto;padding:0 1em}"
             "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #ccc;"
             "padding:2px 8px;text-align:right}td:first-child,th:first-child{text-align:left}"
             "img{max-width:100%}pre{background:#f4f4f4;padding:0.5em;white-space:pre-wrap}"
             "figcaption{color:#666;font-size:small}")
    return ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>msr loop report</title>"
            f"<style>{style}</style></head><body>\n" + body + "\n</body></html>\n")


def write_report(ctx: Any) -> tuple[Path, Path]:
    """Write ``report.md`` and ``report.html`` into the loop's folder (atomically); their paths."""
    markdown = report_markdown(ctx.state, ctx.settings.quick)
    md = atomic_write_text(ctx.folder / "report.md", markdown + "\n")
    page = atomic_write_text(ctx.folder / "report.html", _html(markdown, ctx.folder))
    return md, page

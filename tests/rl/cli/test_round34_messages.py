"""Round 34 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

import shutil
from pathlib import Path

from elastica_magnetic.cli import main as msr

REPO = Path(__file__).resolve().parents[3]


def test_robustness_refuses_its_fields_inside_what_force_replaces(tmp_path, capsys):
    """D1: ``msr real robustness m1-4mT --fields R/fields.csv --out R --force`` deleted the waveform
    it was given with the old result (and wrote a cut copy in its place); only the positional
    input was checked. ``--fields`` (and a ``--case`` spec file) inside ``--out`` are refused."""
    out = tmp_path / "R"
    out.mkdir()
    fields = out / "fields.csv"
    shutil.copy(REPO / "rl" / "policies" / "m1-4mT" / "fields.csv", fields)
    kept = fields.read_bytes()
    assert msr(["real", "robustness", "m1-4mT", "--fields", str(fields), "--out", str(out), "--force",
                "--open-loop-only", "--duration", "0.2", "--no-corners"]) == 2
    err = capsys.readouterr().err
    assert f"--fields {fields}: lies in --out {out}" in err and "copy it elsewhere first" in err
    assert fields.read_bytes() == kept and sorted(p.name for p in out.iterdir()) == ["fields.csv"]


def test_ship_refuses_notes_from_the_policy_it_replaces(trained, tmp_path, capsys):
    """S2: ``msr policy ship RUN --name p1 --out P --force --notes P/p1/MODEL_CARD.md`` took the
    policy's own card as its notes: the card nested inside itself with every ship. Refused as
    ``msr policy notes --file`` refuses it, before any evaluation, the policy left as it was."""
    seed0 = str(trained / "m1-4mT" / "seed0")
    out = tmp_path / "P"
    base = ["policy", "ship", seed0, "--name", "p1", "--out", str(out), "--no-measure", "--checkpoint",
            "final"]
    assert msr(base) == 0
    card = out / "p1" / "MODEL_CARD.md"
    before = {p.name: p.read_bytes() for p in (out / "p1").iterdir() if p.is_file()}
    capsys.readouterr()
    assert msr([*base, "--force", "--notes", str(card)]) == 2
    err = capsys.readouterr().err
    assert f"--notes {card}: is the policy's own MODEL_CARD.md" in err, err
    assert {p.name: p.read_bytes() for p in (out / "p1").iterdir() if p.is_file()} == before

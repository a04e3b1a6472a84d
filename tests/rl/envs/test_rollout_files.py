"""A damaged ``rollout.npz`` (rl/envs/rollout.py) is named, never a traceback or a silent plot
(round 4 of issue 48: a file cut short was a ``BadZipFile`` traceback in ``msr policy figures``, one
lacking ``positions`` a ``KeyError``, one whose fields were NaN was plotted without a word)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from elastica_magnetic_rl.envs.rollout import ROLLOUT_NPZ, Rollout

from elastica_magnetic.cli import main
from elastica_magnetic.io import DamagedFileError


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    out = tmp_path_factory.mktemp("gen") / "gen"
    assert main(["policy", "generate", "m1-4mT", "--duration", "0.05", "--physics", "training",
                 "--no-figures", "--no-gif", "--no-progress", "--out", str(out)]) == 0
    return out


def _edited(path, **changes):
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    for key, value in changes.items():
        if value is None:
            del arrays[key]
        else:
            arrays[key] = value
    np.savez(path, **arrays)


@pytest.mark.parametrize(("damage", "message"), [
    ("cut", r"not a readable \.npz"),
    ("no positions", r"lacks positions"),
    ("nan fields", r"fields holds NaN or infinite values"),
    ("short fields", r"fields has shape \(3, 3\), expected"),
])
def test_a_damaged_rollout_is_named(damage, message, generated, tmp_path, capsys):
    folder = tmp_path / "gen"
    shutil.copytree(generated, folder)
    path = folder / ROLLOUT_NPZ
    if damage == "cut":
        path.write_bytes(path.read_bytes()[:3000])
    elif damage == "no positions":
        _edited(path, positions=None)
    elif damage == "nan fields":
        with np.load(path) as data:
            _edited(path, fields=np.full_like(data["fields"], np.nan))
    else:
        _edited(path, fields=np.zeros((3, 3)))
    with pytest.raises(DamagedFileError, match=r"rollout\.npz: damaged rollout \(" + message):
        Rollout.load(folder)
    assert main(["policy", "figures", str(folder), "--out", str(tmp_path / "figures")]) == 2
    err = capsys.readouterr().err
    assert "rollout.npz: damaged rollout" in err and "Traceback" not in err, err
    assert not (tmp_path / "figures").exists()


def test_an_intact_rollout_reads_back(generated):
    rollout = Rollout.load(generated)
    assert rollout.n_steps == 5 and rollout.positions.shape[0] == 6

"""No function of the packages takes more than about ten parameters (docs/architecture.md,
"Settings of a long call"): a longer call takes a settings dataclass. The exceptions are listed
here, each with its reason; a new one fails this test until it is either split or listed."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The most parameters a function (``self``/``cls`` not counted) may take.
MOST = 10
#: Longer signatures, by "file:function", and why.
EXCEPTIONS = {
    # numba kernels: the block's arrays one by one, as numba compiles them (PyElastica's kernels too)
    "elastica_magnetic/_batch_kernels.py:block_forcing": "numba kernel",
    "elastica_magnetic/_batch_kernels.py:ground_contact": "numba kernel",
    "elastica_magnetic/_implicit_friction.py:implicit_coulomb_friction": "numba kernel",
    "elastica_magnetic/_robot_forcing_kernels.py:moved_dipoles_forcing": "numba kernel",
    "elastica_magnetic/_robot_forcing_kernels.py:coil_loops_forcing": "numba kernel",
    "elastica_magnetic/_robot_forcing_kernels.py:dipole_paths_forcing": "numba kernel",
    "elastica_magnetic/_spatial_kernels.py:moved_map_field_into": "numba kernel",
    "elastica_magnetic/_spatial_kernels.py:moved_map_field": "numba kernel",
    "elastica_magnetic/_robot_forcing_kernels.py:moved_maps_forcing": "numba kernel",
    "elastica_magnetic/_spatial_kernels.py:posed_grid_field": "numba kernel",
    "elastica_magnetic/_robot_forcing_kernels.py:fixed_maps_forcing": "numba kernel",
    # a Gymnasium environment is made by gymnasium.make(id, **kwargs): its options are keywords
    "rl/envs/vector_env.py:__init__": "gymnasium.make keywords",
    "rl/envs/env.py:__init__": "gymnasium.make keywords",
    # the physical values of a band, as PyElastica's CosseratRod.straight_rod takes them
    "elastica_magnetic/section.py:rectangular_band_rod": "mirrors CosseratRod.straight_rod",
}


def _long_signatures() -> dict[str, int]:
    found = {}
    for package in ("elastica_magnetic", "rl"):
        for path in sorted((ROOT / package).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                    continue
                a = node.args
                names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
                count = len(names) + (a.vararg is not None) + (a.kwarg is not None)
                count -= bool(names) and names[0] in ("self", "cls")
                if count > MOST:
                    found[f"{path.relative_to(ROOT).as_posix()}:{node.name}"] = count
    return found


def test_no_function_takes_more_than_about_ten_parameters():
    long = _long_signatures()
    assert set(long) - set(EXCEPTIONS) == set(), f"split these or list them with a reason: {long}"
    assert set(EXCEPTIONS) <= set(long), "an exception no longer needed: remove it from the list"

"""The layering of the project, read from the source: the physics package imports neither the
learning nor the validation package, and no two modules of a package import each other (directly
or through others). The command line modules (``cli``) dispatch by name and are left out."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Installed package name -> its folder in the repository (setup.cfg's package_dir).
PACKAGES = {"elastica_magnetic": "elastica_magnetic", "elastica_magnetic_rl": "rl",
            "elastica_magnetic_validation": "validation"}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    parts[0] = {folder: name for name, folder in PACKAGES.items()}[parts[0]]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Project modules imported anywhere in ``path`` (top level or inside functions)."""
    module = _module_name(path)
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                prefix = ".".join(base + ([node.module] if node.module else []))
            else:
                prefix = node.module or ""
            names = [prefix] + [f"{prefix}.{a.name}" for a in node.names]
        else:
            continue
        found |= {n for n in names if n.split(".")[0] in PACKAGES}
    return found


def _graph() -> dict[str, set[str]]:
    modules = {_module_name(p): p for folder in PACKAGES.values() for p in (ROOT / folder).rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        targets = set()
        for imported in _imports(path):
            while imported and imported not in modules:  # `from .x import f` names x.f
                imported = imported.rsplit(".", 1)[0] if "." in imported else ""
            if imported and imported != name:
                targets.add(imported)
        graph[name] = targets
    return graph


def test_the_physics_package_imports_no_learning_or_validation():
    graph = _graph()
    physics = "elastica_magnetic"
    upward = {(m, t) for m, targets in graph.items() if m.split(".")[0] == physics
              for t in targets if t.split(".")[0] != physics and not m.endswith(".cli")}
    assert not upward, sorted(upward)


#: The learning package's subpackages, bottom layer first: each imports only itself and the layers
#: before it (docs/architecture.md). Its top-level modules (``__init__``) import none of them.
RL_LAYERS = ("runfiles", "td3", "cases", "envs", "runner", "sweep", "reports", "shipping", "sim2real",
             "cli", "loop", "design")


def test_the_learning_subpackages_import_only_lower_layers():
    graph = _graph()
    rl = "elastica_magnetic_rl"
    folders = {p.name for p in (ROOT / PACKAGES[rl]).iterdir() if (p / "__init__.py").is_file()}
    assert folders == set(RL_LAYERS), f"subpackages {sorted(folders)} against the layers {RL_LAYERS}"

    def layer(module: str) -> int | None:
        parts = module.split(".")
        return RL_LAYERS.index(parts[1]) if parts[0] == rl and len(parts) > 1 and parts[1] in RL_LAYERS \
            else None

    upward = sorted(f"{m} -> {t}" for m, targets in graph.items() if layer(m) is not None
                    for t in targets if layer(t) is not None and layer(t) > layer(m))
    assert not upward, upward


def test_no_import_cycles_between_modules():
    graph = {m: {t for t in ts if not t.endswith(".cli")} for m, ts in _graph().items()
             if not m.endswith(".cli")}
    for package in PACKAGES:
        # a module importing its own package's __init__ is not a cycle of concepts
        graph[package] = set()
    state: dict[str, int] = {}

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                raise AssertionError(" -> ".join([*path[path.index(nxt):], nxt]))
            if nxt not in state:
                visit(nxt, [*path, nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])


def test_no_module_imports_the_folder_names():
    """``rl`` and ``validation`` are folders of the repository, installed as ``elastica_magnetic_rl``
    and ``elastica_magnetic_validation``: importing them by folder name would load a second copy."""
    bare = []
    for folder in (*PACKAGES.values(), "tests", "benchmarks", "scripts", "docs"):
        for path in (ROOT / folder).rglob("*.py"):
            if "_build" in path.parts:
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                         [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level
                         else [])
                bare += [f"{path.relative_to(ROOT)}: {n}" for n in names
                         if n.split(".")[0] in ("rl", "validation")]
    assert not bare, bare


def test_installation_puts_no_generic_names_on_the_path(tmp_path):
    """Outside the repository, ``rl`` and ``validation`` are not importable; the package's own names are."""
    import subprocess
    import sys

    code = ("import importlib.util as u; "
            "print([n for n in ('rl', 'validation') if u.find_spec(n)], "
            "[n for n in ('elastica_magnetic_rl', 'elastica_magnetic_validation') if not u.find_spec(n)])")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                         check=True, env={"PATH": "/usr/bin:/bin"}).stdout.strip()
    assert out == "[] []", out


def test_the_validation_reference_solver_depends_on_numpy_and_scipy_only():
    """The boundary-value reference must be independent of the simulator it checks: its modules
    import the standard library, numpy, scipy and each other, nothing else (not PyElastica, not
    this project's physics)."""
    import sys

    reference = {"elastica_bvp", "bvp_model", "bvp_problems", "bvp_magnet"}
    for name in sorted(reference):
        path = ROOT / "validation" / f"{name}.py"
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                tops = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    assert node.module in reference, f"{path}: imports .{node.module}"
                    continue
                tops = [(node.module or "").split(".")[0]]
            else:
                continue
            for top in tops:
                assert top in {"numpy", "scipy", "__future__"} or top in sys.stdlib_module_names, \
                    f"{path}: imports {top}"


def test_benchmarks_import_public_names_only():
    """The benchmarks are users of the packages: no private name (``_x``) and no private module
    (``elastica_magnetic._batch_kernels``) of them is imported."""
    private = []
    for path in sorted((ROOT / "benchmarks").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and not node.level and node.module:
                modules, names = [node.module], [a.name for a in node.names]
            elif isinstance(node, ast.Import):
                modules, names = [a.name for a in node.names], []
            else:
                continue
            for module in modules:
                if module.split(".")[0] not in PACKAGES:
                    continue
                if any(part.startswith("_") for part in module.split(".")) or \
                        any(name.startswith("_") for name in names):
                    private.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not private, private

"""The package's layering (docs/architecture.md): imports point down, never in a circle.

Every import of every module counts, at module level or inside a function: a function-level
import still ties the two modules together.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

PACKAGE_DIR = Path(__file__).resolve().parents[1] / "robust_ismpc"

#: Layers from the bottom up: a module may import its own layer and the layers below it.
LAYERS = (
    ("base", ("robust_ismpc", "robust_ismpc.exceptions", "robust_ismpc.validation", "robust_ismpc.io",
              "robust_ismpc.extras")),
    ("core", ("robust_ismpc.core",)),
    ("estimation", ("robust_ismpc.estimation",)),
    ("control", ("robust_ismpc.control",)),
    ("robots", ("robust_ismpc.robots",)),
    ("sim", ("robust_ismpc.sim",)),
    ("runs", ("robust_ismpc.runs",)),
    ("plotting", ("robust_ismpc.plotting",)),
    ("experiments", ("robust_ismpc.experiments",)),
    ("cli", ("robust_ismpc.cli",)),
)

#: Third-party packages each layer may import at module level (the standard library is free).
#: The core, estimation and control run with numpy, scipy and daqp alone.
THIRD_PARTY = {
    "base": {"numpy"},
    "core": {"numpy", "scipy", "daqp"},
    "estimation": {"numpy", "scipy"},
    "control": {"numpy", "scipy"},
    "robots": {"numpy"},
    "sim": {"numpy", "scipy", "daqp", "mujoco", "mink", "imageio", "PIL"},
    "runs": {"numpy"},
    "plotting": {"numpy"},
    "experiments": {"numpy", "scipy"},
    "cli": {"numpy"},
}


def layer_of(module: str) -> tuple[int, str]:
    """(rank, name) of the layer holding ``module``, the longest matching prefix."""
    best = None
    for rank, (name, prefixes) in enumerate(LAYERS):
        for prefix in prefixes:
            if module == prefix or module.startswith(prefix + ".") and prefix != "robust_ismpc":
                if best is None or len(prefix) > best[2]:
                    best = (rank, name, len(prefix))
    if best is None:
        raise AssertionError(f"module {module} is in no layer; add it to LAYERS and docs/architecture.md")
    return best[0], best[1]


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imports_of(path: Path, root: Path) -> list[tuple[str, int, bool]]:
    """(imported module, line, at module level) for every import in ``path``; relative imports
    resolved, ``from package import name`` counted as the package and, if ``name`` is a
    submodule, as that submodule."""
    module = module_name(path, root)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    tree = ast.parse(path.read_text())
    top_level = {id(node) for node in tree.body}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(alias.name, node.lineno, id(node) in top_level) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            found.append((target, node.lineno, id(node) in top_level))
            for alias in node.names:
                candidate = f"{target}.{alias.name}"
                if (root.parent / Path(*candidate.split("."))).with_suffix(".py").exists() or (
                    root.parent / Path(*candidate.split(".")) / "__init__.py"
                ).exists():
                    found.append((candidate, node.lineno, id(node) in top_level))
    return found


def import_graph(root: Path) -> dict[str, list[tuple[str, int, bool]]]:
    """Module -> its imports (see :func:`imports_of`) for every module under ``root``."""
    return {module_name(p, root): imports_of(p, root) for p in sorted(root.rglob("*.py"))}


def layering_violations(root: Path) -> list[str]:
    """One line per import that points up a layer, or to a third-party package its layer may not
    import at module level."""
    package = root.name
    problems = []
    for module, imports in import_graph(root).items():
        rank, layer = layer_of(module)
        for target, line, top in imports:
            top_name = target.split(".")[0]
            if top_name == package:
                if target == package:
                    continue
                target_rank, target_layer = layer_of(target)
                if target_rank > rank:
                    problems.append(f"{module}:{line} ({layer}) imports {target} ({target_layer}), a higher layer")
            elif top and top_name not in sys.stdlib_module_names and top_name not in THIRD_PARTY[layer]:
                problems.append(f"{module}:{line} ({layer}) imports {top_name} at module level")
    return problems


def import_cycles(root: Path) -> list[list[str]]:
    """Strongly connected components of more than one module in the import graph."""
    graph = {m: sorted({t for t, _, _ in imps if in_graph(t, root)}) for m, imps in import_graph(root).items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return components


def in_graph(target: str, root: Path) -> bool:
    parts = target.split(".")
    if parts[0] != root.name:
        return False
    path = root.parent / Path(*parts)
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


def test_every_import_points_down_the_layers():
    assert layering_violations(PACKAGE_DIR) == []


def test_no_import_cycle():
    assert import_cycles(PACKAGE_DIR) == []


def test_reading_a_robot_file_does_not_import_mujoco():
    """``robots`` is data: reading a TOML robot file works where MuJoCo is not installed."""
    import subprocess

    code = ("import sys; from robust_ismpc.robots import read_robot_file, robot_file_path; "
            "read_robot_file(robot_file_path('g1')); print('mujoco' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _write(root: Path, name: str, text: str) -> None:
    path = root / Path(*name.split("."))
    path.parent.mkdir(parents=True, exist_ok=True)
    for parent in [path.parent, *path.parent.parents]:
        if parent == root.parent:
            break
        (parent / "__init__.py").touch()
    path.with_suffix(".py").write_text(text)


@pytest.fixture
def fake_package(tmp_path: Path) -> Path:
    """A package laid out like ours, without violations."""
    root = tmp_path / "robust_ismpc"
    _write(root, "core.mpc", "import numpy\nfrom .qp import solve\n")
    _write(root, "core.qp", "import daqp\ndef solve():\n    pass\n")
    _write(root, "sim.loop", "import mujoco\nfrom ..core import mpc\n")
    return root


def test_the_checks_pass_a_clean_layout(fake_package: Path):
    assert layering_violations(fake_package) == []
    assert import_cycles(fake_package) == []


def test_the_checks_find_an_upward_import(fake_package: Path):
    """A function-level import of the simulation from the core is still an upward import."""
    _write(fake_package, "core.plan", "def f():\n    from ..sim.loop import x\n")
    assert any("robust_ismpc.core.plan:2" in p and "robust_ismpc.sim.loop" in p
               for p in layering_violations(fake_package))


def test_the_checks_find_a_forbidden_third_party_import(fake_package: Path):
    _write(fake_package, "core.draw", "import matplotlib\n")
    assert layering_violations(fake_package) == ["robust_ismpc.core.draw:1 (core) imports matplotlib at module level"]


def test_the_checks_find_a_cycle(fake_package: Path):
    _write(fake_package, "core.qp", "from . import mpc\n")
    assert import_cycles(fake_package) == [["robust_ismpc.core.mpc", "robust_ismpc.core.qp"]]

"""The architecture, enforced: what may import what inside addon/wildscan.

Imports are read from the source with `ast` (nothing is imported): `import x`, `from x
import y`, relative imports resolved against the importing module, and `from pkg import
name` counted as an import of the submodule `pkg.name` when that is a module. Each import
is either *module-level* (runs when the module is imported: at the top, in class bodies,
under if/try at the top) or *lazy* (inside a function: runs when the function is called).

The rules:

1. The core is numpy-only: nothing under core/, module-level or lazy, imports Blender
   (bpy, mathutils, bmesh, gpu, ...), matplotlib, or any part of the package outside
   core/ except the package root (`from .. import __version__`): not raycast/, blender/,
   the bpy package world/, ui/, app/, cli/, viz/, bench/ or the top-level command modules.
   (ruff's banned-api rule says the same in core/ruff.toml, for the third-party names.)
2. No import cycle among module-level imports: such a cycle makes import order matter
   and breaks with a partially initialised module.
3. Each layer imports only the layers below it (LAYERS, the table in docs/architecture.md),
   and the optional pictures (viz/, matplotlib) only lazily.
4. No import cycle even through lazy imports. Lazy imports are how Blender add-ons keep
   bpy out of import time, and they never fail at load time, but a module whose function
   imports a module whose function imports it back is still two modules knotted into one
   (as cli.py <-> demo.py once were). One exception: the package root (wildscan/__init__.py)
   holds the version and bl_info and imports nothing at module level (checked), and
   register() lazily imports ui/, so edges into the root are leaves, not knots: they are
   left out of this graph.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

from tests.helpers.scene_helpers import REPO

PACKAGE_DIR = REPO / "addon" / "wildscan"
ROOT = "wildscan"
CORE = "wildscan.core"
BANNED_IN_CORE = ("bpy", "bpy_extras", "mathutils", "bmesh", "gpu", "bgl", "blf", "aud", "matplotlib")


@dataclass(frozen=True)
class Import:
    source: str  # importing module
    target: str  # imported module (dotted, absolute)
    line: int
    lazy: bool

    def __str__(self) -> str:
        where = "lazy, in a function" if self.lazy else "module level"
        return f"{self.source} imports {self.target} ({module_path(self.source)}:{self.line}, {where})"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def module_path(name: str) -> str:
    base = PACKAGE_DIR.parent / Path(*name.split("."))
    path = base / "__init__.py" if base.is_dir() else base.with_suffix(".py")
    return str(path.relative_to(REPO))


def all_modules() -> dict[str, Path]:
    return {
        module_name(p): p
        for p in sorted(PACKAGE_DIR.rglob("*.py"))
        if "__pycache__" not in p.parts and ".egg-info" not in str(p)
    }


MODULES = all_modules()


def is_module(name: str) -> bool:
    return name in MODULES


def resolve(importer: str, is_package: bool, module: str | None, level: int) -> str:
    """The absolute module named by `from <level dots><module> import ...`."""
    if level == 0:
        return module or ""
    package = importer if is_package else importer.rpartition(".")[0]
    for _ in range(level - 1):
        package = package.rpartition(".")[0]
    return f"{package}.{module}" if module else package


class ImportVisitor(ast.NodeVisitor):
    def __init__(self, name: str, is_package: bool):
        self.name, self.is_package = name, is_package
        self.depth = 0  # function nesting
        self.found: list[Import] = []

    def _add(self, target: str, node: ast.AST) -> None:
        self.found.append(Import(self.name, target, node.lineno, self.depth > 0))

    def visit_FunctionDef(self, node):
        self.depth += 1
        self.generic_visit(node)
        self.depth -= 1

    visit_AsyncFunctionDef = visit_FunctionDef
    visit_Lambda = visit_FunctionDef

    def visit_If(self, node):
        # `if TYPE_CHECKING:` never runs: count its imports as lazy
        guarded = isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"
        self.depth += guarded
        for child in node.body:
            self.visit(child)
        self.depth -= guarded
        for child in node.orelse:
            self.visit(child)

    def visit_Import(self, node):
        for alias in node.names:
            self._add(alias.name, node)

    def visit_ImportFrom(self, node):
        base = resolve(self.name, self.is_package, node.module, node.level)
        targets = {f"{base}.{a.name}" if is_module(f"{base}.{a.name}") else base for a in node.names}
        for target in sorted(targets):
            self._add(target, node)


def imports_of(name: str) -> list[Import]:
    path = MODULES[name]
    visitor = ImportVisitor(name, path.name == "__init__.py")
    visitor.visit(ast.parse(path.read_text(encoding="utf-8"), str(path)))
    return visitor.found


ALL_IMPORTS = [imp for name in MODULES for imp in imports_of(name)]


def in_package(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Every strongly connected component with more than one module (or a self-import),
    each as a list of module names, found with Tarjan's algorithm."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges.get(v, ())):
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
            if len(component) > 1 or v in edges.get(v, ()):
                found.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def graph(imports) -> dict[str, set[str]]:
    edges: dict[str, set[str]] = {}
    for imp in imports:
        if imp.target in MODULES and imp.target != imp.source:
            edges.setdefault(imp.source, set()).add(imp.target)
    return edges


def describe(component: list[str], imports) -> str:
    members = set(component)
    links = sorted(str(i) for i in imports if i.source in members and i.target in members)
    return "cycle among " + ", ".join(component) + ":\n    " + "\n    ".join(links)


# ---------------------------------------------------------------------------------------


def test_the_walk_sees_every_module_and_resolves_relative_and_lazy_imports():
    assert {"wildscan", "wildscan.core", "wildscan.raycast.base", "wildscan.ui.operators"} <= set(MODULES)
    geometry = [i for i in ALL_IMPORTS if i.source == "wildscan.raycast.geometry"]
    assert any(i.target == "wildscan.core.hits" and not i.lazy for i in geometry)
    select = [i for i in ALL_IMPORTS if i.source == "wildscan.raycast.select"]
    assert any(i.target == "embreex" and i.lazy for i in select)
    assert any(i.target == "wildscan.raycast.extract" and i.lazy for i in select)
    assert resolve("wildscan.core.scan", False, None, 2) == "wildscan"
    assert resolve("wildscan.core", True, "hits", 1) == "wildscan.core.hits"


def test_the_core_imports_no_blender_no_matplotlib_and_nothing_above_it():
    offences = []
    for imp in ALL_IMPORTS:
        if not in_package(imp.source, CORE):
            continue
        top = imp.target.partition(".")[0]
        if top in BANNED_IN_CORE:
            offences.append(f"{imp}: the core is numpy-only")
        elif in_package(imp.target, ROOT) and imp.target != ROOT and not in_package(imp.target, CORE):
            offences.append(f"{imp}: the core imports nothing of the package outside core/")
    assert offences == [], "\n".join(offences)


def test_the_package_root_imports_nothing_of_the_package_at_module_level():
    """`import wildscan` must stay free (no bpy; the version is read from it everywhere)."""
    eager = [str(i) for i in ALL_IMPORTS if i.source == ROOT and not i.lazy]
    assert eager == []


def test_no_import_cycle_among_module_level_imports():
    eager = [i for i in ALL_IMPORTS if not i.lazy]
    found = cycles(graph(eager))
    assert found == [], "\n".join(describe(c, eager) for c in found)


def test_no_import_cycle_even_through_lazy_imports():
    imports = [i for i in ALL_IMPORTS if i.target != ROOT]
    found = cycles(graph(imports))
    assert found == [], "\n".join(describe(c, imports) for c in found)


def test_the_cycle_finder_finds_cycles():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_ruff_bans_the_same_names_in_the_core():
    import tomllib

    config = tomllib.loads((PACKAGE_DIR / "core" / "ruff.toml").read_text())
    banned = set(config["lint"]["flake8-tidy-imports"]["banned-api"])
    assert {"bpy", "mathutils", "bmesh", "gpu", "matplotlib", "wildscan.raycast", "wildscan.ui"} <= banned
    assert "TID251" in config["lint"]["extend-select"]


# What each layer (a subpackage of wildscan) may import besides itself and the package root:
# docs/architecture.md's table. Data flows core -> raycast -> blender -> app -> cli/ui.
LAYERS = {
    "core": set(),
    "raycast": {"core"},
    "blender": {"core"},
    "viz": {"core"},
    "app": {"core", "raycast", "blender", "viz"},
    "bench": {"core", "raycast", "blender", "app", "viz"},
    "cli": {"core", "raycast", "blender", "app", "bench"},
    "ui": {"core", "raycast", "blender", "app"},
}
LAZY_ONLY = {"viz"}  # matplotlib is an optional extra: nothing may need it to import


def layer_of(name: str) -> str | None:
    parts = name.split(".")
    return parts[1] if parts[0] == ROOT and len(parts) > 1 else None


def test_each_layer_imports_only_the_layers_below_it():
    assert set(LAYERS) == {p.name for p in PACKAGE_DIR.iterdir() if (p / "__init__.py").is_file()}
    offences = []
    for imp in ALL_IMPORTS:
        source, target = layer_of(imp.source), layer_of(imp.target)
        if source is None or target is None or source == target:
            continue
        if target not in LAYERS[source]:
            offences.append(f"{imp}: {source}/ may import {', '.join(sorted(LAYERS[source])) or 'nothing'}")
        elif target in LAZY_ONLY and not imp.lazy:
            offences.append(f"{imp}: {target}/ is optional, import it inside the function that needs it")
    assert offences == [], "\n".join(offences)


MAX_LINES = 500


def test_no_module_is_over_500_lines():
    long = {
        str(path.relative_to(REPO)): n
        for path in MODULES.values()
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }
    assert long == {}


# Inside core/, the groups by meaning (docs/architecture.md "Layers"): a group is a module at
# the core/ root or a folder; each imports only groups of its own tier or the tiers above.
CORE_TIERS = (
    # foundations: data, parsing, deterministic math, the ray protocol, frames, how a run runs
    {
        "errors",
        "checks",
        "detmath",
        "rng",
        "classes",
        "label_schemes",
        "class_weights",
        "hits",
        "backend",
        "pointcloud",
        "sensors",
        "spatial",
        "runtime",
    },
    # the world and what stands in it or comes out of it besides the scan
    {"world", "placement", "posesampler", "effects", "truth"},
    # scanning
    {"realism", "scan", "motion"},
    # files
    {"io"},
)
MAX_CORE_ROOT = 15


def core_group(name: str) -> str | None:
    parts = name.split(".")
    return parts[2] if parts[:2] == [ROOT, "core"] and len(parts) > 2 else None


def test_every_core_group_has_a_tier():
    groups = {
        p.stem for p in (PACKAGE_DIR / "core").iterdir() if p.suffix == ".py" or (p / "__init__.py").is_file()
    }
    groups.discard("__init__")
    tiers = set().union(*CORE_TIERS)
    assert groups - tiers == set(), "add the new core/ group to CORE_TIERS and docs/architecture.md"
    assert tiers - groups == set(), "a core/ group in CORE_TIERS no longer exists"


def test_each_core_group_imports_only_its_tier_and_the_tiers_above():
    tier = {group: n for n, groups in enumerate(CORE_TIERS) for group in groups}
    offences = []
    for imp in ALL_IMPORTS:
        source, target = core_group(imp.source), core_group(imp.target)
        if source is None or target is None or source == target or source not in tier or target not in tier:
            continue
        if tier[target] > tier[source]:
            offences.append(
                f"{imp}: core/{source} (tier {tier[source]}) may not import core/{target} "
                f"(tier {tier[target]}, below it)"
            )
    assert offences == [], "\n".join(offences)


def test_the_core_root_holds_at_most_15_modules():
    """Beyond that the root is a heap: a new module goes into the group it belongs to."""
    root = sorted(p.name for p in (PACKAGE_DIR / "core").glob("*.py"))
    assert len(root) <= MAX_CORE_ROOT, root

"""The package's import graph has no cycle, and only viz/ needs matplotlib.

Every import counts, also those inside functions (a lazy import only hides a cycle).
An import of an ancestor package (`from .. import __version__`) is not an edge: Python
has imported every ancestor before the module itself, whatever the module imports.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ADDON = Path(__file__).resolve().parent.parent / "addon"
PACKAGE = ADDON / "wildscan"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ADDON).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imported(name: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The package's modules that `name` imports anywhere in its source."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            found.add(base)
            found |= {f"{base}.{a.name}" for a in node.names}  # `from . import options`
    ancestors = {".".join(name.split(".")[:i]) for i in range(1, name.count(".") + 1)}
    return {m for m in found if m in known and m != name and m not in ancestors}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
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
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_the_package_has_no_import_cycle():
    known = modules()
    graph = {name: imported(name, path, known) for name, path in known.items()}
    assert "wildscan.cli.options" in graph["wildscan.cli.scan"]  # the walk sees sibling imports
    assert "wildscan.app.world" in graph["wildscan.app.scan"]  # and lazy ones
    assert cycles(graph) == []


def test_a_cycle_is_found():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_only_the_pictures_need_matplotlib(tmp_path):
    """Every module imports without matplotlib; asking for a map says what is missing."""
    code = (
        "import sys, pkgutil, importlib\n"
        "sys.modules['matplotlib'] = None  # as if it were not installed\n"
        "import wildscan\n"
        "for m in pkgutil.walk_packages(wildscan.__path__, 'wildscan.'):\n"
        "    if not m.name.endswith('__main__'):\n"
        "        importlib.import_module(m.name)\n"
        "from wildscan.cli import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    argv = ["world", "--seed", "1", "--out", str(tmp_path / "w.blend"), "--map", str(tmp_path / "m.png")]
    proc = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and list(tmp_path.iterdir()) == [], proc.stderr
    assert proc.stderr.strip() == (
        "wildscan world: error: --map needs matplotlib (pip install matplotlib); it is not installed here"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code, "poses", "--seed", "1", "--zone", "park", "--count", "1"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0 and proc.stdout.count("park") == 1, proc.stderr

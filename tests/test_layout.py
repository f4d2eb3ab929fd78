"""The package's layering: no module imports one that is higher in meaning (docs/architecture.md)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "dexpush"

#: lowest first; a module may import only from strictly lower layers (or its own sub-package)
LAYERS = [
    {"fastmath", "se2", "checks", "files", "compile_cache", "polygons", "xla_options", "arguments"},
    {"geometry", "interfaces", "corner", "noise"},
    {"model"},
    {"cost", "mppi", "ukf", "tasks", "fitting", "proposals"},
    {"estimator", "dataset", "viz"},
    {"policy"},
    {"controller", "plants", "sensing", "gcs", "logs", "online"},
    {"simulate"},
    {"registry"},
    {"records", "config"},
    {"runner"},
    {"tables"},
    {"benchmark", "planner_flags"},
    {"env", "cli", "__init__"},
]
RANK = {name: i for i, layer in enumerate(LAYERS) for name in layer}


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py"))


def _top(path: Path) -> str:
    rel = path.relative_to(PACKAGE).with_suffix("")
    return rel.parts[0]


def _imports(path: Path) -> set[str]:
    """The dexpush modules (first component below the package; ``__init__`` for the package root) that
    ``path`` imports, anywhere in it; relative imports are reported as ``<relative>`` (not allowed)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level > 0:
            out.add("<relative>")
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "dexpush":
            parts = node.module.split(".")
            if len(parts) > 1:
                out.add(parts[1])
            else:  # from dexpush import X: a module, or a name from the package root
                out.update(a.name if (PACKAGE / f"{a.name}.py").exists() or (PACKAGE / a.name).is_dir()
                           else "__init__" for a in node.names)
        elif isinstance(node, ast.Import):
            for a in node.names:
                parts = a.name.split(".")
                if parts[0] == "dexpush":
                    out.add(parts[1] if len(parts) > 1 else "__init__")
    return out


def test_every_module_has_a_layer() -> None:
    missing = sorted({_top(p) for p in _modules()} - set(RANK))
    assert not missing, f"give these modules a layer in tests/test_layout.py and docs/architecture.md: {missing}"


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_upward_or_sideways_import(path: Path) -> None:
    me = _top(path)
    bad = sorted(m for m in _imports(path) if m != me and RANK.get(m, len(LAYERS)) >= RANK[me])
    assert not bad, f"{path.name} (layer {RANK[me]}) imports {bad} from its own layer or above"


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_module_is_too_long(path: Path) -> None:
    lines = len(path.read_text().splitlines())
    assert lines <= 520, f"{path.name} has {lines} lines: split it along its seams"

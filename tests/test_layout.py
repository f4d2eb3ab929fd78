"""The package's layering: no module imports one that is higher in meaning (docs/architecture.md).

Two levels: the sub-packages (and the few top-level modules) of ``dexpush`` form the layers of
:data:`LAYERS`, and inside each sub-package its modules form the layers of :data:`INNER`. A
module may import from strictly lower layers, or from its own package at a strictly lower inner
layer; a package's ``__init__`` may import its own modules.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "dexpush"

#: lowest first: the sub-packages (and top-level modules) of dexpush
LAYERS = [
    {"common"},
    {"model"},
    {"problem", "viz", "perception"},
    {"control", "world", "gcs"},
    {"data", "robot"},
    {"ros"},
    {"experiments"},
    {"env", "cli", "__init__"},
]
RANK = {name: i for i, layer in enumerate(LAYERS) for name in layer}

#: lowest first, per sub-package: its modules (gcs/ is one unit: its own chain, one door)
INNER = {
    "common": [{"fastmath", "se2", "checks", "files", "compile_cache", "xla_options", "interfaces", "progress",
                "settings", "netns"}],
    "model": [{"polygons"}, {"radial_table", "convex_pieces"}, {"kernel"}, {"shape_file"}, {"shape", "corner"},
              {"cgvmm"}],
    "problem": [{"weights", "regions"}, {"guidance", "goal_region"}, {"scene_file"}, {"scene"}, {"obstacles"}, {"cost"},
                {"problem"}],
    "control": [{"noise", "ukf"}, {"mppi", "proposals", "estimator"}, {"push_plan"}, {"settings"}, {"policy"},
                {"controller"}],
    "world": [{"model_plant", "sensing"}, {"physics_plant"}, {"rendered_camera"}],
    "robot": [{"safety", "watchdog", "smoothing", "arm_kinematics", "franky_sim_hooks", "object_watch"},
              {"guarded", "driver"},
              {"tabletop"}, {"franky_driver", "franka_sim", "pick", "robot_camera"}],
    "ros": [{"core"}, {"node"}, {"bridge"}],
    "perception": [{"camera_model", "markers"}, {"camera_file", "planar_pose", "detect"}, {"tracker", "calibration"},
                   {"live"}],
    "data": [{"push"}, {"labelling"}, {"fitting"}, {"mit"}, {"validation", "push_logs", "online_ukf"}],
    "experiments": [{"scenarios", "arm_room"}, {"simulate"}, {"methods"}, {"registry"}, {"records"}, {"runner"},
                    {"tables", "robot_trial", "ros_trial", "cluster"}, {"results_folder", "clearing"},
                    {"benchmark"}],
    "cli": [{"arguments", "settings_file"}, {"config", "flags"}, {"commands"}, {"main"}],
}


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py"))


def _parts(path: Path) -> tuple[str, ...]:
    return path.relative_to(PACKAGE).with_suffix("").parts


def _imports(path: Path) -> set[tuple[str, ...]]:
    """The dexpush modules ``path`` imports, as name parts below the package (``("__init__",)``
    for a name from the package root); relative imports as ``("<relative>",)`` (not allowed)."""
    out: set[tuple[str, ...]] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level > 0:
            out.add(("<relative>",))
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "dexpush":
            parts = tuple(node.module.split(".")[1:])
            for a in node.names:   # from dexpush.pkg import module, or a name from a module
                sub = (*parts, a.name)
                is_module = (PACKAGE.joinpath(*sub).with_suffix(".py").exists() or PACKAGE.joinpath(*sub).is_dir())
                out.add(sub if is_module else (parts or ("__init__",)))
        elif isinstance(node, ast.Import):
            for a in node.names:
                parts = tuple(a.name.split("."))
                if parts[0] == "dexpush":
                    out.add(parts[1:] or ("__init__",))
    return out


def test_every_module_has_a_layer() -> None:
    tops = {_parts(p)[0] for p in _modules()}
    missing = sorted(tops - set(RANK))
    assert not missing, f"give these a layer in tests/test_layout.py and docs/architecture.md: {missing}"
    inner = {(q[0], q[1]) for q in map(_parts, _modules()) if len(q) == 2 and q[0] in INNER and q[1] != "__init__"
             and q[1] != "__main__"}
    listed = {(pkg, m) for pkg, layers in INNER.items() for layer in layers for m in layer}
    assert not sorted(inner - listed), f"give these modules an inner layer: {sorted(inner - listed)}"


def _inner_rank(pkg: str, module: str) -> int:
    return next(i for i, layer in enumerate(INNER[pkg]) if module in layer)


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_upward_or_sideways_import(path: Path) -> None:
    me = _parts(path)
    bad = []
    for other in _imports(path):
        if other == ("<relative>",):
            bad.append("a relative import")
        elif other[0] != me[0]:
            if RANK.get(other[0], len(LAYERS)) >= RANK[me[0]]:
                bad.append(".".join(other))
        elif me[0] in INNER and len(me) == 2 and me[1] not in ("__init__", "__main__"):
            if len(other) < 2 or _inner_rank(me[0], other[1]) >= _inner_rank(me[0], me[1]):
                bad.append(".".join(other))
    assert not bad, f"{'/'.join(me)} imports {sorted(bad)} from its own layer or above"


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_module_is_too_long(path: Path) -> None:
    lines = len(path.read_text().splitlines())
    assert lines <= 520, f"{path.name} has {lines} lines: split it along its seams"

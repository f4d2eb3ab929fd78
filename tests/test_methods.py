"""Methods: a new one is one class and one registration, and runs through `run`, `bench` and the env."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest

from dexpush import Observation
from dexpush.cli import main
from dexpush.env import PushEnv
from dexpush.experiments.methods import METHODS, Method, get_method, method_names, register_method
from dexpush.experiments.scenarios import get_task
from dexpush.model.shape import Shape

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "dexpush"


class TowardGoal:
    """A toy controller: the pusher moves toward the goal's position at 2 cm/s, whatever it sees."""

    def __init__(self, goal: tuple[float, float, float]) -> None:
        self.goal = np.asarray(goal[:2])
        self.calls = 0

    def reset(self, object_pose: object = None, pusher_xy: object = None) -> None:
        self.calls = 0

    def act(self, frame: Observation | None, frame_period: float | None = None) -> np.ndarray:
        self.calls += 1
        self._seen = frame if frame is not None else getattr(self, "_seen", None)
        d = self.goal - np.asarray(self._seen.pusher_xy)
        return 0.02 * d / max(float(np.linalg.norm(d)), 1e-9)

    @property
    def stall_resets(self) -> int:
        return self.calls   # what diagnostics() reports, to see it reach the record


class Toy(Method):
    name = "toy"
    description = "moves the pusher toward the goal (a test method)"
    obstacles = False

    def controller(self, problem, params, seed=0, settings=None):
        return TowardGoal(problem.goal)

    def diagnostics(self, result):
        return {"stall_resets": result.stall_resets}


@pytest.fixture()
def toy():
    method = register_method(Toy())
    yield method
    METHODS.pop(method.name)


def test_a_registered_method_runs_through_run(toy, tmp_path, capsys) -> None:
    code = main(["run", "--method", "toy", "--max-steps", "5", "--no-animation", "--quiet", "--out", str(tmp_path)])
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert code == 1 and summary["method"] == "toy" and summary["steps"] == 5   # 5 steps: no success
    assert summary["diagnostics"] == {"stall_resets": 5}                         # its diagnostics reach the record
    assert json.loads((tmp_path / "summary.json").read_text())["method"] == "toy"


def test_a_registered_method_runs_through_bench(toy, tmp_path, capsys) -> None:
    code = main(["bench", "--tasks", "I,III", "--shapes", "rect", "--params", "known", "--methods", "toy",
                 "--seeds", "0", "--max-steps", "4", "--no-figures", "--workers", "1", "--quiet", "--out",
                 str(tmp_path)])
    assert code == 0
    names = sorted(p.stem for p in (tmp_path / "conditions").glob("*.json"))
    assert names == ["I_rect_known_toy"]          # no obstacle support: the toy skips task III
    trial = json.loads((tmp_path / "conditions" / "I_rect_known_toy.json").read_text())["trials"][0]
    assert trial["method"] == "toy" and trial["steps"] == 4 and trial["lanes"] == 1


def test_a_registered_method_pushes_in_the_gymnasium_env(toy) -> None:
    env = PushEnv(task="I", shape="rect")
    obs, _ = env.reset(seed=0)
    ctrl = get_method("toy").controller(env.problem, params=None)
    ctrl.reset(obs[:3], obs[3:5])
    start = np.linalg.norm(obs[3:5] - obs[5:7])
    for _ in range(20):
        frame = Observation(obs[:3].astype(float), obs[3:5].astype(float), 0.0)
        obs, *_ = env.step(ctrl.act(frame))
    assert np.linalg.norm(obs[3:5] - obs[5:7]) < start - 0.015   # 20 × 0.04 s at 2 cm/s toward the goal


def test_registry_refuses_a_name_taken_and_a_nameless_method(toy) -> None:
    with pytest.raises(ValueError, match="registered already"):
        register_method(Toy())
    with pytest.raises(ValueError, match="a method is a dexpush Method"):
        register_method(Method())
    with pytest.raises(ValueError, match="unknown method 'nope'"):
        get_method("nope")
    assert "toy" in method_names() and "toy" not in method_names(default_only=True)


def test_what_a_method_cannot_do_is_refused_in_one_place() -> None:
    gcs = get_method("gcs")
    problem = get_task("III").problem(Shape.rectangle())
    with pytest.raises(ValueError, match="no obstacle support"):
        gcs.check(problem, exact_observations=True)
    with pytest.raises(ValueError, match="exact observations only"):
        gcs.check(get_task("I").problem(Shape.rectangle()), exact_observations=False)


def test_method_names_are_compared_only_in_the_methods_module() -> None:
    names = set(method_names())
    found = []
    for path in PACKAGE.rglob("*.py"):
        if path.name == "methods.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare):
                for side in (node.left, *node.comparators):
                    consts = side.elts if isinstance(side, ast.Tuple | ast.List | ast.Set) else [side]
                    found += [f"{path.relative_to(PACKAGE)}:{node.lineno}" for c in consts
                              if isinstance(c, ast.Constant) and c.value in names]
    assert not found, f"method names tested outside dexpush.experiments.methods: {found}"


def test_the_env_takes_a_problem() -> None:
    from dexpush.problem import Problem

    problem = Problem(Shape.ellipse(), (0.3, 0.1, 0.5), obstacles=((0.15, 0.0, 0.03),), tolerance_m=0.02)
    env = PushEnv(task="I", problem=problem)
    obs, _ = env.reset(seed=1)
    assert env.problem is problem and env.shape is problem.shape and env.obstacles == problem.obstacles
    np.testing.assert_allclose(obs[5:], [0.3, 0.1, 0.5], atol=1e-6)
    with pytest.raises(ValueError, match="holds the shape, the goal"):
        PushEnv(problem=problem, goal=(0.0, 0.0, 0.0))


def test_a_cli_summary_is_the_last_line_even_through_a_pipe(tmp_path) -> None:
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "dexpush.cli", "run", "--max-steps", "30", "--no-animation",
                           "--out", str(tmp_path)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=300)
    lines = proc.stdout.splitlines()
    assert "\r" not in proc.stdout and json.loads(lines[-1])["steps"] == 30


def test_run_episode_takes_a_method_object_that_is_not_registered() -> None:
    from dexpush import run_episode

    ep = run_episode("I", "rect", method=Toy(), max_steps=3)
    assert ep.record.method == "toy" and ep.record.diagnostics == {"stall_resets": 3} and "toy" not in METHODS

"""The safety filter (dexpush.robot.safety): the identity on safe commands, never past a limit, never out
of the workspace or the reach, never into a keep-out disc; and the frame guard and the guarded controller."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush.common.interfaces import Observation
from dexpush.robot.guarded import FrameGuard, GuardedController
from dexpush.robot.safety import SafetySettings, safe_velocity

T = 0.04
BOX = (-0.3, -0.2, 0.3, 0.2)
OBSTACLES = np.array([[0.1, 0.05, 0.04], [-0.15, -0.1, 0.03]])
RHO = 0.01
S = SafetySettings(v_max=0.15, a_max=2.5, workspace=BOX, reach=(0.0, -0.6, 0.35, 0.75), braking_s=0.3)

velocity = st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)).map(np.array)


def _inflated() -> np.ndarray:
    return OBSTACLES[:, 2] + RHO + S.keep_out_margin


def _safe_start(rng: np.random.Generator) -> np.ndarray:
    while True:
        p = rng.uniform([BOX[0] + RHO, BOX[1] + RHO], [BOX[2] - RHO, BOX[3] - RHO])   # the pusher disc inside
        r = np.linalg.norm(p - (0.0, -0.6))
        if np.all(np.linalg.norm(p - OBSTACLES[:, :2], axis=1) > _inflated()) and 0.35 < r < 0.75:
            return p


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.lists(velocity, min_size=60, max_size=60))
def test_never_leaves_the_safe_set_and_never_exceeds_a_limit(seed: int, requests: list[np.ndarray]) -> None:
    p = _safe_start(np.random.default_rng(seed))
    v_prev = np.zeros(2)
    for u in requests:
        r = safe_velocity(u, p, v_prev, T, S, OBSTACLES, RHO)
        v = r.velocity
        assert np.all(np.isfinite(v))
        assert np.linalg.norm(v) <= S.v_max + 1e-9
        if r.relaxed == "":
            assert np.linalg.norm(v - v_prev) <= S.a_max * T + 1e-9
        p = p + v * T
        v_prev = v
        assert BOX[0] + RHO - 1e-9 <= p[0] <= BOX[2] - RHO + 1e-9 and BOX[1] + RHO - 1e-9 <= p[1] <= BOX[3] - RHO + 1e-9
        assert np.all(np.linalg.norm(p - OBSTACLES[:, :2], axis=1) >= _inflated() - 1e-9)
        r_base = np.linalg.norm(p - (0.0, -0.6))
        assert 0.35 - 1e-9 <= r_base <= 0.75 + 5e-4     # the outer circle is met by its tangent: < 0.5 mm beyond


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 10_000), st.floats(0, 2 * np.pi), st.floats(0, 0.1), st.floats(0, 2 * np.pi),
       st.floats(0, 0.05))
def test_the_identity_on_safe_commands(seed: int, a: float, speed: float, b: float, change: float) -> None:
    rng = np.random.default_rng(seed)
    p = _safe_start(rng)
    v_prev = speed * np.array([np.cos(a), np.sin(a)])
    u = v_prev + change * np.array([np.cos(b), np.sin(b)])
    margin = 1.0 * max(np.linalg.norm(u), 1e-9) * S.braking_s    # far enough that no barrier binds
    far = (min(p[0] - BOX[0], BOX[2] - p[0], p[1] - BOX[1], BOX[3] - p[1]) - RHO > margin   # the pusher disc
           and np.all(np.linalg.norm(p - OBSTACLES[:, :2], axis=1) - _inflated() > margin)
           and 0.35 + margin < np.linalg.norm(p - (0.0, -0.6)) < 0.75 - margin)
    if not far or np.linalg.norm(u) > S.v_max * np.cos(np.pi / 16):
        return
    r = safe_velocity(u, p, v_prev, T, S, OBSTACLES, RHO)
    assert not r.changed and np.array_equal(r.velocity, u)


def test_it_slows_towards_a_wall_and_stops_at_it() -> None:
    s = SafetySettings(workspace=(-1.0, -1.0, 0.2, 1.0), a_max=100.0)
    p, v = np.array([0.0, 0.0]), np.zeros(2)
    for _ in range(200):
        r = safe_velocity((0.1, 0.0), p, v, T, s)
        v = r.velocity
        p = p + v * T
    assert 0.2 - 1e-3 < p[0] <= 0.2 + 1e-12 and abs(v[0]) < 1e-3
    assert "workspace" in r.active


def test_a_request_that_is_not_finite_is_a_stop() -> None:
    r = safe_velocity((np.nan, 0.0), (0.0, 0.0), (0.0, 0.0), T, SafetySettings())
    assert np.array_equal(r.velocity, np.zeros(2))


def test_inside_a_keep_out_zone_it_leaves_it_or_stops() -> None:
    p = np.array([0.1, 0.05 + 0.03])      # inside the first inflated disc
    r = safe_velocity((0.0, -0.1), p, np.zeros(2), T, S, OBSTACLES, RHO)
    n = (p - OBSTACLES[0, :2]) / np.linalg.norm(p - OBSTACLES[0, :2])
    assert r.velocity @ n >= -1e-12                      # never further in


@pytest.mark.parametrize("bad", [dict(v_max=0), dict(a_max=-1), dict(workspace=(0, 0, 0, 1)),
                                 dict(workspace=(0, 0, 1)), dict(reach=(0, 0, 0.5, 0.4)), dict(keep_out_margin=-1)])
def test_bad_settings_are_refused_with_a_message(bad: dict) -> None:
    with pytest.raises(ValueError):
        SafetySettings(**bad)


def _frame(x: float, t: float) -> Observation:
    return Observation(np.array([x, 0.0, 0.0]), np.array([x - 0.1, 0.0]), t)


def test_the_guard_holds_back_one_glitch_and_follows_a_real_jump() -> None:
    g = FrameGuard()
    assert g(_frame(0.0, 0.0)) is not None
    assert g(_frame(0.002, 1 / 15)) is not None
    assert g(_frame(0.2, 2 / 15)) is None                 # a glitch: 20 cm in one frame
    assert g(_frame(0.004, 3 / 15)) is not None           # back where it was: the glitch is forgotten
    assert g(_frame(0.034, 4 / 15)) is None               # knocked by 3 cm: held once...
    assert g(_frame(0.035, 5 / 15)) is not None           # ...then confirmed by the next frame
    assert g.held == 2
    assert g(None) is None


class _Stub:
    """A controller that asks for a fixed velocity and records what it was given."""

    def __init__(self, u: tuple[float, float]) -> None:
        self.u, self.seen = np.array(u), []

    def reset(self, object_pose: object = None, pusher_xy: object = None) -> None:
        self.seen = []

    def act(self, frame: Observation | None, frame_period: float | None = None) -> np.ndarray:
        self.seen.append(frame)
        return self.u


def test_the_guarded_controller_filters_and_stops_without_frames() -> None:
    stub = _Stub((0.3, 0.0))
    g = GuardedController(stub, T, SafetySettings(v_max=0.15, a_max=100.0), guard=FrameGuard(), frame_timeout_s=0.2)
    g.reset((0.0, 0.0, 0.0), (-0.1, 0.0))
    v = g.act(_frame(0.0, 0.0), 1 / 15)
    assert np.linalg.norm(v) <= 0.15 + 1e-12 and g.filtered == 1
    for _ in range(5):                                    # 0.2 s without frames
        v = g.act(None, 1 / 15)
    assert np.array_equal(v, np.zeros(2)) and g.blind >= 1
    v = g.act(_frame(0.0, 0.3), 1 / 15)                  # frames are back: it moves again
    assert np.linalg.norm(v) > 0
    assert stub.seen[-1] is not None


# ---------------------------------------------------------------- polygon workspaces and keep-out polygons
HEXAGON = ((-0.3, -0.1), (-0.1, -0.25), (0.25, -0.2), (0.3, 0.05), (0.1, 0.25), (-0.25, 0.15))
WALL = np.array([[0.0, -0.02], [0.2, 0.06], [0.19, 0.085], [-0.01, 0.005]])   # a thin slanted wall
SP = SafetySettings(v_max=0.15, a_max=2.5, workspace=HEXAGON, braking_s=0.3)


def _polygon_gap(p: np.ndarray, poly: np.ndarray) -> float:
    from dexpush.problem.regions import point_gap
    return float(point_gap(p, poly))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.lists(velocity, min_size=60, max_size=60))
def test_a_polygon_workspace_and_keep_out_polygons_hold_the_pusher_disc(seed: int, requests: list) -> None:
    rng = np.random.default_rng(seed)
    hexagon = np.array(HEXAGON)
    while True:                           # a start inside the hexagon and clear of the wall, pusher disc and all
        p = rng.uniform(-0.3, 0.3, 2)
        if _polygon_gap(p, hexagon) < -RHO and _polygon_gap(p, WALL) > RHO + SP.keep_out_margin:
            break
    v_prev = np.zeros(2)
    for u in requests:
        v = safe_velocity(u, p, v_prev, T, SP, (), RHO, (WALL,)).velocity
        assert np.linalg.norm(v) <= SP.v_max + 1e-9
        p, v_prev = p + v * T, v
        assert _polygon_gap(p, hexagon) <= -RHO + 1e-9                       # the disc stays inside
        assert _polygon_gap(p, WALL) >= RHO + SP.keep_out_margin - 1e-9      # and off the wall


def test_a_rectangle_workspace_is_the_same_as_its_corners() -> None:
    rect = SafetySettings(workspace=BOX)
    corners = SafetySettings(workspace=((BOX[0], BOX[1]), (BOX[2], BOX[1]), (BOX[2], BOX[3]), (BOX[0], BOX[3])))
    rng = np.random.default_rng(3)
    for _ in range(200):
        p, u = rng.uniform(-0.3, 0.3, 2), rng.uniform(-0.2, 0.2, 2)
        a = safe_velocity(u, p, u, T, rect, (), RHO).velocity
        b = safe_velocity(u, p, u, T, corners, (), RHO).velocity
        assert np.allclose(a, b, atol=1e-12)


def test_keep_out_polygons_pass_a_command_that_leaves_them_alone() -> None:
    p, u = np.array([0.1, -0.15]), np.array([-0.05, -0.01])             # below the wall, moving away from it
    r = safe_velocity(u, p, u, T, SP, (), RHO, (WALL,))
    assert not r.changed
    r = safe_velocity((0.0, 0.1), (0.1, 0.0), (0.0, 0.1), T, SP, (), RHO, (WALL,))   # straight at it, 2 cm away
    assert r.changed and "keep-out" in r.active and r.velocity[1] < 0.1


@pytest.mark.parametrize("bad", [((0, 0), (1, 0), (1, 1), (0.9, 0.2)), ((0, 0), (1, 0))])
def test_a_bad_workspace_polygon_is_refused_with_a_message(bad: tuple) -> None:
    with pytest.raises(ValueError, match="workspace"):
        SafetySettings(workspace=bad)

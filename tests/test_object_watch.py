"""The object's watch in the safety filter (dexpush.robot.object_watch): exact gaps of a footprint to discs and
polygons; no rows where the object is far, not pushed or not closing; and a pushed object that the planner's
commands would drive into an obstacle, seen through a 15 Hz camera with latency and noise, stops short of it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush.common.interfaces import Observation
from dexpush.model.shape import Shape
from dexpush.problem.regions import box
from dexpush.robot.guarded import GuardedController
from dexpush.robot.object_watch import ObjectWatch, ObjectWatchSettings, object_gaps
from dexpush.robot.safety import SafetySettings, barrier_rate, safe_velocity

T = 0.04
BOX = Shape.rectangle(0.2, 0.12)          # 200 × 120 mm, ρ = its pusher's radius
DISC = np.array([[0.25, 0.0, 0.05]])      # 10 cm in front of the box's front face (x = 0.1) at the start


def test_the_gaps_are_the_footprints_distances_to_discs_and_polygons() -> None:
    foot = BOX.footprint_world((0.0, 0.0, 0.0))
    wall = box(0.2, 0.3, 0.1, 0.1)                                # its corner (0.15, 0.25): 0.05, 0.19 from the box
    g = object_gaps(foot, np.array([[0.2, 0.0, 0.05], [0.0, 0.12, 0.1]]), (wall,))
    assert np.allclose(g, [0.05, -0.04, np.hypot(0.05, 0.19)])    # the second disc overlaps the box by 4 cm
    turned = object_gaps(BOX.footprint_world((0.0, 0.0, np.pi / 2)), DISC, ())
    assert np.isclose(turned[0], 0.25 - 0.06 - 0.05)


def test_the_rows_near_an_obstacle_with_the_pusher_on_the_object() -> None:
    """None while the object is beyond ``watch_m``, the pusher away from it or no push was seen to close the gap;
    a row along the push the frames saw close it, which stays while the pusher draws back."""
    watch = ObjectWatch(BOX, DISC, ())
    g = barrier_rate(T, SafetySettings())
    keep = ObjectWatchSettings().keep_m
    behind = np.array([-0.1 - BOX.pusher_radius, 0.0])            # the pusher on the box's back face

    def pushed(xs: list[float], pusher_moves: bool = True) -> None:
        watch.reset()
        for k, x in enumerate(xs):
            watch.sent(((xs[min(k + 1, len(xs) - 1)] - x) / T if pusher_moves else 0.0, 0.0), k * T)
            watch.see((x, 0.0, 0.0), k * T)

    pushed([0.05 * k * T for k in range(6)])                      # closing at 5 cm/s, 9 cm away: beyond the watch
    assert len(watch.rows(behind + np.array((0.05 * 5 * T, 0.0)), T, g)[1]) == 0
    pushed([0.09] * 6)                                            # 1 cm away, standing still: none
    assert len(watch.rows(behind + np.array((0.09, 0.0)), T, g)[1]) == 0
    pushed([0.08 + 0.002 * k for k in range(6)])                  # closing at the pusher's speed, 1 cm away ...
    A, b = watch.rows(behind + np.array((0.09, 0.0)), T, g)
    assert np.allclose(A, [(1.0, 0.0)]) and np.allclose(b, g * (0.01 - keep) / T)   # ... limits the push along x
    assert len(watch.rows(behind + np.array((0.09, 0.2)), T, g)[1]) == 0    # the pusher away from the box: none
    for k in range(6, 20):                                        # the pusher draws back: the push stays learnt
        watch.sent((-0.05, 0.0), k * T)
        watch.see((0.09, 0.0, 0.0), k * T)
    assert np.allclose(watch.J, [(-1.0, 0.0)], atol=0.05)
    pushed([0.08 + 0.002 * k for k in range(6)], pusher_moves=False)
    assert len(watch.rows(behind + np.array((0.09, 0.0)), T, g)[1]) == 0    # the box moved by itself: nothing learnt
    turned = ObjectWatch(BOX, DISC, ())                           # a push across that turns the box into the disc
    for k in range(8):
        turned.sent((0.0, 0.05), k * T)
        turned.see((0.09, 0.05 * k * T, 0.3 * k * T), k * T)      # its corner swings towards the disc
    A, b = turned.rows(behind + np.array((0.09, 0.05 * 7 * T)), T, g)
    assert len(b) == 1 and A[0, 1] > 0 and abs(A[0, 0]) < 1e-9    # the learnt row limits the push along y
    assert len(ObjectWatch(BOX, np.zeros((0, 3)), ()).rows(behind, T, g)[1]) == 0


class _Stuck:
    """A planner that always asks for the same push."""

    def __init__(self, u: np.ndarray) -> None:
        self.u = u

    def reset(self, object_pose: object = None, pusher_xy: object = None) -> None:
        pass

    def act(self, frame: Observation | None, frame_period: float | None = None) -> np.ndarray:
        return self.u


def _push(u: np.ndarray, spin: float, latency: int, noise: float, seed: int,
          watch: bool) -> tuple[float, GuardedController]:
    """The least gap (m) between the box and the disc, and the guarded controller, when a planner pushes the box
    with ``u`` for 4 s: the box moves with the pusher and turns ``spin`` rad per metre pushed (what a model may
    not predict), seen by a 15 Hz camera ``latency`` periods late with ``noise`` (m, and rad / 10 cm)."""
    rng = np.random.default_rng(seed)
    q, p = np.zeros(3), np.array([-0.1 - BOX.pusher_radius, 0.0])
    guarded = GuardedController(_Stuck(u), T, SafetySettings(), pusher_radius=BOX.pusher_radius,
                                watch=ObjectWatch(BOX, DISC, ()) if watch else None, frame_timeout_s=1.0)
    guarded.reset(q, p)
    history, least = [(q.copy(), p.copy())], np.inf
    for k in range(100):
        seen = None
        if k % 5 in (0, 2) and k >= latency:                     # 15 Hz frames on a 25 Hz loop
            shot, tip = history[k - latency]
            seen = Observation(shot + rng.normal(0, [noise, noise, noise * 10]), tip + rng.normal(0, noise, 2),
                               (k - latency) * T)
        v = guarded.act(seen, T)
        q = q + np.array([*v * T, spin * np.linalg.norm(v) * T])
        p = p + v * T
        history.append((q.copy(), p.copy()))
        least = min(least, float(object_gaps(BOX.footprint_world(q), DISC, ())[0]))
    return least, guarded


@settings(max_examples=40, deadline=None)
@given(st.floats(0.02, 0.1), st.floats(-0.6, 0.6), st.floats(-2.0, 2.0), st.integers(0, 2), st.floats(0, 0.001),
       st.integers(0, 1000))
def test_a_push_into_an_obstacle_stops_short_of_it(speed: float, angle: float, spin: float, latency: int,
                                                    noise: float, seed: int) -> None:
    """Whatever the push's speed and direction, and however the box turns as it goes (a model's error), the
    watch keeps it off the disc through a late, noisy 15 Hz camera."""
    u = speed * np.array([np.cos(angle), np.sin(angle)])
    assert _push(u, spin, latency, noise, seed, watch=True)[0] > 0


def test_without_the_watch_the_same_push_touches() -> None:
    u = np.array([0.05, 0.0])
    assert _push(u, 0.0, 1, 0.0, 0, watch=False)[0] < 0 < _push(u, 0.0, 1, 0.0, 0, watch=True)[0]


def test_a_guarded_controller_names_the_object_rows() -> None:
    """The filter's counters name the rows the watch added (``limited_by["object"]``); with exact, prompt frames
    the box ends near ``keep_m`` from the disc, never nearer than half of it."""
    least, guarded = _push(np.array([0.05, 0.0]), 0.0, 0, 0.0, 0, watch=True)
    assert ObjectWatchSettings().keep_m / 2 < least < 2 * ObjectWatchSettings().keep_m
    assert guarded.limited_by.get("object", 0) > 10


@pytest.mark.parametrize("bad", [{"watch_m": 0.0}, {"keep_m": -0.001}, {"keep_m": 0.03}, {"window_s": 0.0},
                                 {"contact_m": -1.0}])
def test_bad_watch_settings_are_refused_with_a_message(bad: dict) -> None:
    with pytest.raises(ValueError, match=next(iter(bad))):
        ObjectWatchSettings(**bad)


def test_safe_velocity_takes_the_watchs_rows_as_it_takes_its_own() -> None:
    """``extra`` rows bind like the keep-out rows: the closest command that satisfies them, named."""
    from dexpush.robot.safety import filter_velocity

    A, b = np.array([[1.0, 0.0]]), np.array([0.01])
    r = filter_velocity(np.array([0.05, 0.02]), np.zeros(2), np.array([0.05, 0.02]), T, SafetySettings(),
                        np.zeros((0, 3)), 0.0, (), (("object", A, b),))
    assert np.allclose(r.velocity, [0.01, 0.02]) and r.active == ("object",)
    same = safe_velocity(np.array([0.05, 0.02]), np.zeros(2), np.array([0.05, 0.02]), T, SafetySettings())
    assert np.allclose(same.velocity, [0.05, 0.02]) and not same.changed

"""The command line's setting flags, shared by ``dexpush run`` and ``dexpush bench``: each flag is an
override of one key of the configuration (:mod:`dexpush.cli.config`), on top of the defaults and a
``--config`` file, so the command line and the file are one way to say the same settings.

* planner flags (:func:`add_planner_flags`): one field each of ``ControllerSettings`` (or of its
  ``weights``, ``mppi``, ``stall``, ``endgame``, ``proposals``, ``push_plan``,
  ``prediction_margin``);
* camera flags (:func:`add_camera_flags`): ``--camera realistic`` starts from the realistic camera,
  the others set one key each of ``[sensor]`` on top of the file's, ``--camera exact`` with any
  of them is refused.

:func:`planner_overrides` and :func:`camera_overrides` give the overrides and the flags as text for
a results folder's command line.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from dexpush.cli.arguments import at_least_one, nonnegative_float, positive_float, positive_int, positive_or_off
from dexpush.cli.settings_file import merge, to_dict
from dexpush.world.rendered_camera import SETUPS
from dexpush.world.sensing import MAX_CAMERA_HZ, SensorSettings

__all__ = ["add_camera_flags", "add_planner_flags", "camera_overrides", "planner_overrides"]

#: planner flag → (its argparse dest, the path of the controller key it sets)
_PLANNER = {
    "--detour": ("detour", ("weights", "detour")),
    "--guidance": ("guidance", ("weights", "guidance")),
    "--guidance-turn": ("guidance_turn", ("weights", "guidance_turn_m")),
    "--guidance-goal-heading": ("guidance_goal_heading", ("weights", "guidance_goal_heading")),
    "--guidance-pusher-room": ("guidance_pusher_room", ("weights", "guidance_pusher_room")),
    "--guidance-running": ("guidance_running", ("weights", "guidance_running")),
    "--stall-after": ("stall_after", ("stall", "after_s")),
    "--temperature": ("temperature", ("mppi", "temperature")),
    "--spread-cap": ("spread_cap", ("mppi", "spread_cap")),
    "--endgame-temperature": ("endgame_temperature", ("endgame", "temperature")),
    "--margin-cost": ("margin_cost", ("weights", "C_margin")),
    "--obstacle-margin": ("obstacle_margin", ("weights", "obstacle_margin_m")),
    "--contact-proposals": ("contact_proposals", ("proposals", "count")),
    "--push-plan": ("push_plan", ("push_plan", "enabled")),
    "--endgame-push": ("endgame_push", ("push_plan", "endgame", "enabled")),
    "--mppi-update": ("mppi_update", ("mppi", "update")),
    "--prediction-margin": ("prediction_margin", ("prediction_margin", "gain")),
    "--stall-horizon": ("stall_horizon", ("stall", "horizon_scale")),
    "--samples": ("samples", ("mppi", "num_samples")),
    "--obstacles-under-start": ("obstacles_under_start", ("obstacles_under_start",)),
}


def add_planner_flags(parser: argparse.ArgumentParser) -> None:
    """The planner flags, each defaulting to None (not given: the configuration's value)."""
    g = parser.add_argument_group("planner (each flag sets one key of [controller]; flags override --config)")
    g.add_argument("--detour", action=argparse.BooleanOptionalAction, default=None,
                   help="measure the goal distance round the obstacles (default), or straight through them "
                        "as eq. (9) is written (--no-detour; weights.detour; "
                        "docs/controller.md#going-round-obstacles-detour)")
    g.add_argument("--guidance", action=argparse.BooleanOptionalAction, default=None,
                   help="past obstacles and walls, the terminal cost and the stall watch follow the cost-to-go "
                        "round them (default), or the straight goal distance (--no-guidance; weights.guidance; "
                        "docs/workspaces.md#global-guidance)")
    g.add_argument("--guidance-turn", type=positive_or_off("a length per radian"), default=None, metavar="M|off",
                   help="the cost-to-go has a layer per heading, a turn costing M metres per radian, or one layer "
                        "where the footprint may turn to fit anywhere (off) (weights.guidance_turn_m; "
                        "docs/workspaces.md#global-guidance; default: 0.1)")
    g.add_argument("--guidance-goal-heading", action=argparse.BooleanOptionalAction, default=None,
                   help="the cost-to-go's way ends in the goal's heading, counting the turn to it where the "
                        "footprint fits (default), or in any heading (--no-guidance-goal-heading; "
                        "weights.guidance_goal_heading; docs/workspaces.md#the-turn-to-the-goals-heading-2026-12-05)")
    g.add_argument("--guidance-pusher-room", action=argparse.BooleanOptionalAction, default=None,
                   help="each move of the cost-to-go's way needs room for the pusher behind the object, or only "
                        "room for the footprint (--no-guidance-pusher-room, the default; "
                        "weights.guidance_pusher_room; docs/workspaces.md#the-pushers-room-2026-12-07)")
    g.add_argument("--guidance-running", action=argparse.BooleanOptionalAction, default=None,
                   help="the running cost's goal distance follows the cost-to-go too, or the straight distance "
                        "and the detour round discs (--no-guidance-running, the default; weights.guidance_running; "
                        "docs/workspaces.md#the-running-cost-along-the-way-2026-12-07)")
    g.add_argument("--stall-after", type=positive_or_off("a time in seconds"), default=None, metavar="SECONDS|off",
                   help="restart the planner after this long without progress and contact, or never (off) "
                        "(stall.after_s; docs/controller.md#stalls; default: 4)")
    g.add_argument("--stall-horizon", type=at_least_one, default=None, metavar="SCALE",
                   help="after a stall the planner looks SCALE times further ahead until the next progress "
                        "(stall.horizon_scale; docs/controller.md#stalls; default: 2)")
    g.add_argument("--temperature", type=positive_float, default=None, metavar="TAU",
                   help="MPPI's relative temperature τ: λ = τ·(median − min of the sampled costs) "
                        "(mppi.temperature; docs/controller.md; default: 0.02)")
    g.add_argument("--spread-cap", type=positive_or_off("a cost"), default=None, metavar="C|off",
                   help="take the median of λ over the samples within C of the best (those that paid no "
                        "obstacle penalty), checking the update in finer rollouts, or over all of them (off) "
                        "(mppi.spread_cap; docs/controller.md#the-temperature-beside-obstacles; default: 1e6 "
                        "where there are obstacles)")
    g.add_argument("--endgame-temperature", type=positive_or_off("a temperature"), default=None,
                   metavar="TAU|off", help="τ within 4 cm of the goal, or the same τ everywhere (off) "
                   "(endgame.temperature; docs/controller.md#the-endgame-temperature; default: 0.005)")
    g.add_argument("--obstacle-margin", type=positive_float, default=None, metavar="M",
                   help="the planner keeps object and pusher this far (m) from obstacles (weights."
                        "obstacle_margin_m; docs/controller.md#the-margin; default: 0.01)")
    g.add_argument("--margin-cost", type=positive_or_off("a cost"), default=None, metavar="C|off",
                   help="inside the obstacle margin a state costs C times its depth into it, or the collision "
                        "penalty (off) (weights.C_margin; docs/controller.md#the-margin; default: 1e9)")
    g.add_argument("--contact-proposals", type=int, default=None, metavar="J",
                   help="J of MPPI's exploring samples walk round the object to J contact points and push "
                        "(proposals.count; docs/controller.md#contact-proposals; default: 0, none)")
    g.add_argument("--push-plan", action=argparse.BooleanOptionalAction, default=None,
                   help="after a stall, choose a push (where to stand, which way round, how far) past MPPI's "
                        "horizon and carry it out (default), or restart MPPI alone (--no-push-plan; "
                        "push_plan.enabled; docs/workspaces.md#a-push-plan-after-a-stall-2026-12-07)")
    g.add_argument("--endgame-push", action=argparse.BooleanOptionalAction, default=None,
                   help="a stall within 4 cm of the goal searches finer, shorter pushes scored in the success "
                        "test's terms (default), or the push plan's search as far from the goal (--no-endgame-push; "
                        "push_plan.endgame.enabled; docs/workspaces.md#the-endgame-push-2026-12-07)")
    g.add_argument("--mppi-update", choices=("sampled", "clipped"), default=None,
                   help="MPPI's update: average the sampled inputs and clip the average (sampled), or "
                        "average the clipped samples (clipped) (mppi.update; docs/controller.md#the-update; "
                        "default: sampled)")
    g.add_argument("--samples", type=positive_int, default=None, metavar="K",
                   help="MPPI's sampled input sequences per iteration (mppi.num_samples; "
                        "docs/performance.md#samples-against-success-a-pareto-table; default: 1024)")
    g.add_argument("--obstacles-under-start", action=argparse.BooleanOptionalAction, default=None,
                   help="with the UKF, charge each sample the larger of its obstacle costs under the estimate and "
                        "under λ_pred's start (obstacles_under_start; "
                        "docs/robot.md#the-obstacle-cost-under-the-estimate-and-the-start; default: on)")
    g.add_argument("--prediction-margin", type=nonnegative_float, default=None, metavar="GAIN",
                   help="the obstacle margin grows by GAIN times how far the object was predicted on from "
                        "the newest camera frame, up to 2 cm more; 0 keeps it fixed (prediction_margin.gain; "
                        "docs/controller.md#the-margin-grows-with-the-prediction; default: 0.5)")


def _text(flag: str, value: Any) -> str:
    if isinstance(value, bool):
        return f" {flag}" if value else f" --no-{flag[2:]}"
    return f" {flag} {value if isinstance(value, str) else f'{value:g}'}"


def planner_overrides(args: argparse.Namespace) -> tuple[dict, str]:
    """The ``[controller]`` overrides the planner flags in ``args`` make, and the flags as text
    (`` --no-detour --stall-after off`` …) for a results folder's command line."""
    over: dict[str, Any] = {}
    text = ""
    for flag, (dest, path) in _PLANNER.items():
        value = getattr(args, dest, None)
        if value is None:
            continue
        nested: Any = value
        for key in reversed(path):
            nested = {key: nested}
        over = merge(over, nested)
        text += _text(flag, value)
    return ({"controller": over} if over else {}), text


#: camera flag → (its argparse dest, the [sensor] key it sets, the factor from the flag's unit to the key's)
_CAMERA = {
    "--noise-mm": ("noise_mm", "pos_std_m", 1e-3),
    "--noise-deg": ("noise_deg", "heading_std_rad", math.pi / 180),
    "--camera-hz": ("camera_hz", "rate_hz", 1.0),
    "--latency-ms": ("latency_ms", "latency_s", 1e-3),
    "--drop": ("drop", "drop_prob", 1.0),
}


def add_camera_flags(parser: argparse.ArgumentParser) -> None:
    """The camera flags, each defaulting to None (not given: the configuration's [sensor] or [render] value)."""
    g = parser.add_argument_group("sensing (what the controller sees; each flag sets one key of [sensor], or of "
                                  "[render] with --camera rendered; default: the exact state every step)")
    g.add_argument("--camera", choices=["exact", "realistic", "rendered"], default=None,
                   help="exact (default): the true state every step; realistic: 15 Hz, 1 mm / 0.5° noise, "
                        "60 ms latency, 5%% dropped frames (the other camera flags then change one of these); "
                        "rendered: MuJoCo images → ArUco markers → poses, 15 Hz, 60 ms (the physics plants; "
                        "needs dexpush[camera])")
    g.add_argument("--camera-setup", choices=list(SETUPS), default=None,
                   help="with --camera rendered: one camera above the table, one oblique from the side away "
                        "from the robot, or two obliques (default oblique)")
    g.add_argument("--camera-file", default=None, metavar="CAMERA.toml",
                   help="with --camera rendered: the tracker believes these cameras (from `dexpush calibrate`) "
                        "instead of the true ones")
    g.add_argument("--noise-mm", type=nonnegative_float, default=None, help="object position noise σ (mm)")
    g.add_argument("--noise-deg", type=nonnegative_float, default=None, help="object heading noise σ (deg)")
    g.add_argument("--camera-hz", type=positive_float, default=None,
                   help=f"camera rate, up to {MAX_CAMERA_HZ:g} Hz (default: one frame per control step)")
    g.add_argument("--latency-ms", type=nonnegative_float, default=None, help="capture-to-controller delay (ms)")
    g.add_argument("--drop", type=nonnegative_float, default=None, help="probability of a lost frame, in [0, 1)")


def camera_overrides(args: argparse.Namespace) -> tuple[dict, str]:
    """The ``[sensor]`` (or, with ``--camera rendered``, ``[run] camera`` and ``[render]``) overrides the
    camera flags in ``args`` make, and the flags as text."""
    given = {flag: getattr(args, dest, None) for flag, (dest, _, _) in _CAMERA.items()}
    given = {k: v for k, v in given.items() if v is not None}
    camera = getattr(args, "camera", None)
    setup = getattr(args, "camera_setup", None)
    camera_file = getattr(args, "camera_file", None)
    if camera == "exact" and given:
        raise ValueError(f"--camera exact is the true state every step; it contradicts {', '.join(given)}")
    if (setup is not None or camera_file is not None) and camera != "rendered":
        raise ValueError(f"{'--camera-setup' if setup else '--camera-file'} is for the rendered cameras: add "
                         "--camera rendered")
    text = ""
    if camera == "rendered":
        noise = [flag for flag in given if flag in ("--noise-mm", "--noise-deg")]
        if noise:
            raise ValueError(f"{noise[0]} sets the noise model's noise; rendered images have their own errors")
        over: dict[str, Any] = {}
        text = " --camera rendered" + (f" --camera-setup {setup}" if setup else "")
        if setup:
            over["setup"] = setup
        if camera_file:
            over["camera_file"] = str(Path(camera_file).resolve())
            text += f" --camera-file {camera_file}"
        for flag, value in given.items():
            _, key, unit = _CAMERA[flag]
            over[key] = value * unit
            text += _text(flag, value)
        return {"run": {"camera": "rendered"}, **({"render": over} if over else {})}, text
    over = {}
    if camera is not None:
        over = to_dict(SensorSettings.realistic() if camera == "realistic" else SensorSettings())
        over.pop("seed")
        text = f" --camera {camera}"
    for flag, value in given.items():
        _, key, unit = _CAMERA[flag]
        over[key] = value * unit
        text += _text(flag, value)
    return ({"sensor": over} if over else {}), text

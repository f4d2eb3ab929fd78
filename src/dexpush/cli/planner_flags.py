"""The planner's options on the command line (``dexpush bench``): flags, and the settings they make.

Each flag changes one field of :class:`dexpush.control.controller.ControllerSettings` (or of its
``weights`` or ``mppi``); a flag not given keeps the default, and the flags given are written
back into the results' command line, so a table says how it was made.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from dexpush.cli.arguments import (
    at_least_one,
    nonnegative_float,
    positive_float,
    positive_int,
    positive_or_off,
    stall_time,
)
from dexpush.control.controller import ControllerSettings

__all__ = ["add_planner_flags", "planner_settings"]


def add_planner_flags(parser: argparse.ArgumentParser) -> None:
    """The flags, each defaulting to None (not given: the setting's default)."""
    parser.add_argument("--detour", action=argparse.BooleanOptionalAction, default=None,
                       help="measure the goal distance round the obstacles (default), or straight through them "
                            "as eq. (9) is written (--no-detour; CostWeights.detour; "
                            "docs/controller.md#going-round-obstacles-detour)")
    parser.add_argument("--stall-after", type=stall_time, default=None, metavar="SECONDS|off",
                       help="restart the planner after this long without progress and contact, or never (off) "
                            "(ControllerSettings.stall_after_s; docs/controller.md#stalls; default: 4)")
    parser.add_argument("--stall-horizon", type=at_least_one, default=None, metavar="SCALE",
                       help="after a stall the planner looks SCALE times further ahead until the next progress "
                            "(ControllerSettings.stall_horizon_scale; docs/controller.md#stalls; default: 2)")
    parser.add_argument("--temperature", type=positive_float, default=None, metavar="TAU",
                       help="MPPI's relative temperature τ: λ = τ·(median − min of the sampled costs) "
                            "(MPPISettings.temperature; docs/controller.md; default: 0.02)")
    parser.add_argument("--endgame-temperature", type=positive_or_off("a temperature"), default=None,
                       metavar="TAU|off", help="τ within 4 cm of the goal, or the same τ everywhere (off) "
                       "(ControllerSettings.endgame_temperature; docs/controller.md#the-endgame-temperature; "
                       "default: 0.005)")
    parser.add_argument("--obstacle-margin", type=positive_float, default=None, metavar="M",
                       help="the planner keeps object and pusher this far (m) from obstacles (CostWeights."
                            "obstacle_margin_m; docs/controller.md#the-margin; default: 0.01)")
    parser.add_argument("--margin-cost", type=positive_or_off("a cost"), default=None, metavar="C|off",
                       help="inside the 1-cm obstacle margin a state costs C times its depth into it, or the "
                            "collision penalty (off) (CostWeights.C_margin; docs/controller.md#the-margin; "
                            "default: 1e9)")
    parser.add_argument("--contact-proposals", type=int, default=None, metavar="J",
                       help="J of MPPI's exploring samples walk round the object to J contact points and push "
                            "(ControllerSettings.contact_proposals; docs/controller.md#contact-proposals; "
                            "default: 0, none)")
    parser.add_argument("--mppi-update", choices=("sampled", "clipped"), default=None,
                       help="MPPI's update: average the sampled inputs and clip the average (sampled), or "
                            "average the clipped samples (clipped) (MPPISettings.update; "
                            "docs/controller.md#the-update; default: sampled)")
    parser.add_argument("--samples", type=positive_int, default=None, metavar="K",
                       help="MPPI's sampled input sequences per iteration (MPPISettings.num_samples; "
                            "docs/performance.md#samples-against-success-a-pareto-table; default: 1024)")
    parser.add_argument("--prediction-margin", type=nonnegative_float, default=None, metavar="GAIN",
                       help="the obstacle margin grows by GAIN times how far the object was predicted on from "
                            "the newest camera frame, up to 2 cm more; 0 keeps it fixed "
                            "(ControllerSettings.prediction_margin_gain; "
                            "docs/controller.md#the-margin-grows-with-the-prediction; default: 0.5)")


def _given(value: object, default: object) -> object:
    """A flag's value as a setting: the default when not given."""
    return default if value is None else value


def _or_off(value: float | str | None, default: float | None) -> float | None:
    """A ``positive_or_off`` flag's value as a setting: the default when not given, None for off."""
    return None if value == "off" else _given(value, default)


def planner_settings(args: argparse.Namespace) -> tuple[ControllerSettings | None, str]:
    """The settings the flags in ``args`` make (None when no flag was given: the defaults), and the
    flags as command-line text (`` --no-detour --stall-after off`` …) for the results' command."""
    flags = {"--detour": args.detour, "--stall-after": args.stall_after, "--temperature": args.temperature,
             "--endgame-temperature": args.endgame_temperature, "--margin-cost": args.margin_cost,
             "--obstacle-margin": args.obstacle_margin, "--contact-proposals": args.contact_proposals,
             "--mppi-update": args.mppi_update, "--prediction-margin": args.prediction_margin,
             "--stall-horizon": args.stall_horizon, "--samples": args.samples}
    settings = None
    if any(v is not None for v in flags.values()):
        default = ControllerSettings()
        weights = replace(default.weights, detour=_given(args.detour, default.weights.detour),
                          C_margin=_or_off(args.margin_cost, default.weights.C_margin),
                          obstacle_margin_m=_given(args.obstacle_margin, default.weights.obstacle_margin_m))
        mppi = replace(default.mppi,
                       temperature=_given(args.temperature, default.mppi.temperature),
                       update=_given(args.mppi_update, default.mppi.update),
                       num_samples=_given(args.samples, default.mppi.num_samples))
        settings = replace(default, weights=weights, mppi=mppi,
                           stall_after_s=_or_off(args.stall_after, default.stall_after_s),
                           endgame_temperature=_or_off(args.endgame_temperature, default.endgame_temperature),
                           contact_proposals=_given(args.contact_proposals, default.contact_proposals),
                           prediction_margin_gain=_given(args.prediction_margin, default.prediction_margin_gain),
                           stall_horizon_scale=_given(args.stall_horizon, default.stall_horizon_scale))
    options = "".join((" --detour" if v else " --no-detour") if k == "--detour" else
                      f" {k} {v if isinstance(v, str) else f'{v:g}'}" for k, v in flags.items() if v is not None)
    return settings, options

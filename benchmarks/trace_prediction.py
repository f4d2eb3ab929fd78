"""What the planner's model predicted against what the object did, from a saved episode trace.

    python benchmarks/trace_prediction.py TRACE --from K [--steps 10] [--params 15,0,0 ...] [--shape rect]

``TRACE`` is an episode's arrays (``robot_sim.py --traces`` writes ``OUT/traces/TASK_SHAPE_SEED.npz``; ``dexpush run``
writes ``trajectory.npz``). From the true state at step ``K`` the commands the episode sent are replayed, open
loop, through the C-GVMM (:func:`dexpush.model.cgvmm.replay`, each held one control period) with the λ the planner
had at step K and with each ``--params`` given; per step it prints the object's least gap to the trace's discs
(mm, :func:`dexpush.robot.object_watch.object_gaps`) and its heading (degrees), predicted and true. It answers
whether a touch came from the model (a λ that predicts the gap opening while it closed) or from elsewhere
(docs/robot.md#the-objects-clearance).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from dexpush.common.interfaces import CONTROL_PERIOD_S
from dexpush.experiments.registry import SHAPES, make_shape
from dexpush.robot.object_watch import object_gaps


def params_triple(text: str) -> tuple[float, float, float]:
    """An argparse type: λ = β,x_bf,y_bf."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"expected λ as 3 comma-separated numbers, e.g. 15,0,0; got {text!r}")
    return values


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trace", type=Path, help="an episode's arrays (.npz with states, commands, params, obstacles)")
    ap.add_argument("--from", dest="start", type=int, required=True, metavar="K", help="the step to replay from")
    ap.add_argument("--steps", type=int, default=10, help="how many commands to replay (default 10)")
    ap.add_argument("--params", type=params_triple, action="append", default=[], metavar="B,X,Y",
                    help="a λ to replay with beside the planner's (repeatable)")
    ap.add_argument("--shape", default=None,
                    help="the object (default: from a TASK_SHAPE_SEED.npz file name)")
    args = ap.parse_args()
    try:
        z = np.load(args.trace)
        states, commands, planned, discs = (z[k] for k in ("states", "commands", "params", "obstacles"))
    except (OSError, ValueError, KeyError) as exc:
        raise SystemExit(f"error: {args.trace}: not an episode's arrays ({exc})") from None
    name = args.shape or (args.trace.stem.split("_")[1] if args.trace.stem.count("_") == 2 else None)
    if name not in SHAPES:
        raise SystemExit(f"error: give --shape ({', '.join(SHAPES)}): {args.trace.name} does not name one")
    if not 0 <= args.start < len(commands) or args.steps < 1:
        raise SystemExit(f"error: --from must be a step in 0..{len(commands) - 1} and --steps at least 1")
    if not len(discs):
        raise SystemExit(f"error: {args.trace.name} has no obstacle discs to measure a gap to")

    import jax.numpy as jnp

    from dexpush.model.cgvmm import Contour, replay

    shape = make_shape(name)
    contour = Contour.of(shape)
    k0 = args.start
    n = min(args.steps, len(commands) - k0)
    u = jnp.asarray(commands[k0:k0 + n], jnp.float32)
    x0 = jnp.asarray(states[k0], jnp.float32)
    models = [("planner's", planned[k0])] + [("given", np.array(p)) for p in args.params]

    def gap(x: np.ndarray) -> float:
        return float(object_gaps(shape.footprint_world(np.asarray(x[:3], np.float64)), discs, ())[0]) * 1e3

    runs = [np.asarray(replay(contour, x0, u, CONTROL_PERIOD_S, jnp.asarray(lam, jnp.float32))) for _, lam in models]
    print(f"{args.trace.name}, step {k0}: true gap {gap(states[k0]):.2f} mm, "
          + "; ".join(f"λ {label} = [{', '.join(f'{v:.4g}' for v in lam)}]" for label, lam in models))
    print("step | true gap (mm) | " + " | ".join(f"λ {label} gap" for label, _ in models)
          + " | true heading (deg) | " + " | ".join(f"λ {label} heading" for label, _ in models))
    for i in range(n):
        true = states[k0 + 1 + i]
        print(f"{k0 + 1 + i} | {gap(true):.2f} | " + " | ".join(f"{gap(r[i]):.2f}" for r in runs)
              + f" | {np.degrees(true[2]):.1f} | " + " | ".join(f"{np.degrees(r[i][2]):.1f}" for r in runs))


if __name__ == "__main__":
    main()

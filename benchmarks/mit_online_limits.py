"""How well can *any* λ predict a recorded MIT push ahead of time? The floor under the online target.

Issue 15 asks for a whole-push rotation error ≤ 2° with the online estimate on rect1 and ellip1.
This script measures, per object, what bounds that figure from below (docs/validation.md#what-bounds-the-online-error):

1. **per push, in-sample**: the β (CoF at the centre) that replays each push best, and its error —
   how much the best λ differs from push to push;
2. **one λ for all pushes, in-sample**: the best common β at μ_c = 0.25 and at the fitted μ_c, and the
   Levenberg–Marquardt fit of λ and μ_c over all samples (``dexpush fit --fit-mu``) — no estimator
   that sees each push only after predicting it can do better than these;
3. **prospective refit**: before push i, λ and μ_c fitted (``fit_pushes``, with ``fit_mu``) to pushes
   1 … i−1, push i replayed with it — the best an estimator that pools all past pushes does;
4. **the controller's UKF** (``dexpush.data.online_ukf``), with μ_c fixed at 0.25 and with ``estimate_mu``.

Usage::

    python benchmarks/mit_online_limits.py ../shared/data/mit_push [--json out.json]

The last line is one JSON object with every figure. Takes ~3 min on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from dexpush.common.files import write_json_atomic
from dexpush.control.estimator import UKFSettings
from dexpush.data.fitting import fit_pushes, whole_push_errors
from dexpush.data.mit import OBJECTS, load_folder
from dexpush.data.online_ukf import online_session
from dexpush.experiments.registry import PARAMS
from dexpush.model.cgvmm import Contour

BETAS = np.geomspace(8.0, 200.0, 24)


def _heading(contour: Contour, push, lam: np.ndarray, mu: float) -> float:
    return whole_push_errors(contour, [push], np.asarray(lam, np.float64), mu)[1]


def limits(pushes: list, name: str) -> dict:
    shape = OBJECTS[name]()
    contour = Contour.of(shape)
    full = fit_pushes(pushes, shape, mu=0.25, fit_mu=True)
    out: dict = {"pushes": len(pushes), "fit_mu_c": round(full.mu, 3)}
    for mu in (0.25, round(full.mu, 3)):
        err = np.array([[_heading(contour, p, (b, 0.0, 0.0), mu) for b in BETAS] for p in pushes])
        best = err.argmin(axis=1)
        common = err.mean(axis=0)
        out[f"mu_{mu:g}"] = {
            "best_beta_per_push": [round(float(BETAS[i]), 1) for i in best],
            "per_push_best_error_deg": round(float(err.min(axis=1).mean()), 2),
            "best_common_beta": round(float(BETAS[common.argmin()]), 1),
            "best_common_error_deg": round(float(common.min()), 2)}
    out["lm_fit_lambda_mu"] = {"lambda": [round(float(v), 4) for v in full.lam], "mu_c": round(full.mu, 3),
                               "whole_push_error_deg": round(full.whole_push_error_deg, 2)}
    prospective = [_heading(contour, pushes[0], PARAMS["unknown"], 0.25)]
    for i in range(1, len(pushes)):
        try:
            fit = fit_pushes(pushes[:i], shape, mu=0.25, fit_mu=True)
            lam, mu = fit.lam, fit.mu
        except ValueError:                        # too few samples in contact yet: keep the prior
            lam, mu = np.asarray(PARAMS["unknown"]), 0.25
        prospective.append(_heading(contour, pushes[i], lam, mu))
    out["prospective_refit"] = {"each_deg": [round(e, 2) for e in prospective],
                                "mean_deg": round(float(np.mean(prospective)), 2),
                                "mean_deg_from_push_2": round(float(np.mean(prospective[1:])), 2)}
    for key, settings in (("ukf_mu_fixed", UKFSettings()), ("ukf_estimate_mu", UKFSettings(estimate_mu=True))):
        s, _ = online_session(pushes, shape, prior=PARAMS["unknown"], mu=0.25, settings=settings)
        each = s["whole_push_error_deg_each"]
        out[key] = {"mean_deg": s["whole_push_error_deg_online"],
                    "mean_deg_from_push_2": round(float(np.mean(each[1:])), 2),
                    "lambda_final": s["lambda_final"], "mu_c_final": s.get("mu_c_final", 0.25)}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data_dir", help="folder with the MIT push files (rect1, ellip1)")
    ap.add_argument("--json", default=None, help="also write the figures to this file")
    args = ap.parse_args(argv)
    if not Path(args.data_dir).is_dir():
        print(f"data folder not found: {args.data_dir}", file=sys.stderr)
        return 2
    pushes = load_folder(args.data_dir)
    result = {}
    for name in sorted({p.shape for p in pushes}):
        r = result[name] = limits([p for p in pushes if p.shape == name], name)
        m = f"mu_{r['fit_mu_c']:g}"
        print(f"{name}: best β per push {min(r[m]['best_beta_per_push']):g}–{max(r[m]['best_beta_per_push']):g} "
              f"(μ_c {r['fit_mu_c']:g}, {r[m]['per_push_best_error_deg']:.2f}°); one λ for all, in-sample: "
              f"{r['mu_0.25']['best_common_error_deg']:.2f}° (μ_c 0.25), {r[m]['best_common_error_deg']:.2f}° "
              f"(μ_c {r['fit_mu_c']:g}), LM fit of λ and μ_c {r['lm_fit_lambda_mu']['whole_push_error_deg']:.2f}°; "
              f"prospective refit {r['prospective_refit']['mean_deg']:.2f}° "
              f"(from push 2: {r['prospective_refit']['mean_deg_from_push_2']:.2f}°); UKF "
              f"{r['ukf_mu_fixed']['mean_deg']:.2f}° / with μ_c {r['ukf_estimate_mu']['mean_deg']:.2f}°",
              file=sys.stderr)
    if args.json:
        write_json_atomic(args.json, result)
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

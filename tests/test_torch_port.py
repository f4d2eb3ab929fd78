"""The torch port of the C-GVMM step in benchmarks/mppi_speed.py (pytorch-mppi's dynamics) matches
dexpush.model.cgvmm.step, so the speed comparison races the same model. Needs torch (the ``bench`` extra)."""

from __future__ import annotations

import sys
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

torch = pytest.importorskip("torch")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from dexpush import Shape  # noqa: E402
from dexpush.control.mppi import MPPISettings  # noqa: E402
from dexpush.model.cgvmm import LAMBDA_TRUE, Contour, step  # noqa: E402
from mppi_speed import torch_problem  # noqa: E402


@pytest.mark.parametrize("name", ["rectangle", "tee"])
def test_torch_port_matches_the_model_step(name: str) -> None:
    shape = getattr(Shape, name)()
    settings = MPPISettings()
    dynamics, _, _ = torch_problem(shape, settings)
    rng = np.random.default_rng(1)
    n = 4000
    phi = rng.uniform(-np.pi, np.pi, n)
    r, _ = (np.asarray(a, np.float64) for a in shape.contour(jnp.asarray(phi, jnp.float32)))
    # pushers on, just inside and just outside the contour, every heading, every direction
    scale = rng.choice([1.0, 0.999, 1.002, 1.3], n)
    th = rng.uniform(-np.pi, np.pi, n)
    c, s = np.cos(th), np.sin(th)
    p = r * scale[:, None]
    x = np.stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n), th, np.zeros(n), np.zeros(n)], -1)
    x[:, 3] = x[:, 0] + c * p[:, 0] - s * p[:, 1]
    x[:, 4] = x[:, 1] + s * p[:, 0] + c * p[:, 1]
    u = rng.uniform(-0.07, 0.07, (n, 2))
    for t in (0, 12, 24):
        dt = float(settings.step_durations()[t])
        ours = np.asarray(step(Contour.of(shape), jnp.asarray(x, jnp.float32), jnp.asarray(u, jnp.float32),
                               jnp.float32(dt), jnp.asarray(LAMBDA_TRUE, jnp.float32), 0.3), np.float64)
        theirs = dynamics(torch.tensor(x, dtype=torch.float32), torch.tensor(u, dtype=torch.float32), t).numpy()
        err = np.abs(theirs - ours)
        err[:, 2] = np.abs(np.angle(np.exp(1j * (theirs[:, 2] - ours[:, 2]))))
        # float32 round-off, amplified only where a sample sits on a mode boundary
        agree = np.all(err < 1e-4, axis=1)
        assert agree.mean() > 0.995, f"{name}, slot {t}: {1 - agree.mean():.2%} of samples differ"
        assert np.median(err) < 1e-6

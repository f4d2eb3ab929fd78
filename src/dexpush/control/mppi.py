"""Long-horizon MPPI (paper Sec. III-C, eq. 9–10, Table II), dynamics and cost injected.

The planner knows nothing about pushing: it takes

    dynamics(x (K, n), u (K, 2), dt, params) -> x' (K, n)
    running_cost(x (K, n), context) -> (K,)       evaluated on x_1 … x_N
    terminal_cost(x (K, n), context) -> (K,)      evaluated on x_N

and returns an improved nominal input sequence. One iteration (:func:`mppi_iteration`):

    ε ~ mixture (below)                                       sampling noise
    v_k = clip(U_k + ε_k, ±v_max/√2)                          input clamping (10)
    x_{k+1} = dynamics(x_k, v_k, Δt_k, params),  Δt_k = Δt₀·e^{2k/N_p}, k = 0 … N_p−1
    S = Σ_{k=1..N} running(x_k) + terminal(x_N) + q_u·Σ_k Δt_k·‖v_k‖²
    λ = τ·(median S − min S);  w = softmax(−(S − min S)/λ);  U ← clip(Σ w·(U + ε), ±v_max/√2)

Choices the paper leaves to its reference [8] (measured in ``docs/controller.md``):

* ``num_samples`` K = 1024: more samples do not change the outcomes, fewer cost success on the
  physics plant (docs/performance.md#samples-against-success-a-pareto-table).
* sampling noise, a two-part mixture. Half of the samples *explore* with the paper's
  σ = 0.12 m/s (Table II), drawn at ``explore_knots`` = 3 knots over the horizon and
  linearly interpolated, so an exploring sample is a coherent move (a walk around the
  object) rather than a random walk whose slots cancel. The other half *refine* the
  nominal sequence with σ = 0.03 m/s per slot. With Table II's white σ = 0.12 alone,
  whose samples mostly sit on the ±0.071 m/s clip, the weighted average of nearly
  bang-bang samples moved the pusher at ~3 cm/s and Task I took ~1450 of the 1500
  steps; with the mixture it takes 250–450.
* the temperature is *relative*: λ = τ·(median − min of the sampled costs), τ = 0.02.
  The costs of eq. (9) span eight orders of magnitude between "0.6 m away" and "2 mm
  away", and C_pen = 1e13 makes the mean useless; the median-to-best spread keeps the
  weighting equally selective everywhere. Beside an obstacle or a table edge more than half
  of the samples can pay an obstacle penalty, and their median makes λ so large that every
  sample that paid none weighs the same; ``spread_cap`` (opt-in) takes the median over those
  that paid none. A caller may pass another τ per iteration (the controller does near the
  goal: ``ControllerSettings.endgame.temperature``).
* with ``spread_cap`` the update is checked. The capped λ weighs a few samples, and those are the
  ones whose one-Euler-step-per-slot rollout looks best: where that rollout is optimistic (a box
  turning toward a disc in a 0.2-s slot) their average plans into the obstacle. Each iteration
  therefore rolls out five candidates with every slot split into ``check_substeps`` steps: the step
  from the nominal U to the capped update, whole, half and a quarter of it (:data:`CHECK_STEPS`), the
  plain median's update and U itself; it keeps the first whose cost is at most min S + cap (no
  penalty the best sample did not pay), else the plain median's
  (docs/controller.md#the-temperature-beside-obstacles).
* control cost q_u·Σ Δt_k‖v_k‖² with q_u = 1: an effort tie-breaker worth ~0.03 cost
  units for a full-speed 3-s horizon, small against millimetre goal errors.
* warm start: the nominal sequence is a piecewise-constant function of time on the
  non-uniform slots; after a control period T it is shifted by T *in time*, sampling
  the piecewise-linear interpolant through the slot midpoints at (midpoint + T), holding
  the last value past the end (:func:`shift_in_time`).
* the update averages the *sampled* inputs U + ε and clips the average (``update="sampled"``): the
  input bound is part of the dynamics, as in Williams et al.'s MPPI. Averaging the clipped
  samples instead (``"clipped"``, pytorch_mppi's way) pulls a nominal that sits on the bound
  inward, since no sample can lie beyond it; the pusher then walked at 4.5–6.5 cm/s where
  7.1–10 were allowed, and Task III on the T took a median 750 steps against 611
  (docs/controller.md#the-update).
* sample 0 is the noise-free nominal sequence, so an iteration never discards it.
* the first slot is k = 0 (Δt = Δt₀ = the control period), so the first predicted step
  is exactly the period the command is held for; horizon Σ Δt_k = 3.07 s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_nonnegative, check_positive, check_whole
from dexpush.common.interfaces import CONTROL_PERIOD_S
from dexpush.control import noise

#: the fewest samples K an iteration draws: half explore, half refine, and each half needs a few
MIN_SAMPLES = 16
#: the most samples K: memory and time grow with K × N_p (the rollouts hold every sample's states)
MAX_SAMPLES = 65_536
#: the most prediction steps N_p
MAX_HORIZON = 200
#: with ``spread_cap``: the fractions of the step from the nominal to the capped update that are checked, in turn
CHECK_STEPS = (1.0, 0.5, 0.25)
#: the longest horizon Σ Δt_k (s): the paper's spans 3.1 s, a stall's stretch doubles it
MAX_HORIZON_S = 120.0

__all__ = ["CHECK_STEPS", "MAX_HORIZON", "MAX_HORIZON_S", "MAX_SAMPLES", "MIN_SAMPLES", "MPPIResult", "MPPISettings",
           "mppi_iteration", "shift_in_time", "slot_durations"]

Dynamics = Callable[[jnp.ndarray, jnp.ndarray, jnp.ndarray, Any], jnp.ndarray]
Cost = Callable[[jnp.ndarray, Any], jnp.ndarray]


@dataclass(frozen=True)
class MPPISettings:
    """MPPI knobs; paper values (Table II) where it gives them."""

    num_samples: int = 1024       #: K, sampled input sequences per iteration
    horizon: int = 25             #: N_p, prediction steps (Table II)
    dt0: float = CONTROL_PERIOD_S #: Δt₀ (s), first prediction step (Table II: the control period)
    growth: float = 2.0           #: Δt_k = Δt₀·exp(growth·k/N_p) (paper: 2)
    noise_sigma: float = 0.12     #: σ of Σ = diag(σ, σ)² (m/s, Table II): the exploring samples
    refine_sigma: float = 0.03    #: σ of the refining samples around the nominal sequence (m/s)
    refine_fraction: float = 0.5  #: share of the K samples drawn with ``refine_sigma``
    explore_knots: int = 3        #: exploring noise is drawn at this many knots and linearly
                                  #: interpolated over the slots (0: independent per slot)
    v_max: float = 0.1            #: pusher speed limit (m/s); clipped per axis to ±v_max/√2 (10)
    temperature: float = 0.02     #: τ, relative temperature λ = τ·(median S − min S)
    #: the median of λ over the samples that cost at most min S + this (e.g. 1e6: a sample past it paid an
    #: obstacle's penalty, C_margin = 1e9 per margin depth, C_pen = 1e13 per touch), the update checked (module
    #: docstring); None: over all of them. The controller drops it where there is nothing to keep clear of
    #: (:func:`dexpush.control.policy.plan_step`). See docs/controller.md#the-temperature-beside-obstacles.
    spread_cap: float | None = 1e6
    #: with ``spread_cap``: the Euler steps per slot of the rollouts that check the update
    check_substeps: int = 4
    control_cost: float = 1.0     #: q_u of the effort term q_u·Σ Δt_k‖v_k‖²
    control_period: float = CONTROL_PERIOD_S  #: T (s), time between iterations; the warm-start shift
    #: the update: "sampled" averages the sampled inputs U + ε and clips the average, the input bound (10)
    #: being part of the dynamics as in Williams et al.'s MPPI; "clipped" averages the clipped samples, as
    #: pytorch_mppi does, which drags a nominal at the bound inward (docs/controller.md#the-update)
    update: str = "sampled"

    def __post_init__(self) -> None:
        for name, low, high in (("num_samples", MIN_SAMPLES, MAX_SAMPLES), ("horizon", 1, MAX_HORIZON),
                                ("explore_knots", 0, MAX_HORIZON), ("check_substeps", 1, 100)):
            check_whole(name, getattr(self, name), low, high)
        check_nonnegative("growth", self.growth)
        if not 0.0 <= self.refine_fraction <= 1.0:
            raise ValueError(f"refine_fraction must be in [0, 1], got {self.refine_fraction!r}")
        for name in ("dt0", "noise_sigma", "refine_sigma", "v_max", "temperature", "control_period"):
            check_positive(name, getattr(self, name))
        check_nonnegative("control_cost", self.control_cost)
        if self.spread_cap is not None:
            check_positive("spread_cap", self.spread_cap, "or None")
        if self.update not in ("sampled", "clipped"):
            raise ValueError(f"update must be 'sampled' or 'clipped', got {self.update!r}")
        span = float(np.sum(self.step_durations()))
        if not span <= MAX_HORIZON_S:
            raise ValueError(f"the prediction horizon spans {span:.3g} s (dt0, growth, horizon); it must be at most "
                             f"{MAX_HORIZON_S:g} s")

    @property
    def v_clip(self) -> float:
        """Per-axis input bound v_max/√2 of eq. (10)."""
        return self.v_max / np.sqrt(2.0)

    def step_durations(self) -> np.ndarray:
        """Δt_k = Δt₀·e^{growth·k/N_p}, k = 0 … N_p − 1 (s)."""
        k = np.arange(self.horizon)
        return self.dt0 * np.exp(self.growth * k / self.horizon)


class MPPIResult(NamedTuple):
    """One iteration's output: the new nominal sequence and diagnostics."""

    sequence: jnp.ndarray      #: (N_p, 2) improved nominal inputs
    cost_min: jnp.ndarray      #: best sampled cost
    cost_nominal: jnp.ndarray  #: cost of the noise-free nominal sequence (sample 0)
    ess: jnp.ndarray           #: effective sample size 1/Σw² of the importance weights


def _hat_basis(n: int, knots: int) -> np.ndarray:
    """(n, knots) linear-interpolation weights from equally spaced knots to n slots."""
    pos = np.linspace(0, knots - 1, n)
    return np.maximum(0.0, 1.0 - np.abs(pos[:, None] - np.arange(knots)[None, :]))


def _median(S: jnp.ndarray) -> jnp.ndarray:
    """``jnp.median`` of a 1-D array by one partition instead of a full sort."""
    n = S.shape[0]
    m = n // 2
    part = jnp.partition(S, m)
    return part[m] if n % 2 else 0.5 * (jnp.max(part[:m]) + part[m])


def _spread(S: jnp.ndarray, S_min: jnp.ndarray, cap: float | None) -> jnp.ndarray:
    """median − min of the costs S (K,) at most ``S_min + cap`` (all of them with ``cap`` None). Where none is
    above it this is the plain :func:`_median`'s, bit for bit: the same middle elements, the same ½(a + b)."""
    if cap is None:
        return _median(S) - S_min
    below = S <= S_min + cap
    n = jnp.sum(below)
    ordered = jnp.sort(jnp.where(below, S, jnp.inf))
    return 0.5 * (ordered[(n - 1) // 2] + ordered[n // 2]) - S_min


def slot_durations(settings: MPPISettings, horizon_scale: jnp.ndarray | float = 1.0,
                   dtype: Any = jnp.float32) -> jnp.ndarray:
    """The prediction slots Δt_k (N_p,) with every slot after the first stretched by ``horizon_scale``
    (a traced value: changing it does not recompile). Δt₀ stays the control period the first
    input is held for."""
    base = settings.step_durations()
    if isinstance(horizon_scale, int | float):          # a constant: the program sees constant slots
        return jnp.asarray(base * np.where(np.arange(settings.horizon) == 0, 1.0, horizon_scale), dtype=dtype)
    return jnp.asarray(base, dtype) * jnp.where(jnp.arange(settings.horizon) == 0, 1.0,
                                                 jnp.asarray(horizon_scale, dtype))


def shift_in_time(U: jnp.ndarray, durations: jnp.ndarray, shift: float) -> jnp.ndarray:
    """Warm start: the sequence U (N, 2) on slots ``durations`` (N,), shifted by ``shift`` seconds.

    Values live at slot midpoints; the shifted value of slot k is the piecewise-linear
    interpolant at (midpoint_k + shift), held constant past the last midpoint. A sequence
    that is linear in time is therefore shifted exactly (except in the held tail).
    """
    ends = jnp.cumsum(durations)
    mid = ends - 0.5 * durations
    interp = jax.vmap(lambda col: jnp.interp(mid + shift, mid, col), in_axes=1, out_axes=1)
    return interp(U)


def mppi_iteration(key: jax.Array, U: jnp.ndarray, x0: jnp.ndarray, params: Any, context: Any, *,
                   dynamics: Dynamics, running_cost: Cost, terminal_cost: Cost,
                   settings: MPPISettings, horizon_scale: jnp.ndarray | float = 1.0,
                   temperature: jnp.ndarray | float | None = None,
                   proposals: jnp.ndarray | None = None, rate_independent: bool = False) -> MPPIResult:
    """One MPPI update of the nominal sequence U (N_p, 2) from state x0. Pure and jit-able.

    ``x0`` is any pytree of arrays (one state); each leaf gets a leading sample axis K.
    ``horizon_scale`` stretches the slots after the first (:func:`slot_durations`). With
    ``rate_independent`` (dynamics positively homogeneous of degree 1 in the input, as
    quasi-static pushing is: holding s·v for Δt moves the state as holding v for s·Δt) the
    rollout holds s_k·v_k for the unstretched Δt_k instead of v_k for s_k·Δt_k: the same
    states (and the effort is charged as for v_k over s_k·Δt_k), but the slots stay constants
    of the program while s is traced (a traced slot per lane slows the batched simulator's step,
    docs/performance.md).
    ``temperature``, if given, is this iteration's τ in place of ``settings.temperature``.
    ``proposals`` (J, N_p, 2), if given, take the place of the last J exploring samples, clipped as
    they are (10): sequences the caller knows to be worth a try (:mod:`dexpush.control.proposals`), weighted
    by their cost like any sample.
    """
    K, N = settings.num_samples, settings.horizon
    dtype = U.dtype
    n_refine = round(settings.refine_fraction * K)
    # draw only what is used: white noise for the refining rows, knots for the exploring ones,
    # from two ranges of one key's stream
    n_explore, skip = K - n_refine, n_refine * N * 2
    refine = settings.refine_sigma * noise.normal(key, (n_refine, N, 2), dtype)
    if settings.explore_knots >= 2:  # smooth exploring noise: coherent moves over the horizon
        knots = noise.normal(key, (n_explore, settings.explore_knots, 2), dtype, offset=skip)
        basis = jnp.asarray(_hat_basis(N, settings.explore_knots), dtype=dtype)   # (N, knots)
        explore = jnp.einsum("nj,kjd->knd", basis, knots)
    else:
        explore = noise.normal(key, (n_explore, N, 2), dtype, offset=skip)
    eps = jnp.concatenate([refine, settings.noise_sigma * explore])
    eps = eps.at[0].set(0.0)                                  # sample 0: the nominal itself
    raw = U[None] + eps
    if proposals is not None:
        J = proposals.shape[0]
        if not 0 < J <= n_explore - (1 if n_refine == 0 else 0):
            raise ValueError(f"{J} proposals do not fit in the {n_explore} exploring samples")
        raw = raw.at[K - J:].set(proposals.astype(dtype))
    V = jnp.clip(raw, -settings.v_clip, settings.v_clip)      # eq. (10)

    if rate_independent:       # constant slots, the stretch as a factor on the inputs
        scales = jnp.where(jnp.arange(N) == 0, 1.0, jnp.asarray(horizon_scale, dtype)).astype(dtype)
        durations = slot_durations(settings, 1.0, dtype)
    else:
        scales, durations = jnp.ones(N, dtype), slot_durations(settings, horizon_scale, dtype)

    def cost(inputs: jnp.ndarray, substeps: int = 1) -> jnp.ndarray:
        """S (B,) of the input sequences (B, N_p, 2), each slot integrated in ``substeps`` steps."""
        def rollout_step(carry: tuple[Any, jnp.ndarray], inp: tuple[jnp.ndarray, ...]):
            x, total = carry
            v, dt, scale = inp
            for _ in range(substeps):      # (x / 1 is x exactly: one step per slot is the plain rollout)
                x = (dynamics(x, v * scale, dt / substeps, params) if rate_independent
                     else dynamics(x, v, dt * scale / substeps, params))
            effort = settings.control_cost * (dt * scale) * jnp.sum(v * v, -1)
            return (x, total + running_cost(x, context) + effort), None

        # the state may be any pytree (dexpush passes a tuple of scalars): give each leaf a batch axis
        B = inputs.shape[0]
        x = jax.tree.map(lambda leaf: jnp.broadcast_to(leaf, (B, *jnp.shape(leaf))), x0)
        # costs are summed in the scan's carry: no (B, N_p) cost array is kept
        (xN, total), _ = jax.lax.scan(rollout_step, (x, jnp.zeros(B, dtype)),
                                      (jnp.swapaxes(inputs, 0, 1), durations, scales))
        return total + terminal_cost(xN, context)

    S = cost(V)
    S_min = jnp.min(S)
    tau = settings.temperature if temperature is None else temperature

    def update(spread: jnp.ndarray) -> tuple[jnp.ndarray, jnp.ndarray]:
        w = jax.nn.softmax(-(S - S_min) / (tau * spread + 1e-12))
        if settings.update == "sampled":
            return jnp.clip(jnp.einsum("k,knd->nd", w, raw), -settings.v_clip, settings.v_clip), w
        return jnp.einsum("k,knd->nd", w, V), w

    cap = settings.spread_cap
    if cap is None:
        U_new, w = update(_spread(S, S_min, None))
        return MPPIResult(U_new, S_min, S[0], 1.0 / jnp.sum(w * w))
    (U_capped, w_capped), (U_plain, w_plain) = update(_spread(S, S_min, cap)), update(_spread(S, S_min, None))
    U_now = jnp.clip(U, -settings.v_clip, settings.v_clip)
    steps = jnp.asarray(CHECK_STEPS, dtype)[:, None, None]
    candidates = jnp.concatenate([U_now + steps * (U_capped - U_now)[None], U_plain[None], U_now[None]])
    fits = cost(candidates, settings.check_substeps) <= S_min + cap
    pick = jnp.where(jnp.any(fits), jnp.argmax(fits), len(CHECK_STEPS))
    U_new, w = candidates[pick], jnp.where(pick < len(CHECK_STEPS), w_capped, w_plain)
    return MPPIResult(U_new, S_min, S[0], 1.0 / jnp.sum(w * w))

"""Contact proposals: input sequences that walk the pusher round the object to a contact point and push.

MPPI's random samples rarely find a push that needs a walk first: round the stem of a T to its
foot, say, when the pusher sits in the corner under the bar. Such a walk is a specific curve,
and noise drawn at three knots almost never traces it, so the planner keeps pushing where it is
(docs/controller.md#contact-proposals). The proposals are sequences of that shape, built from the
object's own contour, that :func:`dexpush.control.mppi.mppi_iteration` evaluates beside its samples (an
informed sampling distribution in the spirit of Trevisan & Alonso-Mora's biased MPPI, 2024): a
proposal wins only if its predicted cost is lower, through the same model and cost.

Proposal j, for the contact azimuth φ_j = −π + 2πj/J in {B} (j = 0 … J−1), from the pusher's azimuth
φ₀ and distance r₀ = ‖p_c − p_b‖ in {B}:

    walk:   φ(s) = φ₀ + s·wrap(φ_j − φ₀),   ρ(s) = R(φ(s)) + c + (r₀ − R(φ₀) − c)·(1 − s)⁴,  s ∈ [0, 1]
    push:   from R(φ_j) + c straight along −n(φ_j), the inward normal of the contour at φ_j

where R(φ) is the inflated contour's radius and c = ``clearance`` (m) the walk's radial
distance from it (so the walk touches nothing). The curve is followed at ``speed`` and sampled
at the end of each slot Δt_k; the slot's input is its displacement over Δt_k, turned into {W}
with the object's heading. The object is taken to stand still while the pusher walks: these are
proposals, and the model rolls each one out properly before the cost judges it.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.model.cgvmm import Contour

__all__ = ["contact_proposals", "inward_normal", "pusher_in_body", "walk_and_push", "walk_curve"]

#: points along each walk (the curve between them is taken as straight)
WALK_POINTS = 48


def pusher_in_body(x: jnp.ndarray, dtype: jnp.dtype) -> tuple[jnp.ndarray, ...]:
    """(x_b, y_b, cos θ, sin θ, b_x, b_y): the object's pose and the pusher's position in {B}."""
    xb, yb, th, xc, yc = (x[i].astype(dtype) for i in range(5))
    c, s = jnp.cos(th), jnp.sin(th)
    dx, dy = xc - xb, yc - yb
    return xb, yb, c, s, c * dx + s * dy, -s * dx + c * dy


def walk_curve(x: jnp.ndarray, contour: Contour, targets: jnp.ndarray, turns: jnp.ndarray,
               clearance: float) -> tuple[jnp.ndarray, jnp.ndarray, jnp.ndarray]:
    """The walks of the module docstring from state ``x`` (5,) to the azimuths ``targets`` (J,), turning
    ``turns`` (J,) radians on the way (signed: counter-clockwise positive; the short way round is
    wrap(φ_j − φ₀), the long way that less 2π·sign). Returns (points (J, M, 2) in {B}, arc length (J, M)
    from the pusher, inward normal at each target (J, 2) in {B}). Pure and jit-able."""
    dtype = targets.dtype
    _, _, _, _, bx, by = pusher_in_body(x, dtype)
    phi0, r0 = jnp.arctan2(by, bx), jnp.hypot(bx, by)
    R0, _ = contour.lookup(phi0)
    count = targets.shape[0]
    sgrid = jnp.asarray(np.linspace(0.0, 1.0, WALK_POINTS), dtype)                    # (M,)
    phi = phi0 + turns[:, None] * sgrid[None, :]                                      # (J, M)
    R, _ = contour.lookup(phi)
    rho = R + clearance + (r0 - R0 - clearance) * (1.0 - sgrid) ** 4
    walk = jnp.stack([rho * jnp.cos(phi), rho * jnp.sin(phi)], -1)                   # (J, M, 2)
    seg = jnp.linalg.norm(jnp.diff(walk, axis=1), axis=-1)                            # (J, M−1)
    arc = jnp.concatenate([jnp.zeros((count, 1), dtype), jnp.cumsum(seg, axis=1)], 1)  # (J, M)
    return walk, arc, inward_normal(contour, targets)


def inward_normal(contour: Contour, targets: jnp.ndarray) -> jnp.ndarray:
    """The contour's inward unit normal (J, 2) in {B} at the azimuths ``targets`` (J,): −(outward normal) of
    p(φ) = R(φ)·(cos φ, sin φ), the contour counter-clockwise. Pure and jit-able."""
    Rt, dRt = contour.lookup(targets)
    tx = dRt * jnp.cos(targets) - Rt * jnp.sin(targets)
    ty = dRt * jnp.sin(targets) + Rt * jnp.cos(targets)
    norm = jnp.hypot(tx, ty)
    return jnp.stack([-ty / norm, tx / norm], -1)


def walk_and_push(x: jnp.ndarray, contour: Contour, durations: jnp.ndarray, targets: jnp.ndarray,
                  turns: jnp.ndarray, speed: float | jnp.ndarray, clearance: float,
                  push_m: float | jnp.ndarray = jnp.inf) -> jnp.ndarray:
    """Input sequences (J, N, 2) in {W} on the slots ``durations`` (N,): each walk of :func:`walk_curve`
    followed at ``speed``, then a push along the target's inward normal for ``push_m`` (m, scalar or (J,);
    the pusher then holds still). Pure and jit-able."""
    dtype = durations.dtype
    _, _, c, s, bx, by = pusher_in_body(x, dtype)
    walk, arc, inward = walk_curve(x, contour, targets, turns, clearance)
    # where the curve is at the end of each slot
    ends = jnp.cumsum(durations) * speed                                              # (N,) distance travelled
    total = arc[:, -1:]                                                               # (J, 1)
    along = jnp.minimum(ends[None, :], total)                                         # (J, N)
    interp = jax.vmap(jnp.interp)                                                     # one walk a row
    px, py = interp(along, arc, walk[..., 0]), interp(along, arc, walk[..., 1])
    beyond = jnp.clip(ends[None, :] - total, 0.0, jnp.reshape(jnp.asarray(push_m, dtype), (-1, 1)))  # (J, N)
    pos = jnp.stack([px, py], -1) + beyond[..., None] * inward[:, None, :]            # (J, N, 2) in {B}
    start = jnp.stack([bx, by])
    prev = jnp.concatenate([jnp.broadcast_to(start, (targets.shape[0], 1, 2)), pos[:, :-1]], 1)
    vb = (pos - prev) / durations[None, :, None]                                     # {B} velocities
    return jnp.stack([c * vb[..., 0] - s * vb[..., 1], s * vb[..., 0] + c * vb[..., 1]], -1)


def contact_proposals(x: jnp.ndarray, contour: Contour, durations: jnp.ndarray, count: int, speed: float,
                      clearance: float = 0.015) -> jnp.ndarray:
    """``count`` input sequences (count, N, 2) in {W} for state ``x`` (5,) on the slots ``durations`` (N,),
    each the short way round to its target and pushing to the horizon's end.

    Pure and jit-able; ``count`` is static. See the module docstring for the curve.
    """
    dtype = durations.dtype
    _, _, _, _, bx, by = pusher_in_body(x, dtype)
    phi0 = jnp.arctan2(by, bx)
    targets = jnp.asarray(2 * np.pi * np.arange(count) / count - np.pi, dtype)        # (J,)
    turn = jnp.arctan2(jnp.sin(targets - phi0), jnp.cos(targets - phi0))              # shortest way round
    return walk_and_push(x, contour, durations, targets, turn, speed, clearance)

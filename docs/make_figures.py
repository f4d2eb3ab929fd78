"""Regenerate the documentation figures that need no experiment run.

    python docs/make_figures.py      # writes docs/figures/shapes.png and docs/figures/corner.png
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from dexpush import LAMBDA_TRUE, Shape, contact_solution
from dexpush.model.cgvmm import MODE_NAMES, Contour
from dexpush.viz import MODE_COLORS, plot_shapes, save_figure_atomic


def corner_figure(path: Path) -> None:
    """The T's right inner corner: geometry, and the object's turning rate for every push
    direction from the corner, with and without the two-contact model."""
    tee = Shape.tee()
    row = tee.corners[np.argmax(tee.corners[:, 0])]
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 4.4), gridspec_kw={"width_ratios": [1, 1.5]})
    for poly in tee.polygons:
        ax0.fill(*np.r_[poly, poly[:1]].T, color="0.85", lw=0)
    ax0.plot(*np.r_[tee.contour_points(), tee.contour_points()[:1]].T, color="0.4", lw=0.8, label="inflated contour")
    for c in tee.corners:
        ax0.plot(*c[:2], "o", color=MODE_COLORS["corner"], ms=6)
        for n in (c[2:4], c[4:6]):
            ax0.annotate("", xy=c[:2] + 0.03 * n, xytext=c[:2], arrowprops=dict(arrowstyle="->", color="k"))
    ax0.set_aspect("equal")
    ax0.set_xlim(-0.11, 0.11)
    ax0.set_ylim(-0.19, 0.04)
    ax0.set_title("T: concave corners and their two inward normals", fontsize=9)
    ang = np.linspace(-np.pi, np.pi, 721)
    u = 0.05 * np.stack([np.cos(ang), np.sin(ang)], -1)
    x = np.broadcast_to(np.r_[0.0, 0.0, 0.0, row[:2]], (len(ang), 5))
    two = contact_solution(tee, x, u, LAMBDA_TRUE)
    one = contact_solution(Contour.of(tee)._replace(corners=None), x, u, LAMBDA_TRUE)
    mode = np.asarray(two.mode)
    for m in np.unique(mode):
        sel = mode == m
        ax1.fill_between(np.degrees(ang), -1.5, 1.5, where=sel, color=MODE_COLORS[MODE_NAMES[m]], alpha=0.18,
                         lw=0, label=f"two contacts: {MODE_NAMES[m]}")
    ax1.plot(np.degrees(ang), np.asarray(two.xdot)[:, 2], color="k", lw=1.6, label="θ̇, two-contact model")
    ax1.plot(np.degrees(ang), np.asarray(one.xdot)[:, 2], color="0.5", lw=1.0, ls="--",
             label="θ̇, single-contact model")
    ax1.set_xlabel("push direction from the right inner corner (°, world = body)")
    ax1.set_ylabel("θ̇ (rad/s) at 5 cm/s")
    ax1.set_xlim(-180, 180)
    ax1.set_ylim(-1.5, 1.5)
    ax1.legend(fontsize=7, loc="lower left")
    ax1.set_title("λ = λ_true, μ_c = 0.3: jammed pushes turn the T with the pusher", fontsize=9)
    fig.tight_layout()
    save_figure_atomic(fig, path, dpi=130)
    plt.close(fig)


if __name__ == "__main__":
    figures = Path(__file__).parent / "figures"
    plot_shapes([Shape.rectangle(), Shape.tee(), Shape.ellipse()], path=figures / "shapes.png")
    corner_figure(figures / "corner.png")
    print(figures / "shapes.png", figures / "corner.png")

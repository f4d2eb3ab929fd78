"""Figures: episode trajectories (like the paper's Fig. 8), animations, and shape diagrams.

Importing this module leaves matplotlib's backend to the application: the command line chooses
the non-interactive Agg backend (:func:`dexpush.cli.main.main`), a notebook keeps its own.
"""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib.colors
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.patches import Circle, Polygon

from dexpush.common.files import atomic_path
from dexpush.common.interfaces import CONTROL_PERIOD_S
from dexpush.model.cgvmm import MODE_NAMES
from dexpush.model.shape import Shape

__all__ = ["animate_episode", "draw_obstacles", "plot_condition", "plot_confusion", "plot_endgame", "plot_episode",
           "plot_fit", "plot_guidance", "plot_layouts", "plot_mode_decisions", "plot_online_lambda", "plot_params",
           "plot_shapes", "save_figure_atomic", "write_video"]

MODE_COLORS = {"stick": "#e6a800", "slide_ccw": "#2ca02c", "slide_cw": "#1f77b4", "free": "#d62728",
               "corner": "#9467bd"}
#: the single-contact modes, which recorded pushes on convex objects can show (the validation figures)
SINGLE_MODES = MODE_NAMES[:4]


def save_figure_atomic(fig: plt.Figure, path: str | os.PathLike, **kwargs: object) -> None:
    """``fig.savefig`` through :func:`dexpush.common.files.atomic_path`."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, **kwargs)


def _draw_pose(ax: plt.Axes, shape: Shape, pose: np.ndarray, **kw: object) -> None:
    label = kw.pop("label", None)
    for i, poly in enumerate(shape.footprint_world(pose)):   # one legend entry per pose, not per piece
        ax.add_patch(Polygon(poly, closed=True, label=label if i == 0 else None, **kw))


def _setup_axes(ax: plt.Axes, shape: Shape, states: np.ndarray, goal: np.ndarray,
                obstacles: np.ndarray, goal_label: str = "goal", polygons: tuple = (),
                workspace: np.ndarray | None = None, region: object = None) -> None:
    pts = np.concatenate([states[:, :2], states[:, 3:], goal[None, :2]]
                         + ([] if workspace is None else [np.asarray(workspace)]))
    pad = shape.bounding_radius + 0.03
    ax.set_xlim(pts[:, 0].min() - pad, pts[:, 0].max() + pad)
    ax.set_ylim(pts[:, 1].min() - pad, pts[:, 1].max() + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(alpha=0.3)
    draw_obstacles(ax, obstacles, polygons, workspace)
    if region is not None:
        draw_goal_region(ax, region)
        goal_label = "a pose in the goal region"
    _draw_pose(ax, shape, goal, fill=False, ec="#d62728", lw=1.5, ls="--", label=goal_label)


def draw_goal_region(ax: plt.Axes, region: object) -> None:
    """The lines of a goal region's rows (:class:`dexpush.problem.goal_region.RegionRows`) on ``ax``: where the
    footprint must reach (green, dashed) and what its point must stay behind (red, dotted)."""
    for rows, style, label in ((region.reach, dict(color="#2ca02c", ls="--"), "goal: the footprint reaches"),
                               (region.keep, dict(color="#d62728", ls=":"), "goal: the centre stays behind")):
        for i, (nx, ny, o, _) in enumerate(np.asarray(rows).reshape(-1, 4)):
            at = np.array([nx, ny]) * o
            ax.axline(at, at + np.array([-ny, nx]), lw=1.3, label=label if i == 0 else None, **style)


def draw_obstacles(ax: plt.Axes, obstacles: np.ndarray, polygons: tuple = (),
                   workspace: np.ndarray | None = None) -> None:
    """Disc obstacles (c_x, c_y, r), convex polygons (boxes, walls: corner arrays) and the workspace's
    boundary on ``ax``, one legend entry each."""
    for i, (cx, cy, r) in enumerate(np.asarray(obstacles).reshape(-1, 3)):
        ax.add_patch(Circle((cx, cy), r, color="#d62728", alpha=0.5, label="obstacle" if i == 0 else None))
    for i, corners in enumerate(polygons):
        ax.add_patch(Polygon(np.asarray(corners), closed=True, color="#8c564b", alpha=0.55,
                             label="box / wall" if i == 0 else None))
    if workspace is not None:
        ax.add_patch(Polygon(np.asarray(workspace), closed=True, fill=False, ec="k", lw=1.5, ls="-",
                             label="workspace"))


def _finish(fig: plt.Figure, ax: plt.Axes, title: str, path: str | os.PathLike | None, dpi: int) -> plt.Figure:
    """Legend, title, layout, and the atomic save of a scene figure."""
    ax.legend(loc="best", fontsize=7, framealpha=0.8)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    if path is not None:
        save_figure_atomic(fig, path, dpi=dpi)
    return fig


def plot_episode(shape: Shape, states: np.ndarray, modes: np.ndarray, goal: np.ndarray,
                 obstacles: np.ndarray | None = None, title: str = "", outlines: int = 12,
                 path: str | os.PathLike | None = None, polygons: tuple = (),
                 workspace: np.ndarray | None = None, region: object = None,
                 events: np.ndarray | None = None) -> plt.Figure:
    """Object outlines along the path, its reference path, the pusher path coloured by mode; the
    obstacles (discs, ``polygons``), the ``workspace`` boundary and a goal ``region``'s lines; with ``events``
    ((T, 2) stall restarts and push plans so far after each step), where the object was at each stall
    restart and where the pusher was when each push plan was chosen."""
    states = np.asarray(states)
    obstacles = np.zeros((0, 3)) if obstacles is None else np.asarray(obstacles).reshape(-1, 3)
    fig, ax = plt.subplots(figsize=(7, 5.5))
    _setup_axes(ax, shape, states, np.asarray(goal), obstacles, polygons=polygons, workspace=workspace,
                region=region)
    idx = np.unique(np.linspace(0, len(states) - 1, outlines).astype(int))
    for j, i in enumerate(idx):
        _draw_pose(ax, shape, states[i], fill=True, fc="0.6", ec="0.2", alpha=0.12 + 0.25 * j / len(idx), lw=0.8)
    _draw_pose(ax, shape, states[0], fill=False, ec="#1f77b4", lw=1.5, label="start")
    ax.plot(states[:, 0], states[:, 1], "k-", lw=1.2, label="object reference")
    if len(modes):
        seg = np.stack([states[:-1, 3:], states[1:, 3:]], 1)
        colors = [MODE_COLORS[MODE_NAMES[m]] for m in modes]
        ax.add_collection(LineCollection(seg, colors=colors, lw=1.6))
        for name, c in MODE_COLORS.items():
            if np.any(np.asarray(modes) == MODE_NAMES.index(name)):
                ax.plot([], [], color=c, lw=2, label=f"pusher: {name}")
    ax.plot(*states[-1, 3:], "o", color="c", ms=6, mec="k")
    if events is not None and len(events):
        grew = np.diff(np.asarray(events), axis=0, prepend=0) > 0      # the steps at which each count rose
        for col, xy, style, label in ((0, slice(0, 2), dict(marker="x", color="#d62728", ms=8, mew=2), "stall restart"),
                                      (1, slice(3, 5), dict(marker="^", color="#9467bd", ms=7, mec="k"), "push plan")):
            at = np.flatnonzero(grew[:, col]) + 1                        # the state after that step's command
            if len(at):
                ax.plot(*states[at, xy].T, ls="none", label=f"{label} ({len(at)})", **style)
    return _finish(fig, ax, title, path, dpi=130)


def plot_condition(shape: Shape, trajectories: list[np.ndarray], successes: list[bool], goal: np.ndarray,
                   obstacles: np.ndarray | None = None, title: str = "",
                   path: str | os.PathLike | None = None, polygons: tuple = (),
                   workspace: np.ndarray | None = None, region: object = None) -> plt.Figure:
    """All trials of one benchmark condition: object reference paths (green: success, red:
    failure), start and final footprints, pusher paths faint, goal and obstacles."""
    obstacles = np.zeros((0, 3)) if obstacles is None else np.asarray(obstacles).reshape(-1, 3)
    fig, ax = plt.subplots(figsize=(7, 5.5))
    _setup_axes(ax, shape, np.concatenate(trajectories), np.asarray(goal), obstacles, polygons=polygons,
                workspace=workspace, region=region)
    for k, (X, ok) in enumerate(zip(trajectories, successes)):
        color = "#2ca02c" if ok else "#d62728"
        ax.plot(X[:, 3], X[:, 4], "-", color="0.5", lw=0.4, alpha=0.35, label="pusher paths" if k == 0 else None)
        ax.plot(X[:, 0], X[:, 1], "-", color=color, lw=1.0, alpha=0.8)
        _draw_pose(ax, shape, X[0], fill=False, ec="#1f77b4", lw=0.6, alpha=0.5, label="starts" if k == 0 else None)
        _draw_pose(ax, shape, X[-1], fill=True, fc=color, ec="0.2", lw=0.4, alpha=0.15)
    ax.plot([], [], color="#2ca02c", label="object path (success)")
    if not all(successes):
        ax.plot([], [], color="#d62728", label="object path (failure)")
    return _finish(fig, ax, title, path, dpi=110)


def plot_layouts(shape: Shape, trials: list[tuple[object, np.ndarray, bool]], title: str = "",
                 path: str | os.PathLike | None = None, columns: int = 6) -> plt.Figure:
    """Small multiples for a family whose layout changes with the seed (the clutter benchmark): one panel
    per trial ``(problem, states, success)`` with its obstacles, workspace, goal, start and object path
    (green: success, red: failure) and the pusher path faint."""
    rows = max(1, -(-len(trials) // columns))
    fig, axes = plt.subplots(rows, columns, figsize=(2.2 * columns, 2.2 * rows), squeeze=False)
    for ax in axes.flat[len(trials):]:
        ax.set_axis_off()
    for ax, (problem, X, ok) in zip(axes.flat, trials):
        X = np.asarray(X)
        color = "#2ca02c" if ok else "#d62728"
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        draw_obstacles(ax, problem.obstacles, problem.polygons, problem.workspace)
        if problem.workspace is not None:
            w = np.asarray(problem.workspace)
            ax.set_xlim(w[:, 0].min() - 0.02, w[:, 0].max() + 0.02)
            ax.set_ylim(w[:, 1].min() - 0.02, w[:, 1].max() + 0.02)
        ax.plot(X[:, 3], X[:, 4], "-", color="0.5", lw=0.4, alpha=0.5)
        ax.plot(X[:, 0], X[:, 1], "-", color=color, lw=1.0)
        _draw_pose(ax, shape, X[0], fill=False, ec="#1f77b4", lw=0.8)
        _draw_pose(ax, shape, np.asarray(problem.goal), fill=False, ec="#d62728", lw=0.8, ls="--")
        _draw_pose(ax, shape, X[-1], fill=True, fc=color, ec="0.2", lw=0.4, alpha=0.25)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    if path is not None:
        save_figure_atomic(fig, path, dpi=100)
    return fig


def plot_guidance(shape: Shape, problem: object, states: np.ndarray | None = None, title: str = "",
                  path: str | os.PathLike | None = None) -> plt.Figure:
    """The cost-to-go V of ``problem.guide`` as a filled contour (positions where the footprint does not fit
    hatched out; a field with heading layers is drawn in the layer nearest the start's heading, or 0 without
    ``states``), the obstacles, the object's own bound and keep-out discs (a robot's reach: dashed), the goal
    and, given ``states``, the object's and the pusher's paths."""
    guide = problem.guide
    fig, ax = plt.subplots(figsize=(7, 5.5))
    if guide is not None:
        k = guide.layer(0.0 if states is None else float(np.asarray(states)[0, 2]))
        _, nx, ny = guide.values.shape
        xs = guide.lo[0] + guide.cell * np.arange(nx)
        ys = guide.lo[1] + guide.cell * np.arange(ny)
        v = np.where(guide.reached[k], guide.values[k], np.nan)
        field = ax.contourf(xs, ys, v.T, levels=24, cmap="viridis", alpha=0.85)
        fig.colorbar(field, ax=ax, label="cost-to-go V (m)")
        ax.contourf(xs, ys, (~guide.free[k]).T.astype(float), levels=[0.5, 1.5], colors="none", hatches=["///"])
    draw_obstacles(ax, problem.obstacles, problem.polygons, problem.workspace)
    if problem.object_workspace is not None:
        ax.add_patch(Polygon(np.asarray(problem.object_workspace), closed=True, fill=False, ec="k", lw=1.2, ls="--",
                             label="object's bound"))
    for i, (cx, cy, r_object, _) in enumerate(problem.keep_out):
        ax.add_patch(Circle((cx, cy), r_object, fill=False, ec="k", lw=1.2, ls="--",
                            label=None if problem.object_workspace is not None or i else "object's bound"))
    _draw_pose(ax, shape, np.asarray(problem.goal), fill=False, ec="#d62728", lw=1.5, ls="--", label="goal")
    if states is not None:
        X = np.asarray(states)
        ax.plot(X[:, 3], X[:, 4], "-", color="w", lw=0.8, alpha=0.9, label="pusher path")
        ax.plot(X[:, 0], X[:, 1], "-", color="k", lw=1.6, label="object path")
        _draw_pose(ax, shape, X[0], fill=False, ec="#1f77b4", lw=1.5, label="start")
        _draw_pose(ax, shape, X[-1], fill=True, fc="0.6", ec="k", lw=0.8, alpha=0.6, label="end")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return _finish(fig, ax, title, path, dpi=120)


def plot_endgame(shape: Shape, problem: object, states: np.ndarray, first: int = 0,
                 control_period: float = CONTROL_PERIOD_S, title: str = "",
                 path: str | os.PathLike | None = None) -> plt.Figure:
    """The end of an episode near the goal, from step ``first`` on: the object's bound and the pusher's
    (``problem.object_workspace``, ``problem.pusher_workspace``: dashed), the goal, the pusher's path coloured
    by time, the object's reference path and its end (filled), in a window 2.6 bounding radii wide round the
    goal."""
    X = np.asarray(states)
    first = min(max(int(first), 0), len(X) - 1)
    fig, ax = plt.subplots(figsize=(6.5, 5.5))
    for corners, colour, label in ((problem.object_workspace, "k", "object's bound"),
                                   (problem.pusher_workspace, "#1f77b4", "pusher's bound")):
        if corners is not None:
            ax.add_patch(Polygon(np.asarray(corners), closed=True, fill=False, ec=colour, lw=1.2, ls="--",
                                 label=label))
    _draw_pose(ax, shape, np.asarray(problem.goal), fill=False, ec="#d62728", lw=1.5, label="goal")
    _draw_pose(ax, shape, X[-1, :3], fill=True, fc="0.6", ec="none", alpha=0.6, label="end")
    t = np.arange(first, len(X)) * control_period
    pusher = ax.scatter(X[first:, 3], X[first:, 4], c=t, s=3, cmap="viridis", label="pusher")
    fig.colorbar(pusher, ax=ax, label="time (s)")
    ax.plot(X[first:, 0], X[first:, 1], "k-", lw=1.2, label="object's reference")
    g, half = np.asarray(problem.goal[:2]), 1.3 * shape.bounding_radius
    ax.set_xlim(g[0] - half, g[0] + half)
    ax.set_ylim(g[1] - half, g[1] + half)
    ax.set_aspect("equal")
    ax.legend(loc="lower left", fontsize=7)
    ax.set_title(title, fontsize=9)
    if path is not None:
        save_figure_atomic(fig, path, dpi=110, bbox_inches="tight")
    return fig


def animate_episode(shape: Shape, states: np.ndarray, modes: np.ndarray, goal: np.ndarray,
                    obstacles: np.ndarray | None, path: str | os.PathLike, fps: float = 12.5,
                    control_period: float = CONTROL_PERIOD_S, speedup: float = 1.0, title: str = "",
                    polygons: tuple = (), workspace: np.ndarray | None = None, region: object = None) -> str:
    """An animation of the episode playing at ``speedup`` × real time; returns the path written.

    One frame every k = round(speedup / (fps·T)) control steps (T = ``control_period``),
    shown for k·T/speedup seconds, so the clock in the video runs at ``speedup`` × real time
    (at 25 Hz and the defaults: every 2nd step, 12.5 frames per second). The file is an MP4
    when ``path`` ends in ``.mp4`` and ffmpeg is installed, else a GIF (``path`` with the
    suffix ``.gif``); the caption states the speed-up.
    """
    states = np.asarray(states)
    obstacles = np.zeros((0, 3)) if obstacles is None else np.asarray(obstacles).reshape(-1, 3)
    stride = max(1, round(speedup / (fps * control_period)))
    fps = speedup / (stride * control_period)          # the rate that keeps the clock exact
    frames = np.arange(0, len(states), stride)
    if frames[-1] != len(states) - 1:
        frames = np.append(frames, len(states) - 1)
    fig, ax = plt.subplots(figsize=(5, 4), dpi=80)
    _setup_axes(ax, shape, states, np.asarray(goal), obstacles, polygons=polygons, workspace=workspace,
                region=region)
    ax.set_title(title, fontsize=8)
    patches = [Polygon(np.zeros((3, 2)), closed=True, fc="0.6", ec="k", animated=True) for _ in shape.polygons]
    for p in patches:
        ax.add_patch(p)
    trail, = ax.plot([], [], "k-", lw=1, animated=True)
    pusher = Circle((0, 0), shape.pusher_radius, color="c", ec="k", zorder=5, animated=True)
    ax.add_patch(pusher)
    text = ax.text(0.02, 0.96, "", transform=ax.transAxes, fontsize=8, va="top", animated=True)
    speed = "real time" if speedup == 1 else f"{speedup:g}× real time"
    # the axes, goal and obstacles are drawn once; each frame redraws only the moving artists on a copy
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    images = []
    for i in frames:
        for p, poly in zip(patches, shape.footprint_world(states[i])):
            p.set_xy(poly)
        trail.set_data(states[: i + 1, 0], states[: i + 1, 1])
        pusher.center = tuple(states[i, 3:])
        mode = MODE_NAMES[modes[min(i, len(modes) - 1)]] if len(modes) else "free"
        pusher.set_color(MODE_COLORS[mode])
        text.set_text(f"t = {i * control_period:5.2f} s   {mode}   ({speed})")
        fig.canvas.restore_region(background)
        for artist in (*patches, trail, pusher, text):
            ax.draw_artist(artist)
        images.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
    plt.close(fig)
    return write_video(images, Path(path), fps)


def write_video(images: list[np.ndarray], path: str | os.PathLike, fps: float) -> str:
    """Frames (H, W, 3) uint8 to an MP4 through ffmpeg when ``path`` ends in .mp4 and ffmpeg is
    on the PATH, otherwise to a GIF beside it; atomic either way. Returns the path written."""
    import shutil
    import subprocess

    from PIL import Image

    path = Path(path)
    ffmpeg = shutil.which("ffmpeg")
    if path.suffix == ".mp4" and ffmpeg:
        h, w = images[0].shape[:2]
        with atomic_path(path) as tmp:
            cmd = [ffmpeg, "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}",
                   "-r", f"{fps:g}", "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p",
                   "-f", "mp4", str(tmp)]
            subprocess.run(cmd, input=b"".join(im.tobytes() for im in images), check=True)
        return str(path)
    path = path.with_suffix(".gif")
    # one palette for all frames (no flicker), fitted to a montage of frames and the contact-mode colours
    picks = [images[k] for k in np.linspace(0, len(images) - 1, min(12, len(images))).astype(int)]
    swatch = np.zeros((8, images[0].shape[1], 3), np.uint8)
    for k, color in enumerate(MODE_COLORS.values()):
        swatch[:, k * 8:(k + 1) * 8] = (np.array(matplotlib.colors.to_rgb(color)) * 255).astype(np.uint8)
    palette = Image.fromarray(np.concatenate([*picks, swatch])).quantize(colors=96)
    frames = [Image.fromarray(im).quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    with atomic_path(path) as tmp:
        frames[0].save(tmp, format="GIF", save_all=True, append_images=frames[1:], duration=round(1000 / fps),
                       loop=0)
    return str(path)


def plot_fit(shape: Shape, recorded: list[np.ndarray], replayed: list[np.ndarray], summary: dict,
             path: str | os.PathLike | None = None, max_pushes: int = 6) -> plt.Figure:
    """Recorded pushes (object pose and pusher) against the model's open-loop replays with the fitted λ."""
    n = min(len(recorded), max_pushes)
    cols = min(n, 3)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 3.2 * rows), squeeze=False)
    for k, ax in enumerate(axes.ravel()):
        if k >= n:
            ax.axis("off")
            continue
        rec, rep = np.asarray(recorded[k]), np.asarray(replayed[k])
        _setup_axes(ax, shape, rec, rec[-1, :3], np.zeros((0, 3)), goal_label="recorded, end")
        _draw_pose(ax, shape, rec[0, :3], fc="0.85", ec="0.5", label="start")
        _draw_pose(ax, shape, rep[-1, :3], fill=False, ec="#1f77b4", lw=1.5, label="model, end")
        ax.plot(rec[:, 0], rec[:, 1], "k-", lw=1.2, label="object (recorded)")
        ax.plot(rep[:, 0], rep[:, 1], "--", color="#1f77b4", lw=1.2, label="object (model)")
        ax.plot(rec[:, 3], rec[:, 4], ":", color="c", lw=1, label="pusher")
        ax.set_title(f"push {k}", fontsize=8)
        if k == 0:
            ax.legend(fontsize=6, loc="best")
    lam = summary["lambda"]
    std = [f"{s * k:.1f}" if s is not None else "?" for s, k in zip(summary["lambda_std"], (1, 1e3, 1e3))]
    fig.suptitle(f"fitted λ = [{lam[0]:.1f} ± {std[0]}, {lam[1] * 1e3:.1f} ± {std[1]} mm, "
                 f"{lam[2] * 1e3:.1f} ± {std[2]} mm], μ_c = {summary['mu_c']:.2f}: whole push "
                 f"{summary['whole_push_error_mm']:.1f} mm / {summary['whole_push_error_deg']:.1f}°", fontsize=9)
    fig.tight_layout()
    if path is not None:
        save_figure_atomic(fig, path, dpi=110)
    return fig


def plot_shapes(shapes: list[Shape], path: str | os.PathLike | None = None, normals: int = 24) -> plt.Figure:
    """Each shape's footprint, pusher-inflated contour and inward normals n̂ (eq. 1)."""
    fig, axes = plt.subplots(1, len(shapes), figsize=(4 * len(shapes), 4))
    for ax, shape in zip(np.atleast_1d(axes), shapes):
        _draw_pose(ax, shape, np.zeros(3), fc="0.8", ec="k")
        c = shape.contour_points(720)
        ax.plot(*np.vstack([c, c[:1]]).T, "b-", lw=1.2, label=f"contour (ρ = {shape.pusher_radius * 1000:.0f} mm)")
        phi = np.linspace(-np.pi, np.pi, normals, endpoint=False)
        r, dr = (np.asarray(a, np.float64) for a in shape.contour(phi))
        n = np.stack([-dr[:, 1], dr[:, 0]], -1) / np.linalg.norm(dr, axis=-1, keepdims=True)
        ax.quiver(r[:, 0], r[:, 1], n[:, 0], n[:, 1], color="r", scale=25, width=0.006, label="inward normal n̂")
        ax.plot(0, 0, "k+", ms=10, label="reference {B}")
        ax.set_aspect("equal")
        ax.set_title(shape.name)
        ax.grid(alpha=0.3)
        lim = shape.bounding_radius + 0.02
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
    np.atleast_1d(axes)[0].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    if path is not None:
        save_figure_atomic(fig, path, dpi=130)
    return fig


def plot_mode_decisions(per_object: dict, mu: float, path: str | os.PathLike | None = None) -> plt.Figure:
    """The paper's Fig. 6: mode-decision vectors Γ⁻¹w coloured by the observed mode.

    Vectors are normalised to unit length (only their direction decides the mode). The
    black lines are the friction-cone edges [1, ±μ_c]; the dashed grey rays are each
    sample's sliding/free boundary ±Γ⁻¹η, which moves with φ_c.
    """
    names = sorted(per_object)
    fig, axes = plt.subplots(1, len(names), figsize=(5 * len(names), 4.8), squeeze=False)
    for ax, name in zip(axes[0], names):
        d = per_object[name]
        a = d["decision"] / np.linalg.norm(d["decision"], axis=-1, keepdims=True)
        g = d["boundary"] / np.linalg.norm(d["boundary"], axis=-1, keepdims=True)
        for gi in g[:: max(1, len(g) // 60)]:
            ax.plot([-gi[0], gi[0]], [-gi[1], gi[1]], color="0.6", lw=0.5, ls="--", alpha=0.5)
        for m, mode in enumerate(SINGLE_MODES):
            sel = d["observed"] == m
            ax.scatter(a[sel, 0], a[sel, 1], s=12, color=MODE_COLORS[mode], label=f"observed {mode} ({sel.sum()})",
                       alpha=0.8, edgecolors="none")
        for sgn in (1, -1):
            v = np.array([1.0, sgn * mu]) / np.hypot(1, mu)
            ax.plot([0, 1.3 * v[0]], [0, 1.3 * v[1]], "k-", lw=1.5)
        ax.plot([], [], "k-", label=f"friction cone [1, ±{mu}]")
        ax.plot([], [], color="0.6", ls="--", label="boundary ±Γ⁻¹η (per sample)")
        agree = np.trace(d["confusion"]) / len(d["observed"])
        ax.set_title(f"{name}: β = {d['beta']:.1f} 1/m, mode agreement {agree:.0%}", fontsize=9)
        ax.set_xlabel("(Γ⁻¹w)₀ / |Γ⁻¹w|  (normal)")
        ax.set_ylabel("(Γ⁻¹w)₁ / |Γ⁻¹w|  (tangential)")
        ax.set_aspect("equal")
        ax.set_xlim(-1.3, 1.3)
        ax.set_ylim(-1.3, 1.3)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    if path is not None:
        save_figure_atomic(fig, path, dpi=130)
    return fig


def plot_confusion(per_object: dict, path: str | os.PathLike | None = None) -> plt.Figure:
    """Observed (rows) against predicted (columns) contact modes, per object."""
    names = sorted(per_object)
    fig, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 3.8), squeeze=False)
    for ax, name in zip(axes[0], names):
        cm = per_object[name]["confusion"]
        ax.imshow(cm, cmap="Blues")
        for i in range(4):
            for j in range(4):
                ax.text(j, i, str(cm[i, j]), ha="center", va="center", fontsize=9,
                        color="w" if cm[i, j] > cm.max() / 2 else "k")
        ax.set_xticks(range(4), SINGLE_MODES, rotation=30, fontsize=8)
        ax.set_yticks(range(4), SINGLE_MODES, fontsize=8)
        ax.set_xlabel("predicted by the C-GVMM")
        ax.set_ylabel("observed")
        ax.set_title(name)
    fig.tight_layout()
    if path is not None:
        save_figure_atomic(fig, path, dpi=130)
    return fig


def plot_params(params: np.ndarray, truth: object | None, path: str | os.PathLike | None = None,
                dt: float = CONTROL_PERIOD_S, title: str = "") -> plt.Figure:
    """β, x_bf and y_bf the controller planned with, against time, with λ_true (``truth``;
    None for a world without one, such as the physics plant)."""
    params = np.asarray(params)
    t = np.arange(len(params)) * dt
    fig, axes = plt.subplots(3, 1, figsize=(6, 5), sharex=True)
    labels = ("β (1/m)", "x_bf (mm)", "y_bf (mm)")
    scale = (1.0, 1000.0, 1000.0)
    for i, ax in enumerate(axes):
        ax.plot(t, params[:, i] * scale[i], "b-", lw=1.2, label="estimate")
        if truth is not None:
            ax.axhline(np.asarray(truth)[i] * scale[i], color="k", ls="--", lw=1, label="λ_true")
        ax.set_ylabel(labels[i])
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[0].set_title(title, fontsize=9)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    if path is not None:
        save_figure_atomic(fig, path, dpi=130)
    return fig


def plot_online_lambda(traces: dict, path: str | os.PathLike | None = None) -> plt.Figure:
    """λ_pred over a session of recorded pushes per object (``validate-mit --online``): β, x_bf, y_bf
    (and μ_c, where the traces have a 4th column) against time; ``traces`` maps a name to
    (time (T,), λ_pred (T, 3) or (T, 4))."""
    rows = max(np.asarray(lam).shape[1] for _, lam in traces.values())
    fig, axes = plt.subplots(rows, 1, figsize=(7, 1.8 * rows + 0.1), sharex=True)
    labels = ("β (1/m)", "x_bf (mm)", "y_bf (mm)", "μ_c")
    scale = (1.0, 1000.0, 1000.0, 1.0)
    for name, (t, lam) in sorted(traces.items()):
        lam = np.asarray(lam)
        for i in range(lam.shape[1]):
            axes[i].plot(t, lam[:, i] * scale[i], label=name)
    for ax, label in zip(axes, labels):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("session time (s): the object's pushes one after another")
    fig.tight_layout()
    if path is not None:
        save_figure_atomic(fig, path, dpi=130)
    return fig

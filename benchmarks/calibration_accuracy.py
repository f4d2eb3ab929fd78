"""How well ``dexpush calibrate`` places a camera, on rendered images of a board against the true camera.

    python benchmarks/calibration_accuracy.py

For each camera of each set-up (dexpush.world.rendered_camera.SETUPS): the pose from a 7 × 5 ChArUco
board of 5 cm squares and from a single 10 cm marker, each lying flat on the table, with the true
intrinsics (as a camera's maker gives them); the error of the camera's position (mm) and axes (degrees),
the reprojection error (px) and the largest error this puts on a table point seen at the objects' height
(mm, over a grid of the workspace). Then the intrinsics of the top camera from six tilted views of a
9 × 6 board of 6 cm squares. Prints Markdown tables and a JSON line.
"""

from __future__ import annotations

import json
import math

import numpy as np

from dexpush.perception.calibration import Board, calibrate_extrinsics, calibrate_intrinsics
from dexpush.world.rendered_camera import SETUPS, RenderSettings, board_images, setup_cameras

CHARUCO = Board(squares=(7, 5), square_m=0.05, marker_m=0.037, pose=(0.15, 0.3, 0.0))
MARKER = Board(kind="marker", square_m=0.1, marker_id=3, pose=(0.3, 0.15, 20.0))


def _errors(est, true) -> dict:
    angle = math.degrees(math.acos(np.clip((np.trace(est.rotation.T @ true.rotation) - 1) / 2, -1, 1)))
    gx, gy = np.meshgrid(np.linspace(-0.1, 0.7, 9), np.linspace(-0.1, 0.4, 6))
    pts = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, 0.0224)], 1)
    px = true.project(pts)
    table = float(np.max(np.linalg.norm(est.on_plane(px, 0.0224) - pts[:, :2], axis=1)))
    return {"position_mm": float(np.linalg.norm(est.position - true.position)) * 1e3, "axes_deg": angle,
            "reprojection_px": float(est.reprojection_error_px), "table_point_mm_max": table * 1e3}


def main() -> None:
    rows = []
    print("| set-up | camera | board | position error mm | axes error ° | reprojection px | table point error mm "
          "(max) |\n|---|---|---|---|---|---|---|")
    for setup in SETUPS:
        for cam in setup_cameras(RenderSettings(setup=setup)):
            for board in (CHARUCO, MARKER):
                est = calibrate_extrinsics(board_images(board, cam)[0], cam, board)
                r = {"setup": setup, "camera": cam.name, "board": board.kind, **_errors(est, cam)}
                rows.append(r)
                print(f"| {setup} | {cam.name} | {board.kind} | {r['position_mm']:.2f} | {r['axes_deg']:.3f} | "
                      f"{r['reprojection_px']:.3f} | {r['table_point_mm_max']:.2f} |", flush=True)
    cam = setup_cameras(RenderSettings(setup="top"))[0]
    board = Board(squares=(9, 6), square_m=0.06, marker_m=0.045, pose=(0.03, 0.33, 0.0))
    tilts = [(25, 0, 0), (-25, 0, 0), (0, 25, 0), (0, -25, 0), (20, 20, 15), (-20, 15, -15)]
    est = calibrate_intrinsics(board_images(board, cam, tilts, lift_m=0.6)[1:], board)
    intr = {"fx_error_pct": 100 * (est.fx / cam.fx - 1), "fy_error_pct": 100 * (est.fy / cam.fy - 1),
            "cx_error_px": est.cx - cam.cx, "cy_error_px": est.cy - cam.cy, "rms_px": est.reprojection_error_px}
    print("\n| intrinsics (top, 6 tilted views) | fx error % | fy error % | cx error px | cy error px | RMS px |\n"
          f"|---|---|---|---|---|---|\n| 9 × 6 ChArUco, 6 cm | {intr['fx_error_pct']:.3f} | {intr['fy_error_pct']:.3f} "
          f"| {intr['cx_error_px']:.2f} | {intr['cy_error_px']:.2f} | {intr['rms_px']:.3f} |")
    print(json.dumps({"extrinsics": rows, "intrinsics": intr}))


if __name__ == "__main__":
    main()

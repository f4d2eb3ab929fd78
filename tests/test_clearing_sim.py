"""Grasps on the simulated FR3 (``make test-franka``: loopback only): the arm's kinematics, a cup picked from
above into the bin, a plate that overhangs the edge grasped by its rim and lifted level, and the whole
clearing through ``dexpush clear`` (slow)."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("franky_sim")
pytest.importorskip("franky")
pytest.importorskip("pinocchio")

from dexpush.experiments.clearing import LIFT_KEPT, ClearingScene
from dexpush.robot.arm_kinematics import ArmKinematics
from dexpush.robot.pick import hand_down, hand_level

pytestmark = pytest.mark.franka

HOME = np.array([0.0, 0.0, 0.0, -1.57, 0.0, 1.57, 0.785])


def test_inverse_kinematics_reaches_the_grasp_poses_and_refuses_what_is_out_of_reach() -> None:
    kin = ArmKinematics()
    for R, p in ((hand_level([1.0, 0.0]), [0.48, -0.12, 0.0045]), (hand_down(np.pi), [0.68, 0.25, 0.045])):
        q = kin.ik(R, p, HOME)
        R2, p2 = kin.fk(q)
        assert np.allclose(p2, p, atol=1e-4) and np.allclose(R2, R, atol=1e-3)
        assert np.all(q >= kin.lower) and np.all(q <= kin.upper)
    with pytest.raises(ValueError, match="out of the arm's reach"):
        kin.ik(hand_down(0.0), [1.5, 0.0, 0.0], HOME)


def _wait(world, seconds: float) -> None:
    end = world.time + seconds
    while world.time < end:
        time.sleep(0.01)


@pytest.fixture(scope="module")
def cell():
    """The clearing scene on the simulated FR3, the plate already overhanging the edge by 6.5 cm."""
    import franky

    from dexpush.robot.franka_sim import FrankaSim, SimSettings
    from dexpush.robot.franky_driver import FrankyDriver
    from dexpush.robot.pick import Picker

    scene = ClearingScene()
    frames = scene.frames()
    sim = SimSettings(physics=scene.physics(), driver=frames, tool="fingers", tabletop=scene.tabletop())
    with FrankaSim(scene.shape(), (), sim) as world:
        world.place((scene.table[2] + 0.065 - scene.plate_radius, 0.08, 0.3))
        driver = FrankyDriver(world.address, frames, realtime=False)
        picker = Picker(driver.robot, franky.Gripper(world.address), frames, scene.pick)
        yield scene, sim, world, picker
        driver.close()


def test_a_cup_picked_from_above_ends_in_the_bin(cell) -> None:
    scene, _, world, picker = cell
    cup = next(p for p in scene.props if p.name == "cup")
    x, y, _, _ = world.bodies()["cup"]
    assert picker.pick_from_above((x, y), cup.height, 2 * cup.size)
    assert world.bodies()["cup"][2] > cup.height / 2 + 0.1                # it rose with the hand
    picker.drop_into(scene.bin)
    _wait(world, 1.0)
    assert scene.bin.holds(world.bodies()["cup"][:3])


def test_a_plate_over_the_edge_is_grasped_by_its_rim_lifted_level_and_dropped_in_the_bin(cell) -> None:
    scene, sim, world, picker = cell
    x, y, z0, _ = world.bodies()["object"]
    height = sim.physics.support_radius + scene.plate_thickness / 2
    overhang = x + scene.plate_radius - scene.table[2]
    assert picker.pick_rim([scene.table[2], y], [1.0, 0.0], height, scene.plate_thickness, overhang)
    assert picker.gripper.width < 2 * scene.plate_thickness          # the pads closed on the plate, not its rim
    picker.lift(scene.lift_m)
    _wait(world, 1.0)
    x, y, z, tilt = world.bodies()["object"]
    assert z - z0 >= LIFT_KEPT * scene.lift_m and tilt < 10.0
    tcp = scene.frames().to_table(picker.tcp()[1][:2])
    picker.drop_into(scene.bin, carried=np.array([x, y]) - tcp)
    _wait(world, 1.5)
    assert scene.bin.holds(world.bodies()["object"][:3])


def test_a_bad_seed_is_one_line() -> None:
    r = subprocess.run([sys.executable, "-m", "dexpush.cli", "clear", "--seed", "-1"], capture_output=True, text=True)
    assert r.returncode == 2 and "seed" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.slow
def test_dexpush_clear_clears_the_table_and_films_it(tmp_path: Path) -> None:
    r = subprocess.run([sys.executable, "-m", "dexpush.cli", "clear", "--seed", "1000", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=900)
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    record = json.loads((tmp_path / "clearing.json").read_text())
    assert summary["success"] == record["success"]
    assert record["overhang"] and not record["dropped"] and record["push"]["collisions"] == 0
    assert record["robot"]["reflex_limit_steps"] == 0
    assert Path(summary["files"]["video"]).stat().st_size > 10_000

"""The simulated Franka over the libfranka protocol (franky-sim + franky-control, the ``franka`` extra), on
loopback: a short episode, the faults of docs/robot.md#faults, and what the simulator binds.

One episode carries the faults that let it go on (the camera stops for 1 s, the object is knocked by
3 cm, the loop stalls past the planner's deadline, the markers are hidden for 2 s) and ends with a
Ctrl-C; a second loses the connection. Each test reads one of them.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("franky_sim")
pytest.importorskip("franky")

from dexpush.experiments.registry import make_shape
from dexpush.experiments.robot_trial import RobotSettings, run_robot_episode
from dexpush.experiments.scenarios import get_task
from dexpush.robot.driver import RobotError
from dexpush.world.sensing import SensorSettings

pytestmark = pytest.mark.franka

T = 0.04
CAMERA_OFF = range(25, 50)        # 1 s without frames
KNOCK = 75                        # the object moves 3 cm
STALL = 100                       # the loop hangs 0.6 s (wall)
HIDDEN = range(130, 180)          # 2 s with the markers hidden
INTERRUPT = 200


@dataclasses.dataclass(frozen=True)
class BlackoutSensor:
    """The noise-model camera, delivering nothing during the steps in ``off``."""

    inner: SensorSettings = dataclasses.field(default_factory=SensorSettings.realistic)
    off: tuple[range, ...] = (CAMERA_OFF, HIDDEN)
    seed: int = 0

    @property
    def rate_hz(self) -> float | None:
        return self.inner.rate_hz

    @property
    def perfect(self) -> bool:
        return False

    def describe(self) -> str:
        return self.inner.describe() + " with blackouts"

    def camera(self, plant: object, obstacles: object = ()) -> object:
        return _Blackout(dataclasses.replace(self.inner, seed=self.seed).camera(plant, obstacles), self.off)


class _Blackout:
    def __init__(self, camera: object, off: tuple[range, ...]) -> None:
        self.camera, self.off, self.k = camera, off, 0

    def reset(self, *a: object) -> object:
        self.k = 0
        return self.camera.reset(*a)

    def step(self, *a: object) -> object:
        frame = self.camera.step(*a)
        self.k += 1
        return None if any(self.k in r for r in self.off) else frame

    def __getattr__(self, name: str) -> object:
        return getattr(self.camera, name)


@pytest.fixture(scope="module")
def faulted() -> dict:
    log: dict = {"tip": {}, "stall": [], "held_after_knock": None}

    def on_step(k: int, plant: object, sim: object, guarded: object) -> None:
        log["tip"][k] = (sim.time, sim.tip())
        log["plant"], log["guarded"] = plant, guarded
        if k == KNOCK:
            log["held_before_knock"] = guarded.guard.held
            sim.knock((0.03, 0.0))
        if k == KNOCK + 4:
            log["held_after_knock"] = guarded.guard.held
        if k == STALL:
            sent = log["stall_sent"] = plant._sent_at     # the last command's time on the robot's clock
            t0 = time.monotonic()
            while time.monotonic() - t0 < 0.6:
                log["stall"].append((sim.time - sent, sim.tip()))
                time.sleep(0.01)
            log["late_before"] = plant.late_steps
        if k == STALL + 3:
            log["late_after"] = plant.late_steps
        if k == INTERRUPT:
            raise KeyboardInterrupt

    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        run_robot_episode(get_task("II"), make_shape("rect"), params="unknown", method="mppi-ukf", seed=1,
                          sensor=BlackoutSensor(), robot=RobotSettings(), max_steps=400, on_step=on_step)
    log["wall_s"] = time.monotonic() - t0
    return log


def _speed(log: dict, steps: range) -> np.ndarray:
    tips = log["tip"]
    return np.array([np.linalg.norm(tips[k + 1][1][:2] - tips[k][1][:2]) / (tips[k + 1][0] - tips[k][0])
                     for k in steps if k in tips and k + 1 in tips])


def test_the_episode_ran_on_loopback_and_stopped_on_ctrl_c(faulted: dict) -> None:
    plant = faulted["plant"]
    assert max(faulted["tip"]) == INTERRUPT
    assert plant.driver.stops >= 1 and plant._closed          # Ctrl-C: stopped softly, then closed
    assert plant.driver.address.startswith("127.")


def test_the_camera_stopping_stops_the_robot_which_then_resumes(faulted: dict) -> None:
    # frame_timeout_s (0.5 s, 13 periods) after the last frame the command is zero
    stopped = _speed(faulted, range(CAMERA_OFF.start + 16, CAMERA_OFF.stop - 1))
    assert np.all(stopped < 0.002), stopped
    assert faulted["guarded"].blind >= 10
    resumed = _speed(faulted, range(CAMERA_OFF.stop + 2, CAMERA_OFF.stop + 20))
    assert resumed.max() > 0.01


def test_hidden_markers_for_two_seconds_stop_the_robot_too(faulted: dict) -> None:
    stopped = _speed(faulted, range(HIDDEN.start + 16, HIDDEN.stop - 1))
    assert np.all(stopped < 0.002), stopped


def test_a_knocked_object_is_held_back_once_then_followed(faulted: dict) -> None:
    assert faulted["held_after_knock"] >= faulted["held_before_knock"] + 1


def test_a_stalled_loop_is_stopped_by_the_watchdog_within_a_tenth_of_a_second_of_its_deadline(faulted: dict) -> None:
    plant = faulted["plant"]
    assert plant.watchdog_stops >= 1 and plant.watchdog.last_trip_late_s <= 0.1
    # and the robot is at rest soon after the stop was sent: braking, plus the simulator's lag behind
    # the client (franky-sim steps in Python; a real Franka answers within its 1 ms cycle)
    stop_at = plant.last_watchdog_stop_at + plant._t0 - faulted["stall_sent"]
    samples = faulted["stall"]
    times = np.array([t for t, _ in samples])
    tips = np.array([p[:2] for _, p in samples])
    moving = np.linalg.norm(np.diff(tips, axis=0), axis=1) / np.maximum(np.diff(times), 1e-6) > 0.001
    last_moving = times[1:][moving].max() if moving.any() else 0.0
    assert last_moving - stop_at <= 0.2, (last_moving, stop_at)
    assert faulted["late_after"] >= faulted["late_before"] + 1   # the step after the stall missed its deadline


def test_a_lost_connection_ends_the_episode_cleanly_with_a_message() -> None:
    def on_step(k: int, plant: object, sim: object, guarded: object) -> None:
        if k == 15:
            sim._proc.kill()

    t0 = time.monotonic()
    with pytest.raises(RobotError, match="connection"):
        run_robot_episode(get_task("I"), make_shape("rect"), params="unknown", method="mppi-ukf", seed=0,
                          sensor=SensorSettings.realistic(), max_steps=100, on_step=on_step)
    assert time.monotonic() - t0 < 60


def _bound_addresses(pid: int) -> list[str]:
    inodes = {os.readlink(f"/proc/{pid}/fd/{fd}")[8:-1] for fd in os.listdir(f"/proc/{pid}/fd")
              if os.readlink(f"/proc/{pid}/fd/{fd}").startswith("socket:")}
    out = []
    for table in ("tcp", "udp", "tcp6", "udp6"):
        path = Path(f"/proc/{pid}/net/{table}")
        for line in path.read_text().splitlines()[1:] if path.exists() else []:
            fields = line.split()
            if fields[9] in inodes:
                out.append(fields[1].split(":")[0])
    return out


def test_the_simulated_robot_binds_loopback_only() -> None:
    from dexpush.robot.franka_sim import FrankaSim
    from dexpush.robot.franky_driver import FrankyDriver

    with FrankaSim(make_shape("rect")) as sim:
        driver = FrankyDriver(sim.address, realtime=False)      # connected: its state socket is open too
        driver.send((0.0, 0.0))
        addresses = _bound_addresses(sim._proc.pid)
        driver.close()
    assert addresses and all(a == "0100007F" for a in addresses), addresses   # 127.0.0.1


def test_the_robot_command_runs_an_episode_and_writes_what_run_writes(tmp_path: Path) -> None:
    import json
    import subprocess
    import sys

    out = tmp_path / "robot"
    # Task IV: walls (prisms in the simulated world, keep-out polygons in the filter) and discs, in the arm's reach
    proc = subprocess.run([sys.executable, "-m", "dexpush.cli", "robot", "--sim", "--task", "IV", "--max-steps", "30",
                           "--no-animation", "--quiet", "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode in (0, 1), proc.stderr          # 1: not at the goal within 30 steps
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert summary["plant"] == "franka-sim" and summary["steps"] == 30
    robot = summary["robot"]
    assert robot["reflex_limit_steps"] == 0 and robot["joint_limit_steps"] == 0 and robot["workspace_exits"] == 0
    assert summary["collisions"] == 0
    for name in ("summary.json", "trajectory.png", "trajectory.npz", "push_log.csv"):
        assert (out / name).exists()
    from dexpush.data.push_logs import read_log

    pushes = read_log(out / "push_log.csv")
    assert len(pushes) >= 1



def test_the_rendered_camera_sees_the_robot_world_with_the_arm_in_it() -> None:
    """Rendered images of the simulated robot's own world: a short episode runs on the frames read from them;
    from the front (``oblique``) the pose read agrees with the simulated truth, and the images show the FR3."""
    from dexpush.robot.driver import RobotPlant
    from dexpush.robot.franka_sim import FrankaSim
    from dexpush.robot.franky_driver import FrankyDriver
    from dexpush.robot.robot_camera import RobotRenderSettings
    from dexpush.world.rendered_camera import RenderSettings

    shape = make_shape("rect")
    episode, _ = run_robot_episode(get_task("II"), shape, params="unknown", method="mppi-ukf", seed=1,
                                   sensor=RenderSettings(width=640, height=360), robot=RobotSettings(), max_steps=50)
    record = episode.record
    assert "rendered" in record.sensor
    assert record.frames["delivered"] >= 20 and record.frames["withheld"] <= 5, record.frames

    with FrankaSim(shape) as sim:
        sim.place((0.02, -0.01, 0.3))
        driver = FrankyDriver(sim.address, realtime=False)
        with RobotPlant(driver, sim) as plant:
            camera = RobotRenderSettings(width=640, height=360, world=sim, middle=(0.0, 0.0)).camera(plant)
            frame = camera.tracker.locate(camera.images(), 0.0, np.zeros(2))
            with_arm, without = camera.images()[0], camera.images(without_arm=True)[0]
            camera.close()
            truth = sim.object_pose()
        driver.close()
    assert frame is not None
    assert np.linalg.norm(frame.object_pose[:2] - truth[:2]) < 0.003
    assert abs(frame.object_pose[2] - truth[2]) < np.radians(1.5)
    drawn = np.abs(with_arm.astype(int) - without.astype(int)) > 40
    assert drawn.mean() > 0.005                # the arm is in the picture


def test_the_robot_benchmark_runs_the_arms_problem_without_the_arm(tmp_path) -> None:
    """``robot_sim.py --without-arm``: the placed, bounded problem on the physics plant, recorded with the way's
    room; a folder of another plant, reach, band or area is refused in one line. (It needs no franky; it is the robot
    benchmark's test, run with the robot's.)"""
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "robot_sim.py"
    base = [sys.executable, str(script), "--out", str(tmp_path), "--tasks", "I", "--shapes", "tee", "--seeds", "0"]
    proc = subprocess.run([*base, "--max-steps", "20", "--without-arm"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    (rec,) = [json.loads(line) for line in (tmp_path / "records.jsonl").read_text().splitlines()]
    assert rec["plant"] == "physics" and rec["steps"] == 20 and "robot" not in rec
    assert rec["way_room_m"] < 0 < 0.02 < rec["bent_way_room_m"] and rec["bend_m"] >= 0.05    # it fits bent
    assert rec["reach"] == [0.36, 0.8] and rec["workspace_margin"] == 0.4
    assert "| I | tee | 0/1 |" in (tmp_path / "table.md").read_text()
    filtered = tmp_path / "filtered"                                 # the robot's guard and filter on the bare plant
    proc = subprocess.run([*base[:3], str(filtered), *base[4:], "--max-steps", "20", "--without-arm", "--with-filter"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    (rec,) = [json.loads(line) for line in (filtered / "records.jsonl").read_text().splitlines()]
    assert rec["plant"] == "physics" and rec["filtered"] is True and rec["steps"] == 20
    for extra, message in (([], "another filter and libfranka cutoff and plant than this run's (filter on, libfranka "
                                "cutoff 1000.0, plant franka-sim)"),
                           (["--without-arm", "--reach", "0.3,0.9"], "another reach than this run's (reach (0.3, 0.9)"),
                           (["--reach", "0.5,0.4"], "expected 0 <= R_MIN < R_MAX"),
                           (["--with-filter"], "--with-filter goes with --without-arm"),
                           (["--without-arm", "--with-filter"], "another filter than this run's (filter on)")):
        proc = subprocess.run([*base, *extra], capture_output=True, text=True, timeout=120)
        assert proc.returncode != 0 and message in proc.stderr and "Traceback" not in proc.stderr
    chord = tmp_path / "chord"                           # a folder of the band before the annulus: refused too
    chord.mkdir()
    old = {k: v for k, v in rec.items() if k not in ("bent_way_room_m", "bend_m")}
    (chord / "records.jsonl").write_text(json.dumps(old) + "\n")
    proc = subprocess.run([*base[:3], str(chord), *base[4:], "--without-arm", "--with-filter"], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode != 0 and "another band than this run's (band annulus)" in proc.stderr
    narrow = tmp_path / "narrow"                   # a folder of the 0.25-m area round the task: refused too
    narrow.mkdir()
    (narrow / "records.jsonl").write_text(json.dumps({k: v for k, v in rec.items() if k != "workspace_margin"}) + "\n")
    proc = subprocess.run([*base[:3], str(narrow), *base[4:], "--without-arm", "--with-filter"], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode != 0 and "another area margin than this run's (area margin 0.4)" in proc.stderr


def test_the_simulator_speed_check_reports_its_factor_and_capacity() -> None:
    """``benchmarks/franka_sim_speed.py``: a fresh simulated FR3, idle, its real-time factor and step capacity."""
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "franka_sim_speed.py"
    proc = subprocess.run([sys.executable, str(script), "--seconds", "1", "--repeats", "1"], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    (run,) = json.loads(proc.stdout.strip().splitlines()[-1])["runs"]
    assert 0 < run["real_time_factor"] <= 1.05 and run["step_capacity"] >= run["real_time_factor"] - 1e-3

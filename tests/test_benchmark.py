"""The benchmark runner: resumable conditions, tables that agree with their records."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from dexpush.cli import main
from dexpush.control.controller import ControllerSettings
from dexpush.control.mppi import MPPISettings
from dexpush.control.settings import EndgameSettings, PredictionMarginSettings, StallSettings
from dexpush.experiments.benchmark import run_benchmark
from dexpush.experiments.records import summarize
from dexpush.experiments.tables import write_tables
from dexpush.problem.weights import CostWeights
from dexpush.world.sensing import SensorSettings


def test_benchmark_resumes_without_rerunning_recorded_trials(tmp_path: Path) -> None:
    run = partial(run_benchmark, tmp_path, ["I"], ["rect"], ["known"], ["mppi"], max_steps=5, lanes=2,
                  progress=False)
    first = run([0])
    assert first[0]["steps"] == 5 and first[0]["seed"] == 0 and first[0]["lanes"] == 2
    path = tmp_path / "conditions" / "I_rect_known_mppi.json"
    # mark the recorded trial: a resumed run must keep it, not run seed 0 again
    data = json.loads(path.read_text())
    data["trials"][0]["planning_ms_max"] = -1.0
    path.write_text(json.dumps(data))
    both = run([0, 1])
    assert [t["seed"] for t in both] == [0, 1]
    assert both[0]["planning_ms_max"] == -1.0
    assert [t["seed"] for t in json.loads(path.read_text())["trials"]] == [0, 1]
    with np.load(tmp_path / "trajectories" / "I_rect_known_mppi.npz") as npz:
        assert sorted(npz.files) == ["seed_0", "seed_1"] and npz["seed_1"].shape == (6, 5)
    assert (tmp_path / "figures" / "I_rect_known_mppi.png").stat().st_size > 0
    path.write_text("{broken")
    with pytest.raises(ValueError, match="not a dexpush condition file"):
        run([0])


def test_a_folder_refuses_runs_with_other_settings(tmp_path: Path) -> None:
    run_benchmark(tmp_path, ["I"], ["rect"], ["known"], ["mppi"], [0], max_steps=2, lanes=2, progress=False,
                  figures=False)
    saved = json.loads((tmp_path / "settings.json").read_text())
    assert saved["settings"]["plant"] == "model" and saved["settings"]["lanes"] == 2
    with pytest.raises(ValueError, match=r"other settings \(plant: 'model' there, 'physics' now"):
        run_benchmark(tmp_path, ["I"], ["rect"], ["known"], ["mppi"], [0], max_steps=2, lanes=2, progress=False,
                      plant="physics", sensor=SensorSettings.realistic())
    with pytest.raises(ValueError, match="max_steps: 2 there, 3 now"):
        run_benchmark(tmp_path, ["I"], ["rect"], ["known"], ["mppi"], [0], max_steps=3, lanes=2, progress=False)
    assert main(["bench", "--tasks", "I", "--shapes", "rect", "--params", "known", "--methods", "mppi",
                 "--seeds", "0", "--max-steps", "9", "--lanes", "2", "--quiet", "--out", str(tmp_path)]) == 2
    # an older dexpush wrote the controller's settings as one flat table, without the options it did not have
    # yet: such a folder is read in today's groups, with each missing option off (the stall watch and the
    # detour are on by default now) and a newer setting at its default
    controller = saved["settings"]["controller"]
    for group in ("stall", "endgame", "proposals", "prediction_margin"):
        del controller[group]
    controller["stall_backoff"] = 2.0
    for key in ("detour", "C_margin"):
        del saved["settings"]["controller"]["weights"][key]
    del saved["settings"]["controller"]["mppi"]["update"]
    (tmp_path / "settings.json").write_text(json.dumps(saved))
    with pytest.raises(ValueError, match=r"endgame.temperature: None there, 0.005 now; controller.mppi.update: "
                                         r"'clipped' there, 'sampled' now; controller.prediction_margin.gain: "
                                         r"0.0 there, 0.5 now; …"):
        run_benchmark(tmp_path, ["I"], ["rect"], ["known"], ["mppi"], [0], max_steps=2, lanes=2, progress=False,
                      figures=False)
    run_benchmark(tmp_path, ["I"], ["rect"], ["known"], ["mppi"], [0], max_steps=2, lanes=2, progress=False,
                  figures=False, settings=ControllerSettings(weights=CostWeights(detour=False, C_margin=None),
                                                             stall=StallSettings(after_s=None),
                                                             endgame=EndgameSettings(temperature=None),
                                                             mppi=MPPISettings(update="clipped"),
                                                             prediction_margin=PredictionMarginSettings(gain=0.0)))


def test_a_folder_from_before_the_spread_cap_guidance_and_push_plan_reads_them_as_off(tmp_path: Path) -> None:
    """A settings.json written before these options existed (the physics table of 2026-12-02 lacks them, and every
    table before 2026-12-08 the obstacle cost under the start): their records were made without them, so a run
    with today's defaults (all on) is refused, not mixed in."""
    from dexpush.experiments.results_folder import run_settings, saved_settings

    wanted = run_settings("model", None, None, 2, 2)
    controller = json.loads(json.dumps(wanted["controller"]))
    del controller["mppi"]["spread_cap"], controller["push_plan"], controller["obstacles_under_start"]
    for key in ("guidance", "guidance_goal_heading"):
        del controller["weights"][key]
    (tmp_path / "settings.json").write_text(json.dumps({"settings": {**wanted, "controller": controller}}))
    read = saved_settings(tmp_path / "settings.json", wanted["controller"])["controller"]
    assert read["mppi"]["spread_cap"] is None and read["push_plan"]["enabled"] is False
    assert read["push_plan"]["endgame"]["enabled"] is False and read["obstacles_under_start"] is False
    assert read["weights"]["guidance"] is False and read["weights"]["guidance_goal_heading"] is False
    assert read["push_plan"]["targets"] == wanted["controller"]["push_plan"]["targets"]   # the rest at today's
    with pytest.raises(ValueError, match=r"other settings \(controller.mppi.spread_cap: None there, 1000000.0 now"):
        run_benchmark(tmp_path, ["I"], ["rect"], ["known"], ["mppi"], [0], max_steps=2, lanes=2, progress=False,
                      figures=False)


def test_bench_turns_the_default_options_off_and_says_so_in_its_command(tmp_path: Path) -> None:
    assert main(["bench", "--tasks", "I", "--shapes", "rect", "--params", "known", "--methods", "mppi", "--seeds", "0",
                 "--max-steps", "2", "--lanes", "1", "--no-detour", "--stall-after", "off", "--temperature", "0.05",
                 "--endgame-temperature", "off", "--margin-cost", "off", "--mppi-update", "clipped",
                 "--contact-proposals", "4", "--no-push-plan", "--no-endgame-push", "--prediction-margin", "0.25",
                 "--stall-horizon", "1.5", "--samples", "64", "--no-figures", "--quiet",
                 "--out", str(tmp_path)]) == 0
    controller = json.loads((tmp_path / "settings.json").read_text())["settings"]["controller"]
    assert controller["weights"]["detour"] is False and controller["stall"]["after_s"] is None
    assert controller["mppi"]["temperature"] == 0.05 and controller["endgame"]["temperature"] is None
    assert controller["weights"]["C_margin"] is None
    assert controller["mppi"]["update"] == "clipped" and controller["proposals"]["count"] == 4
    assert controller["push_plan"]["enabled"] is False and controller["push_plan"]["endgame"]["enabled"] is False
    assert controller["prediction_margin"]["gain"] == 0.25 and controller["stall"]["horizon_scale"] == 1.5
    assert controller["mppi"]["num_samples"] == 64
    command = ("--no-detour --stall-after off --temperature 0.05 --endgame-temperature off --margin-cost off "
               "--contact-proposals 4 --no-push-plan --no-endgame-push --mppi-update clipped --prediction-margin 0.25 "
               "--stall-horizon 1.5 --samples 64")
    assert command in (tmp_path / "benchmark.md").read_text()
    for bad in (["--stall-after", "0"], ["--temperature", "0"], ["--temperature", "nan"],
                ["--endgame-temperature", "-1"], ["--margin-cost", "0"], ["--mppi-update", "mean"],
                ["--prediction-margin", "-0.5"], ["--stall-horizon", "0.5"], ["--samples", "0"]):
        with pytest.raises(SystemExit):
            main(["bench", *bad, "--out", str(tmp_path)])


def test_an_interrupted_run_keeps_every_finished_trials_trajectory(tmp_path: Path, monkeypatch) -> None:
    import dexpush.experiments.benchmark as bench

    real = bench.simulate

    def interrupted(*args, on_result, **kwargs):
        def first_then_stop(result):
            on_result(result)
            raise KeyboardInterrupt
        return real(*args, on_result=first_then_stop, **kwargs)

    monkeypatch.setattr(bench, "simulate", interrupted)
    run = partial(run_benchmark, tmp_path, ["I"], ["rect"], ["known"], ["mppi"], max_steps=3, lanes=2,
                  progress=False)
    with pytest.raises(KeyboardInterrupt):
        run([0, 1])
    recorded = [t["seed"] for t in json.loads((tmp_path / "conditions" / "I_rect_known_mppi.json").read_text())
                ["trials"]]
    with np.load(tmp_path / "trajectories" / "I_rect_known_mppi.npz") as npz:
        assert len(recorded) == 1 and npz.files == [f"seed_{recorded[0]}"]
    monkeypatch.setattr(bench, "simulate", real)
    run([0, 1])                                   # resumed: runs the other seed only, keeps both paths
    with np.load(tmp_path / "trajectories" / "I_rect_known_mppi.npz") as npz:
        assert sorted(npz.files) == ["seed_0", "seed_1"]


def test_the_tables_cover_every_trial_in_the_folder(tmp_path: Path, capsys) -> None:
    common = ["bench", "--tasks", "I", "--shapes", "rect", "--params", "known", "--methods", "mppi",
              "--max-steps", "2", "--lanes", "2", "--quiet", "--out", str(tmp_path)]
    assert main([*common, "--seeds", "0-1"]) == 0
    assert main([*common, "--seeds", "1"]) == 0        # a re-run of one seed does not shrink the table
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["trials"] == 1
    saved = json.loads((tmp_path / "benchmark.json").read_text())
    assert [t["seed"] for t in saved["trials"]] == [0, 1] and saved["summary"][0]["trials"] == 2
    assert "earlier runs" in (tmp_path / "benchmark.md").read_text()


def test_rerunning_one_seed_reproduces_its_record(tmp_path: Path) -> None:
    """Seed 1 run beside seed 0 and then alone (same lanes) gives the same record, bit for bit."""
    common = dict(max_steps=40, lanes=2, progress=False, figures=False)
    both = run_benchmark(tmp_path / "a", ["II"], ["rect"], ["unknown"], ["mppi-ukf"], [0, 1], **common)
    alone = run_benchmark(tmp_path / "b", ["II"], ["rect"], ["unknown"], ["mppi-ukf"], [1], **common)
    timing = {"planning_ms_median", "planning_ms_max"}
    strip = [{k: v for k, v in r.items() if k not in timing} for r in (both[1], alone[0])]
    assert strip[0] == strip[1]
    assert strip[0]["diagnostics"]["params_estimate"] != [15.0, 0.0, 0.0]   # the UKF did move λ


def test_tables_agree_with_records(tmp_path: Path) -> None:
    records = [
        dict(task="I", shape="rect", params="known", method="mppi", seed=s, success=ok, steps=n, time_s=n * 0.04,
             object_path_m=op, pusher_path_m=pp, planning_ms_median=2.0, planning_ms_max=9.0)
        for s, ok, n, op, pp in [(0, True, 100, 0.7, 1.0), (1, False, 1500, 0.2, 2.0), (2, True, 300, 0.9, 1.4)]
    ]
    for r, stalls in zip(records, (0, 3, 1), strict=True):   # MPPI records count stall restarts
        r["diagnostics"] = {"stall_resets": stalls}
    gcs = dict(records[0], method="gcs", diagnostics={"offline_plan_s": 1.5, "replans": 2})   # GCS: plan times
    s = summarize(records)
    assert s["success_rate"] == pytest.approx(2 / 3, abs=1e-4) and s["successes"] == 2
    assert s["object_path_m"][0] == pytest.approx(0.8) and s["pusher_path_m"][0] == pytest.approx(1.2)
    assert s["time_to_goal_s"][0] == pytest.approx(8.0)
    assert s["offline_plan_s"] is None and summarize([gcs])["offline_plan_s"] == [1.5, 1.5]
    assert s["stall_resets_mean"] == pytest.approx(4 / 3, abs=0.01) and summarize([gcs])["stall_resets_mean"] is None
    files = write_tables(tmp_path, [*records, gcs], {"command": "test", "date": "today", "machine": "here"})
    saved = json.loads(Path(files["json"]).read_text())
    assert saved["trials"] == [*records, gcs] and saved["summary"][0]["success_rate"] == s["success_rate"]
    md = Path(files["markdown"]).read_text()
    assert "| I | rect | known | mppi | 2/3 (67 %) | 0.800 ± 0.100 |" in md
    assert "| 2.0 / 9 | – | – | 1.3 |" in md and "| I | rect | known | gcs | 1/1 (100 %) |" in md
    assert md.strip().endswith("| 2.0 / 9 | 1.5 / 1.5 | 2.0 | – | – | – |")
    lines = Path(files["csv"]).read_text().strip().splitlines()
    assert len(lines) == 5 and lines[0].endswith(",diagnostics") and lines[1].endswith(',"{""stall_resets"": 0}"')
    # Task III records carry the trial's least clearance: the table gives the least and the median (mm)
    task3 = [dict(r, task="III", clearance_m=g) for r, g in zip(records, (0.012, -0.001, 0.03), strict=True)]
    assert summarize(task3)["clearance_m"] == [-0.001, 0.012]
    write_tables(tmp_path, task3, {"command": "test", "date": "today", "machine": "here"})
    assert Path(files["markdown"]).read_text().strip().endswith("| 1.3 | -1.0 / 12.0 | – |")
    # a camera's records count its frames: the table gives the share the perception withheld
    seen = [dict(r, frames={"captured": 100, "dropped": 0, "withheld": w, "delivered": 100 - w})
            for r, w in zip(records, (0, 6, 3), strict=True)]
    assert summarize(seen)["frames_withheld"] == pytest.approx(0.03) and summarize(records)["frames_withheld"] is None
    write_tables(tmp_path, seen, {"command": "test", "date": "today", "machine": "here"})
    assert Path(files["markdown"]).read_text().strip().endswith("| 1.3 | – | 3.0 % |")


def test_records_of_0_3_are_read_with_their_method_fields_as_diagnostics() -> None:
    from dexpush.experiments.results_folder import upgrade_record

    old = dict(task="I", seed=0, stall_resets=2, rejected_frames=None, offline_plan_s=None, clearance_m=None)
    assert upgrade_record(old) == dict(task="I", seed=0, clearance_m=None, diagnostics={"stall_resets": 2})
    assert upgrade_record(upgrade_record(old)) == upgrade_record(old)


def test_bench_cli_runs_a_tiny_table(tmp_path: Path, capsys) -> None:
    code = main(["bench", "--tasks", "II", "--shapes", "rect", "--params", "unknown", "--methods", "mppi-ukf",
                 "--trials", "1", "--max-steps", "5", "--lanes", "2", "--quiet", "--out", str(tmp_path)])
    assert code == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["trials"] == 1 and summary["conditions"] == 1
    rec = json.loads((tmp_path / "benchmark.json").read_text())["trials"][0]
    assert rec["method"] == "mppi-ukf" and len(rec["diagnostics"]["params_estimate"]) == 3
    assert main(["bench", "--shapes", "star", "--out", str(tmp_path)]) == 2


@pytest.mark.slow   # two spawned processes each import JAX and compile; nothing faster covers workers > 1
def test_worker_processes_record_what_one_process_records(tmp_path: Path) -> None:
    common = dict(max_steps=6, lanes=2, progress=False, figures=False)
    one = run_benchmark(tmp_path / "one", ["I", "II"], ["rect"], ["unknown"], ["mppi-ukf"], [0], **common)
    two = run_benchmark(tmp_path / "two", ["I", "II"], ["rect"], ["unknown"], ["mppi-ukf"], [0], workers=2,
                        **common)
    timing = {"planning_ms_median", "planning_ms_max"}
    assert [{k: v for k, v in r.items() if k not in timing} for r in one] == \
        [{k: v for k, v in r.items() if k not in timing} for r in two]


def test_pool_workers_end_when_the_benchmark_process_is_killed(tmp_path) -> None:
    """A killed ``dexpush bench`` must not leave workers running on (and writing records)."""
    script = tmp_path / "parent.py"
    script.write_text(
        "import multiprocessing, os, sys, time\n"
        "from concurrent.futures import ProcessPoolExecutor\n"
        "from dexpush.experiments.benchmark import exit_with_parent\n"
        "if __name__ == '__main__':\n"
        "    ex = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context('spawn'),\n"
        "                             initializer=exit_with_parent, initargs=(os.getpid(), 0.1))\n"
        "    print(ex.submit(os.getpid).result(), flush=True)\n"
        "    ex.submit(time.sleep, 60)\n"
        "    time.sleep(0.5)\n"
        "    os._exit(0)   # as if killed: no pool shutdown\n")
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120, check=True)
    worker = int(out.stdout.split()[0])
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        try:   # gone, or a zombie that nobody reaps (its parent is dead)
            if Path(f"/proc/{worker}/stat").read_text().split(")")[-1].split()[0] in "ZX":
                return
        except (FileNotFoundError, ProcessLookupError):
            return
        time.sleep(0.1)
    os.kill(worker, 9)
    raise AssertionError("the orphaned worker was still running 20 s after its parent died")


def test_records_label_a_trajectory_in_blocks_as_they_would_unpadded() -> None:
    """make_episode pads to LABEL_BLOCK steps (one compile per block count): the modes and
    touches it records are those of the trajectory itself."""
    import jax.numpy as jnp

    from dexpush.experiments.records import LABEL_BLOCK, Condition, make_episode
    from dexpush.experiments.registry import make_shape
    from dexpush.experiments.scenarios import get_task
    from dexpush.experiments.simulate import TrialResult, TrialSpec
    from dexpush.model.cgvmm import LAMBDA_TRUE, MODE_NAMES, Contour, contact_solution
    from dexpush.problem.obstacles import collides
    from dexpush.problem.scene import Scene

    task, shape = get_task("III"), make_shape("rect")
    rng = np.random.default_rng(3)
    n = LABEL_BLOCK + 37
    # the pusher sweeps past the box's back face (contact on and off) while the box drifts into the disc
    X = np.zeros((n + 1, 5))
    X[:, 0] = np.linspace(0.0, 0.3, n + 1)
    X[:, 3] = X[:, 0] - 0.06 + 0.01 * np.sin(np.arange(n + 1) / 9)
    X[:, 4] = 0.03 * rng.standard_normal(n + 1)
    U = rng.uniform(-0.05, 0.1, (n, 2))
    ep = make_episode(task.problem(shape), Condition(task.key, "rect", "known", "mppi"),
                      TrialResult(TrialSpec(0), False, X, U, np.zeros((n, 3)), np.ones(n)), 16)
    modes = np.asarray(contact_solution(Contour.of(shape), X[:-1], U, LAMBDA_TRUE).mode)
    hits = np.asarray(collides(jnp.asarray(X[1:], jnp.float32), Scene.make(shape, task.goal, task.obstacles)))
    np.testing.assert_array_equal(ep.modes, modes)
    in_contact = modes != MODE_NAMES.index("free")
    assert ep.record.contact_switches == int(np.sum(in_contact[1:] != in_contact[:-1])) > 0
    assert ep.record.collisions == int(hits.sum()) > 0
    # the record's clearance is the trajectory's smallest gap: below zero, since it touches
    from dexpush.experiments.records import summarize
    from dexpush.problem.obstacles import clearance
    gaps = np.asarray(clearance(jnp.asarray(X[1:], jnp.float32), Scene.make(shape, task.goal, task.obstacles)))
    assert ep.record.clearance_m == pytest.approx(float(gaps.min()), abs=1e-5) and ep.record.clearance_m < 0
    clear = make_episode(task.problem(shape), Condition(task.key, "rect", "known", "mppi"),
                         TrialResult(TrialSpec(1), False, X[:40], U[:39], np.zeros((39, 3)), np.ones(39)), 16)
    assert clear.record.clearance_m > 0
    assert summarize([ep.summary(), clear.summary()])["clearance_m"] == pytest.approx(
        [ep.record.clearance_m, 0.5 * (ep.record.clearance_m + clear.record.clearance_m)], abs=1e-5)
    result = TrialResult(TrialSpec(0), False, X, U, np.zeros((n, 3)), np.ones(n))
    no_obstacle = make_episode(get_task("I").problem(shape), Condition("I", "rect", "known", "mppi"), result, 16)
    assert no_obstacle.record.clearance_m is None and summarize([no_obstacle.summary()])["clearance_m"] is None


def test_longest_groups_run_first() -> None:
    from dexpush.experiments.benchmark import _expected_cost

    groups = [(t, s) for t in ("I", "II", "III") for s in ("rect", "tee")]
    ordered = sorted(groups, key=_expected_cost, reverse=True)
    assert ordered[0] == ("III", "tee") and ordered[-1][1] == "rect"
    assert ordered.index(("III", "rect")) < ordered.index(("I", "rect"))


def test_the_engine_is_checked_and_ray_is_asked_for_by_name(tmp_path, monkeypatch):
    kwargs = dict(tasks=["I"], shapes=["rect"], params=["known"], methods=["mppi"], seeds=[0], progress=False,
                  figures=False)
    with pytest.raises(ValueError, match="unknown engine 'spark'"):
        run_benchmark(tmp_path / "a", engine="spark", **kwargs)
    with pytest.raises(ValueError, match="engine='ray'"):
        run_benchmark(tmp_path / "b", address="10.0.0.1:6379", **kwargs)
    monkeypatch.setitem(sys.modules, "ray", None)            # import ray raises ImportError
    with pytest.raises(ImportError, match=r"pip install 'dexpush\[cluster\]'"):
        run_benchmark(tmp_path / "c", engine="ray", **kwargs)


def test_a_local_ray_instance_starts_only_in_a_loopback_only_namespace(tmp_path, monkeypatch):
    import types

    from dexpush.cli.main import main
    from dexpush.experiments import cluster

    monkeypatch.setitem(sys.modules, "ray", types.SimpleNamespace(is_initialized=lambda: False))
    monkeypatch.setattr(cluster, "why_not_loopback", lambda: "this process sees eth0")
    with pytest.raises(OSError, match="only in a loopback-only network namespace, and this process sees eth0"):
        cluster.run_on_ray(print, [((), {})], workers=1)
    # the command runs itself again in a new namespace; one that is still not loopback-only is refused
    import dexpush.common.netns as netns

    monkeypatch.setattr(netns, "why_not_loopback", lambda: "this process sees eth0")
    monkeypatch.setenv("DEXPUSH_IN_NAMESPACE", "1")
    assert main(["bench", "--tasks", "I", "--shapes", "rect", "--trials", "1", "--engine", "ray", "--quiet",
                 "--out", str(tmp_path / "b")]) == 2


def test_bench_diff_pairs_two_tables_trial_by_trial(tmp_path: Path, capsys) -> None:
    """``benchmarks/bench_diff.py`` counts the records that are the same (planning times aside), and gives each
    condition's success and mean time in both; a folder without a table is a one-line error."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("bench_diff", Path(__file__).resolve().parents[1] / "benchmarks"
                                                  / "bench_diff.py")
    bench_diff = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench_diff)

    def trial(seed: int, time_s: float, ms: float = 1.0, success: bool = True) -> dict:
        return {"task": "III", "shape": "rect", "params": "unknown", "method": "mppi-ukf", "seed": seed,
                "success": success, "steps": int(time_s / 0.04), "time_s": time_s, "object_path_m": 0.8,
                "pusher_path_m": 1.4, "final_error_m": 0.005, "final_error_deg": 1.0, "collisions": 0,
                "clearance_m": 0.01, "planning_ms_median": ms}

    for name, trials in (("old", [trial(0, 10.0), trial(1, 20.0), trial(2, 30.0)]),
                         ("new", [trial(0, 10.0, ms=9.0), trial(1, 16.0), trial(2, 60.0, success=False)])):
        (tmp_path / name).mkdir()
        (tmp_path / name / "benchmark.json").write_text(json.dumps({"trials": trials}))
    assert bench_diff.main([str(tmp_path / "old"), str(tmp_path / "new")]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert json.loads(out[-1]) == {"paired": 3, "same": 1, "only_old": 0, "only_new": 0, "old_success": 3,
                                   "new_success": 2}
    assert out[2] == "| III rect unknown mppi-ukf | 1/3 | 3 → 2 | 20.000 → 13.000 | -35.0 % |"
    with pytest.raises(SystemExit, match=r"^error: .*benchmark.json not found"):
        bench_diff.main([str(tmp_path / "old"), str(tmp_path)])

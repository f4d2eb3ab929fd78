"""The benchmark's groups as tasks on Ray (dexpush.experiments.cluster): the same records as the local pool,
bit for bit but for wall times. Needs Ray (the cluster extra); the local Ray instance binds 127.0.0.1, and
``make test-cluster`` runs it inside a loopback-only network namespace besides."""

import json

import pytest

pytestmark = pytest.mark.cluster

ray = pytest.importorskip("ray", reason="needs Ray: pip install -e '.[cluster]' (make test-cluster)")

from dexpush.common.netns import why_not_loopback  # noqa: E402
from dexpush.experiments.benchmark import run_benchmark  # noqa: E402

if (_why := why_not_loopback()) is not None:
    pytest.skip(f"the Ray tests run in a loopback-only network namespace (make test-cluster), and {_why}",
                allow_module_level=True)


def _records(folder):
    out = {}
    for path in sorted((folder / "conditions").glob("*.json")):
        data = json.loads(path.read_text())
        trials = data["trials"] if isinstance(data, dict) and "trials" in data else data
        out[path.stem] = [{k: v for k, v in t.items() if "_ms" not in k and "wall" not in k} for t in trials]
    return out


def test_a_benchmark_on_ray_records_what_the_local_pool_records(tmp_path):
    kwargs = dict(tasks=["I"], shapes=["rect", "tee"], params=["known"], methods=["mppi"], seeds=[0, 1],
                  progress=False, figures=False, workers=2, max_steps=300)
    run_benchmark(tmp_path / "ray", engine="ray", **kwargs)
    run_benchmark(tmp_path / "local", **kwargs)
    on_ray, local = _records(tmp_path / "ray"), _records(tmp_path / "local")
    assert set(on_ray) == {"I_rect_known_mppi", "I_tee_known_mppi"}
    assert on_ray == local

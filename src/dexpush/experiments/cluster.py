"""Work units of a benchmark as tasks on Ray (:func:`run_on_ray`), instead of the local process pool.

Each call runs as one Ray task with one CPU and one XLA thread (``NPROC=1``, as a local worker
has), so a group's records are the same bit for bit wherever it runs. The tasks write the
results folder themselves: on a cluster every node must see it at the same path (a shared file
system). Without an address a local Ray instance of ``workers`` CPUs is started on 127.0.0.1
(no dashboard, no usage statistics) and shut down after; its processes listen on every interface
whatever the node address, so it is started only inside a loopback-only network namespace
(:mod:`dexpush.common.netns`; ``dexpush bench --engine ray`` makes one and runs itself there);
with one (``ray://host:10001`` or ``host:6379``) the cluster's workers must have dexpush installed.
Ray is the ``cluster`` extra.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any

from dexpush.common.netns import why_not_loopback

__all__ = ["ENGINES", "run_on_ray"]

#: where a benchmark's groups run: local worker processes, or tasks on Ray
ENGINES = ("local", "ray")

#: the workers' environment: one XLA thread each (the tasks are the parallelism), no usage statistics sent
_WORKER_ENV = {"NPROC": "1", "RAY_USAGE_STATS_ENABLED": "0"}


def _require_ray() -> Any:
    try:
        import ray
    except ImportError:
        raise ImportError("--engine ray needs Ray: pip install 'dexpush[cluster]'") from None
    return ray


def run_on_ray(fn: Callable[..., object], calls: Sequence[tuple[tuple, dict]], *, workers: int,
               address: str | None = None) -> list[object]:
    """``fn(*args, **kwargs)`` for each ``(args, kwargs)`` in ``calls`` as Ray tasks; their results in order.

    ``workers``: the local instance's CPUs (without ``address``). A Ctrl-C cancels the tasks (what they
    saved stays saved) and is raised again.
    """
    ray = _require_ray()
    if address is None and (why := why_not_loopback()) is not None:
        raise OSError(f"a local Ray instance listens on every network interface, so dexpush starts one only in a "
                      f"loopback-only network namespace, and {why}: run it through `dexpush bench --engine ray` "
                      "(which makes one), or give a cluster's address")
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    started = not ray.is_initialized()
    if started:
        runtime_env = {"env_vars": dict(_WORKER_ENV)}
        try:
            if address is None:
                ray.init(num_cpus=workers, include_dashboard=False, _node_ip_address="127.0.0.1",
                         runtime_env=runtime_env, log_to_driver=True, logging_level="WARNING")
            else:
                ray.init(address=address, runtime_env=runtime_env, logging_level="WARNING")
        except (ConnectionError, RuntimeError, ValueError) as exc:
            where = address or "a local instance on 127.0.0.1"
            raise OSError(f"cannot start Ray ({where}): {exc}") from None
    try:
        remote = ray.remote(num_cpus=1, max_retries=0)(fn)
        refs = [remote.remote(*args, **kwargs) for args, kwargs in calls]
        try:
            return ray.get(refs)
        except KeyboardInterrupt:
            for ref in refs:
                ray.cancel(ref, force=True)
            raise
    finally:
        if started:
            ray.shutdown()

"""dexpush.common.xla_options: what importing dexpush sets for XLA, and when it leaves the process alone."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

PROBE = ("import json, os, dexpush; from dexpush import xla_options; "
         "print(json.dumps({'flags': os.environ.get('XLA_FLAGS'), 'nproc': os.environ.get('NPROC'), "
         "'active': xla_options.active()}))")


def probe(env_extra: dict[str, str], before: str = "") -> dict:
    """Import dexpush in a fresh interpreter (``before`` runs first) and report what it set."""
    env = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", "NPROC", "DEXPUSH_XLA_OPTIONS")}
    env.update(env_extra)
    out = subprocess.run([sys.executable, "-c", before + PROBE], env=env, capture_output=True, text=True,
                         check=True, timeout=120)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("user_flags", ["", "--xla_cpu_prefer_vector_width=256"])
def test_import_asks_for_one_xla_thread_and_leaves_the_users_flags_alone(user_flags: str) -> None:
    got = probe({"XLA_FLAGS": user_flags} if user_flags else {})
    assert got["nproc"] == "1" and got["active"]
    assert got["flags"] == (user_flags or None)


def test_a_users_own_thread_count_wins() -> None:
    got = probe({"NPROC": "2"})
    assert got["nproc"] == "2" and not got["active"]


def test_opting_out_or_a_started_backend_leaves_xla_alone() -> None:
    assert probe({"DEXPUSH_XLA_OPTIONS": "0"}) == {"flags": None, "nproc": None, "active": False}
    # a backend started before dexpush was imported has read its settings: NPROC is not set
    started = probe({}, before="import jax; jax.numpy.zeros(1).block_until_ready(); ")
    assert started["nproc"] is None and not started["active"]

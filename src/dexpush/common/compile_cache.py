"""JAX's persistent compilation cache, so a second process does not compile the controller again.

The controller's programs take 5–9 s to compile on a 2-core CPU; with the cache on, a new
process loads them from disk (``benchmarks/act_latency.py`` prints ``reset_s``). The
command line turns it on by default (``DEXPUSH_NO_CACHE=1`` turns it off); a script or a
robot driver calls :func:`enable` once, before its first controller.
"""

from __future__ import annotations

import os
from pathlib import Path

import jax

__all__ = ["default_dir", "enable"]


def default_dir() -> Path:
    """``$DEXPUSH_CACHE_DIR``, else ``$XDG_CACHE_HOME/dexpush/jax``, else ``~/.cache/dexpush/jax``."""
    if os.environ.get("DEXPUSH_CACHE_DIR"):
        return Path(os.environ["DEXPUSH_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "dexpush" / "jax"


def enable(path: str | os.PathLike | None = None) -> Path:
    """Cache every compiled program under ``path`` (default :func:`default_dir`) and return it.

    Also exports the settings as environment variables, so worker processes started from
    this one (``dexpush bench --workers``) use the same cache. Call it before the first
    compilation: JAX fixes the cache at its first use.
    """
    folder = Path(path) if path is not None else default_dir()
    folder.mkdir(parents=True, exist_ok=True)
    settings = {"jax_compilation_cache_dir": str(folder), "jax_persistent_cache_min_compile_time_secs": 0.0,
                "jax_persistent_cache_min_entry_size_bytes": 0}
    for name, value in settings.items():
        jax.config.update(name, value)
        os.environ[name.upper()] = str(value)
    return folder

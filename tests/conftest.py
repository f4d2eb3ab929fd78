import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))  # tests/reference.py

# the CLI turns on JAX's persistent compilation cache in ~/.cache; tests run it in-process and must not
os.environ.setdefault("DEXPUSH_NO_CACHE", "1")


# Property tests draw the same examples on every run (CI must not turn red by chance); set
# HYPOTHESIS_PROFILE=explore to search new random examples (a found failure is then a real case
# to fix, e.g. the one in tests/test_model.py's note).
from hypothesis import settings

settings.register_profile("ci", derandomize=True, deadline=None)
settings.register_profile("explore", derandomize=False, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

# rendered cameras (tests/test_perception_*.py) draw off-screen: EGL, chosen before anything imports MuJoCo
if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")


def pytest_configure(config) -> None:
    """One compilation cache for the session, in a fresh temporary folder: the two xdist workers
    and the command lines the tests start load a program another compiled instead of
    compiling it again (JAX reads ``JAX_COMPILATION_CACHE_DIR`` at start-up; programs that
    compile in under 0.5 s are not worth a file). Set
    ``DEXPUSH_TEST_NO_CACHE=1`` to compile everything in every process."""
    if os.environ.get("DEXPUSH_TEST_NO_CACHE") or "PYTEST_XDIST_WORKER" in os.environ:
        return                                   # a worker inherits the controller's folder
    import tempfile

    folder = tempfile.mkdtemp(prefix="dexpush-test-jax-")
    config._dexpush_cache = folder
    cache = {"jax_compilation_cache_dir": folder, "jax_persistent_cache_min_compile_time_secs": 0.5}
    os.environ.update({name.upper(): str(value) for name, value in cache.items()})
    if "jax" in sys.modules:                     # imported already (a plugin): set it directly too
        for name, value in cache.items():
            sys.modules["jax"].config.update(name, value)


def pytest_unconfigure(config) -> None:
    folder = getattr(config, "_dexpush_cache", None)
    if folder:
        import shutil

        shutil.rmtree(folder, ignore_errors=True)


def _memory_maps() -> int | None:
    """How many memory mappings this process holds (Linux), else None."""
    try:
        with open("/proc/self/maps", "rb") as f:
            return sum(1 for _ in f)
    except OSError:
        return None


def _map_limit() -> int:
    try:
        with open("/proc/sys/vm/max_map_count") as f:
            return int(f.read())
    except (OSError, ValueError):
        return 65530


@pytest.fixture(autouse=True)
def _release_compiled_programs(request):
    """Free JAX's compiled programs after a test once this process holds half the mappings Linux allows.

    XLA's CPU client maps each compiled kernel's code and data separately (about three mappings a kernel:
    ``benchmarks/memory_maps.py``), and a program stays mapped while JAX caches it. An xdist worker that
    compiles every module's programs reaches ``vm.max_map_count`` (65,530 by default) and LLVM's next
    allocation fails ("Cannot allocate memory", then an abort or a segfault in XLA). ``jax.clear_caches()``
    unmaps them; a later test reloads what it needs from the session's compile cache. With
    ``DEXPUSH_TEST_MAPS_LOG=FILE`` each test that adds over 2,000 mappings, and each clearing, is logged."""
    log = os.environ.get("DEXPUSH_TEST_MAPS_LOG")
    before = _memory_maps() if log else None
    yield
    count = _memory_maps()
    if count is None:
        return
    lines = [f"{request.node.nodeid} {before} -> {count}"] if before is not None and count - before > 2000 else []
    if count > _map_limit() // 2 and "jax" in sys.modules:
        sys.modules["jax"].clear_caches()
        lines.append(f"{os.environ.get('PYTEST_XDIST_WORKER', 'main')} cleared: {count} -> {_memory_maps()}")
    if log and lines:
        with open(log, "a") as f:
            f.write("".join(line + "\n" for line in lines))

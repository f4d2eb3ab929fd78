import os
import sys

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

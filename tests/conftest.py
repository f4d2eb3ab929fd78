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

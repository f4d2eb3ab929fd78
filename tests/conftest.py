import os
import sys

sys.path.insert(0, os.path.dirname(__file__))  # tests/reference.py

# the CLI turns on JAX's persistent compilation cache in ~/.cache; tests run it in-process and must not
os.environ.setdefault("DEXPUSH_NO_CACHE", "1")

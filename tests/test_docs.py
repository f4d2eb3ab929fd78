"""The code in the README and in docs/api.md runs as written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _python_blocks(path: Path) -> list[str]:
    """The runnable python blocks (those that import dexpush; the others show signatures)."""
    blocks = re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S)
    return [b for b in blocks if re.search(r"^import dexpush", b, flags=re.M)]


@pytest.mark.parametrize("doc", ["README.md", "docs/api.md"])
def test_python_snippets_run_as_written(doc: str, capsys) -> None:
    blocks = _python_blocks(ROOT / doc)
    assert blocks, f"{doc} has no python block"
    for code in blocks:
        namespace: dict = {}
        exec(compile(code, doc, "exec"), namespace)      # our own documentation
    if doc == "README.md":
        obs, goal = namespace["obs"], (0.6, 0.3, 0.0)
        assert abs(obs.object_pose[0] - goal[0]) < 0.01 and abs(obs.object_pose[1] - goal[1]) < 0.01

"""The Python examples of README.md and python/README.md run as written."""

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def python_blocks(path):
    return re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S)


@pytest.mark.parametrize("readme", ["README.md", "python/README.md"])
def test_readme_examples_run(readme, capsys):
    blocks = python_blocks(REPO / readme)
    assert blocks, f"{readme} has no python example"
    for code in blocks:
        namespace = {}
        exec(compile(code, readme, "exec"), namespace)
        # the examples state the identity; hold them to it
        if "y_d" in namespace and "y" in namespace:
            import numpy as np

            assert np.max(np.abs(namespace["y"] - namespace["y_d"])) < 1e-9

"""The Python examples of the guide's Python chapter and python/README.md
run as written."""

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def python_blocks(path):
    """The package's examples; the FMPy example needs an FMU and runs in
    verification/fmi/test_fmpy.py (test_the_readme_fmpy_example_runs); the
    controller program reads its samples from stdin and runs through
    `mfcbeam benchmark-control` in verification/cli.rs
    (the_python_pid_example_is_the_built_in_pid_bit_for_bit)."""
    blocks = re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S)
    return [b for b in blocks if "from fmpy" not in b and "sys.stdin" not in b]


@pytest.mark.parametrize("readme", ["docs/guide/python.md", "python/README.md"])
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

"""The README's Python example runs and shows what it claims."""

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_example_runs():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.DOTALL)
    assert blocks, "the README has no python example"
    namespace = {}
    for block in blocks:
        # Running the documented example is the point of this test.
        exec(compile(block, str(README), "exec"), namespace)  # noqa: S102
    physics, model, data = namespace["physics"], namespace["model"], namespace["data"]
    assert abs(physics.params_["mass"] - 1.0) < 0.05
    assert abs(physics.params_["length"] - 1.0) < 0.05
    parts = namespace["parts"]
    np.testing.assert_allclose(
        parts.physics + parts.dense, model.predict(data.X), atol=1e-10
    )
    assert namespace["std"].shape == namespace["mean"].shape

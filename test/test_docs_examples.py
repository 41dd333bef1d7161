"""The Python examples in the docs run as written.

Examples that start ROS (they use :mod:`phd_swarm.testing`'s ``ChildProcesses`` or
``InProcessRos``) need a recorded run or a live one; each is run by the test named in
:data:`ROS_EXAMPLES`, next to the fixtures it needs, and an example missing there fails.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
EXAMPLES = [(page.name, i, code) for page in sorted(DOCS.glob("*.md"))
            for i, code in enumerate(re.findall(r"```python\n(.*?)```", page.read_text(),
                                                re.S))]

#: Examples that start ROS, by id, and the test that runs each.
ROS_EXAMPLES = {
    "replay.md[0]": "test/tools/test_replay.py::test_the_docs_example_receives_every_metric",
}


def starts_ros(code: str) -> bool:
    """Whether an example starts ROS processes or contexts."""
    return "ChildProcesses" in code or "InProcessRos" in code


@pytest.mark.parametrize(("page", "index", "code"),
                         [e for e in EXAMPLES if not starts_ros(e[2])],
                         ids=[f"{p}[{i}]" for p, i, c in EXAMPLES if not starts_ros(c)])
def test_the_example_runs(page, index, code, capsys):
    exec(compile(code, f"{page}[{index}]", "exec"), {})  # noqa: S102 - our own docs
    capsys.readouterr()


def test_every_ros_example_has_its_test():
    ros = {f"{p}[{i}]" for p, i, c in EXAMPLES if starts_ros(c)}
    assert ros == set(ROS_EXAMPLES)
    root = DOCS.parent
    for target in ROS_EXAMPLES.values():
        path, name = target.split("::")
        assert f"def {name}(" in (root / path).read_text(), target


def test_there_are_examples():
    assert any(page == "estimators.md" for page, _, _ in EXAMPLES)

"""The Python examples in the docs run as written (no ROS)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
EXAMPLES = [(page.name, i, code) for page in sorted(DOCS.glob("*.md"))
            for i, code in enumerate(re.findall(r"```python\n(.*?)```", page.read_text(),
                                                re.S))]


@pytest.mark.parametrize(("page", "index", "code"), EXAMPLES,
                         ids=[f"{p}[{i}]" for p, i, _ in EXAMPLES])
def test_the_example_runs(page, index, code, capsys):
    exec(compile(code, f"{page}[{index}]", "exec"), {})  # noqa: S102 - our own docs
    capsys.readouterr()


def test_there_are_examples():
    assert any(page == "estimators.md" for page, _, _ in EXAMPLES)

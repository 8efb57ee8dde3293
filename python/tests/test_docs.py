"""Every ```python block of docs/python.md runs (from the repository root)."""

from __future__ import annotations

import os
import re

import pytest

from conftest import REPO

PAGE = REPO / "docs" / "python.md"
BLOCKS = re.findall(r"```python\n(.*?)```", PAGE.read_text(), flags=re.S)


def test_the_page_has_examples():
    assert len(BLOCKS) >= 4


@pytest.mark.parametrize("k", range(len(BLOCKS)))
def test_docs_example_runs(k, capsys):
    cwd = os.getcwd()
    os.chdir(REPO)
    try:
        exec(compile(BLOCKS[k], f"docs/python.md block {k + 1}", "exec"), {})
    finally:
        os.chdir(cwd)

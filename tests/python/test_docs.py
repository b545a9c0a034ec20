"""Every ```python block of docs/python.md runs, in order, from the repository's root: the
documentation's examples cannot rot."""

import os
import re

import pytest

from conftest import ROOT

DOC = ROOT / "docs" / "python.md"
BLOCKS = re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)


def test_the_document_has_examples():
    assert len(BLOCKS) >= 9


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_example_runs(index, monkeypatch, capsys):
    monkeypatch.chdir(ROOT)
    exec(compile(BLOCKS[index], f"{DOC}:python block {index + 1}", "exec"), {})
    assert capsys.readouterr().out  # every example prints what it shows

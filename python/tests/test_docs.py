"""The ```python examples of docs/python.md run as printed."""

import os

import pytest

from conftest import REPO
from readme_example import examples_dir, python_blocks, run_file


def test_the_python_blocks_are_found(tmp_path):
    md = tmp_path / "x.md"
    md.write_text("text\n```python\na = 1\n```\n```sh\nls\n```\n\n```python\nassert a == 1\n```\n")
    assert python_blocks(str(md)) == [(3, "a = 1\n"), (10, "assert a == 1\n")]
    run_file(str(md), str(tmp_path))
    md.write_text("```python\nraise ValueError('no')\n```\n")
    with pytest.raises(SystemExit, match=r"x.md:2: this ```python block failed"):
        run_file(str(md), str(tmp_path))
    md.write_text("no code\n")
    with pytest.raises(SystemExit, match="no ```python block"):
        run_file(str(md), str(tmp_path))


def test_docs_python_md_runs_as_printed():
    doc = os.path.join(REPO, "docs", "python.md")
    cwd = examples_dir()
    run_file(doc, cwd)
    assert os.path.isdir(os.path.join(cwd, "runs"))

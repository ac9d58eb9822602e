"""Runs the ```python blocks of Markdown files, as a reader would.

    python readme_example.py [--cwd DIR] FILE.md...

Each file's blocks run in order in one namespace (a block may use what an
earlier one defined), with DIR as the current directory (default: a fresh
temporary directory holding a copy of the repository's examples/ folder, so
that paths such as examples/quick.toml work as printed). Exits 1 naming the
file and the block's line when a block raises, or when a file has no
```python block. README.md's Python quick start is checked this way by .ci/run
against the installed wheel; python/tests/test_docs.py checks docs/python.md.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import sys
import tempfile
import traceback
from typing import List, Tuple

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
_FENCE = re.compile(r"^```python[ \t]*$")


def python_blocks(path: str) -> List[Tuple[int, str]]:
    """The ```python blocks of the Markdown file ``path``: (1-based line of
    the block's first code line, code)."""
    blocks = []
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    i = 0
    while i < len(lines):
        if _FENCE.match(lines[i]):
            start = i + 1
            j = start
            while j < len(lines) and lines[j].strip() != "```":
                j += 1
            if j == len(lines):
                raise SystemExit(f"{path}:{i + 1}: ```python block without its closing ```")
            blocks.append((start + 1, "\n".join(lines[start:j]) + "\n"))
            i = j
        i += 1
    return blocks


def examples_dir() -> str:
    """A fresh temporary directory holding a copy of the repository's examples/."""
    d = tempfile.mkdtemp(prefix="rwg-md-")
    shutil.copytree(os.path.join(REPO, "examples"), os.path.join(d, "examples"))
    return d


def run_file(path: str, cwd: str) -> None:
    """Runs every ```python block of ``path`` with ``cwd`` as the current
    directory; raises SystemExit naming the block on failure."""
    blocks = python_blocks(path)
    if not blocks:
        raise SystemExit(f"{path}: no ```python block to run")
    namespace = {"__name__": "__main__"}
    here = os.getcwd()
    os.chdir(cwd)
    try:
        for line, code in blocks:
            print(f"--- {path}:{line}", flush=True)
            try:
                exec(compile(code, f"{path}:{line}", "exec"), namespace)
            except BaseException:
                traceback.print_exc()
                raise SystemExit(f"{path}:{line}: this ```python block failed (above)")
    finally:
        os.chdir(here)


def main(argv: List[str]) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cwd", help="directory to run in (default: a temporary copy of examples/)")
    p.add_argument("files", nargs="+")
    args = p.parse_args(argv)
    files = [os.path.abspath(f) for f in args.files]
    for f in files:
        run_file(f, args.cwd or examples_dir())
    print(f"ok: the ```python blocks of {', '.join(args.files)} ran")


if __name__ == "__main__":
    main(sys.argv[1:])

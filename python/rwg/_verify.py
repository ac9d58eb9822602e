"""The run directory's checksums, checked as ``rwg verify`` checks them.

Each finished cell's ``cells/CELL/SHA256SUMS`` lists the SHA-256 of its
``scores.csv``, ``samples.csv`` and ``cell.json`` (the format of
``sha256sum``); an unfinished cell's ``cells/CELL/blocks/SHA256SUMS`` lists
its committed blocks. A block file without a line there is not committed
(``rwg run`` computes it again) and is not a problem.
"""

from __future__ import annotations

import hashlib
import os
import re
from typing import Dict, List, Optional

SUMS = "SHA256SUMS"
_LINE = re.compile(r"^([0-9a-fA-F]{64})  ([^/\\]+)$")
_BLOCK = re.compile(r"^b[0-9]+\.csv$")


class SumsError(Exception):
    """A ``SHA256SUMS`` file that cannot be read or parsed (the message names it)."""


def read_sums(path: str, strict: bool) -> Optional[Dict[str, str]]:
    """The digests a ``SHA256SUMS`` file records, by file name; ``None`` if the
    file does not exist. ``strict`` (a finished cell's index, written at once):
    every line must parse. Otherwise (a block index, appended to while a run
    writes) a last line without its newline is not yet written and ignored."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except FileNotFoundError:
        return None
    except OSError as e:
        raise SumsError(f"cannot read {path}: {e}") from e
    if not strict:
        data = data[: data.rfind(b"\n") + 1]
    out: Dict[str, str] = {}
    for i, raw in enumerate(data.split(b"\n")):
        if not raw and (not strict or i > 0):
            continue
        try:
            m = _LINE.match(raw.decode("utf-8"))
        except UnicodeDecodeError:
            m = None
        if m:
            out[m.group(2)] = m.group(1).lower()
        elif strict:
            raise SumsError(f"{path}:{i + 1}: not a '<sha256>  <file>' line")
    return out


def sha256_hex(data: bytes) -> str:
    """The SHA-256 of ``data`` as 64 lowercase hex digits."""
    return hashlib.sha256(data).hexdigest()


def hash_file(path: str) -> str:
    """The SHA-256 of a file's contents as 64 lowercase hex digits."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def mismatch(path: str, recorded: str, found: str) -> str:
    """The problem line of a file whose digest is not the recorded one (the
    words of ``rwg verify``)."""
    return (
        f"{path}: checksum mismatch: the run's index records sha256 {recorded}, the file has "
        f"{found}; it was changed, truncated or damaged after rwg wrote it (a block: or it did "
        "not reach the disk before a crash of the machine). Running the study again computes "
        "a damaged block again; for a finished cell's file, delete the cell's directory first"
    )


def verify_cell_files(cell_dir: str) -> List[str]:
    """Checks a finished cell's files against its ``SHA256SUMS`` (which must
    exist); returns the problems."""
    sums_path = os.path.join(cell_dir, SUMS)
    try:
        sums = read_sums(sums_path, strict=True)
    except SumsError as e:
        return [str(e)]
    if sums is None:
        return [f"{sums_path}: missing: run.json lists this cell as finished"]
    problems = []
    for name, want in sorted(sums.items()):
        path = os.path.join(cell_dir, name)
        try:
            got = hash_file(path)
        except OSError as e:
            problems.append(f"cannot read {path}: {e}")
            continue
        if got != want:
            problems.append(mismatch(path, want, got))
    return problems


def verify_blocks(cell_dir: str) -> List[str]:
    """Checks an unfinished cell's committed blocks against
    ``blocks/SHA256SUMS``; returns the problems. A block that disappears while
    it is checked was finalised by a running ``rwg run`` and is no problem."""
    bdir = os.path.join(cell_dir, "blocks")
    if not os.path.isdir(bdir):
        return []
    try:
        index = read_sums(os.path.join(bdir, SUMS), strict=False) or {}
        names = sorted(n for n in os.listdir(bdir) if _BLOCK.match(n))
    except FileNotFoundError:
        return []
    except (OSError, SumsError) as e:
        return [str(e)]
    problems = []
    for name in names:
        want = index.get(name)
        if want is None:
            continue
        path = os.path.join(bdir, name)
        try:
            got = hash_file(path)
        except FileNotFoundError:
            continue
        except OSError as e:
            problems.append(f"cannot read {path}: {e}")
            continue
        if got != want:
            problems.append(mismatch(path, want, got))
    return problems

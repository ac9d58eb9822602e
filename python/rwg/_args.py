"""The arguments of the package's functions, checked: a bad one raises
:class:`ArgumentError` naming it and what it takes."""

from __future__ import annotations

import numbers
import os
from typing import Any

import numpy as np

from .errors import ArgumentError


def path(value: Any, name: str, where: str, what: str = "the run directory's path") -> str:
    """``value`` (``str``, ``bytes`` or ``os.PathLike``) as a ``str`` path
    (bytes decoded as the file system does; a leading ``~`` or ``~user``
    expanded, as pandas does, never a folder named ``~`` made)."""
    if isinstance(value, (str, bytes, os.PathLike)):
        try:
            p = os.path.expanduser(os.fsdecode(value))
        except TypeError:  # an os.PathLike whose __fspath__ gives neither
            p = None
        if p == "":
            raise ArgumentError(f"{where}: {name} is empty; give {what}")
        if p is not None and "\0" not in p:
            try:
                os.fsencode(p)
            except UnicodeEncodeError as e:
                raise ArgumentError(
                    f"{where}: {name} {ascii(p)} holds a lone surrogate ({ascii(p[e.start])} at "
                    f"index {e.start}), which no file name holds; give {what}"
                ) from None
            return p
    raise ArgumentError(f"{where}: {name} takes {what}, not {value!r}")


def absolute(p: str, name: str, where: str) -> str:
    """``p`` made absolute from the current directory."""
    try:
        return os.path.abspath(p)
    except OSError as e:  # the current directory was deleted
        raise ArgumentError(
            f"{where}: {name} {p!r} is relative and the current directory cannot be read "
            f"({e.strerror or e}); give an absolute path"
        ) from e


def flag(value: Any, name: str, where: str) -> bool:
    """``value`` as a bool: ``True``/``False`` or a numpy bool, nothing else."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise ArgumentError(f"{where}: {name}= takes True or False, not {value!r}")


def whole(value: Any, name: str, where: str) -> int:
    """``value`` as an int >= 0: a Python or numpy integer (not a bool, a
    float or a string)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise ArgumentError(f"{where}: {name}= takes a whole number, not {value!r}")
    v = int(value)
    if v < 0:
        raise ArgumentError(f"{where}: {name}= must be 0 or more, not {v}")
    return v


def text(value: Any, name: str, where: str, what: str) -> str:
    """``value`` as a ``str`` (numpy strings included)."""
    if isinstance(value, str):
        return str(value)
    raise ArgumentError(f"{where}: {name}= takes {what}, not {value!r}")


def command_path(p: str) -> str:
    """``p`` as a command's argument: a relative path starting with ``-`` as
    ``./-...``, so that it is not read as an option."""
    return os.path.join(".", p) if p.startswith("-") else p

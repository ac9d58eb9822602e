"""A small TOML writer for study manifests given as dicts.

It writes what a manifest holds: strings, booleans, integers, floats, lists of
those, tables (dicts) and arrays of tables (lists of dicts, as
``[[architectures]]`` and ``[[envs]]``), nested to any depth. numpy scalars
and ``os.PathLike`` values are written as their Python values; anything else
is refused naming its key.
"""

from __future__ import annotations

import math
import os
import re
from typing import Any, List, Mapping

from .errors import ArgumentError

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def dumps(doc: Mapping[str, Any]) -> str:
    """``doc`` as TOML text (which ``tomllib.loads`` reads back as ``doc``)."""
    if not isinstance(doc, Mapping):
        raise ArgumentError(f"a manifest must be a dict, not {type(doc).__name__}")
    lines: List[str] = []
    try:
        _table(doc, [], lines)
    except RecursionError:
        raise ArgumentError(
            "a manifest given as a dict: its dicts and lists nest too deep to write as TOML "
            "(past Python's recursion limit); rwg reads values nested under 80 levels deep"
        ) from None
    return "\n".join(lines).lstrip("\n") + "\n"


def _key(k: Any, path: List[str]) -> str:
    if not isinstance(k, str):
        raise ArgumentError(f"{_dotted(path)}: keys must be strings, not {k!r}")
    _utf8(k, "key", path)
    return k if _BARE_KEY.match(k) else _string(k)


def _utf8(s: str, what: str, path: List[str]) -> None:
    """Refuses a string UTF-8 cannot encode (a lone surrogate, as
    ``"\\ud800"`` or a file name's undecodable byte), naming its key."""
    try:
        s.encode("utf-8")
    except UnicodeEncodeError as e:
        raise ArgumentError(
            f"manifest key {_dotted(path)}: the {what} {ascii(s)} holds a lone surrogate "
            f"({ascii(s[e.start])} at index {e.start}), which UTF-8, and so TOML, cannot hold"
        ) from None


def _dotted(path: List[str]) -> str:
    return ".".join(path) if path else "(top level)"


def _is_table_array(v: Any) -> bool:
    return isinstance(v, (list, tuple)) and len(v) > 0 and all(isinstance(x, Mapping) for x in v)


def _table(t: Mapping[str, Any], path: List[str], lines: List[str]) -> None:
    # Plain values first: a table's keys must come before its sub-tables.
    for k, v in t.items():
        if not isinstance(v, Mapping) and not _is_table_array(v):
            lines.append(f"{_key(k, path)} = {_value(v, path + [str(k)])}")
    for k, v in t.items():
        sub = path + [str(k)]
        header = ".".join(_key(p, path) for p in sub)
        if isinstance(v, Mapping):
            lines.extend(["", f"[{header}]"])
            _table(v, sub, lines)
        elif _is_table_array(v):
            for item in v:
                lines.extend(["", f"[[{header}]]"])
                _table(item, sub, lines)


def _plain(v: Any) -> Any:
    """numpy scalars as Python values, paths as strings."""
    if type(v).__module__ == "numpy" and hasattr(v, "tolist"):
        return v.tolist()  # a scalar's value, an array's list
    if isinstance(v, os.PathLike):
        return os.fspath(v)
    return v


def _value(v: Any, path: List[str]) -> str:
    v = _plain(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        _utf8(v, "string", path)
        return _string(v)
    if isinstance(v, Mapping):
        items = ", ".join(f"{_key(k, path)} = {_value(x, path + [str(k)])}" for k, x in v.items())
        return "{ " + items + " }" if items else "{}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x, path) for x in v) + "]"
    raise ArgumentError(
        f"manifest key {_dotted(path)}: cannot write a {type(v).__name__} ({v!r}) as TOML; "
        "use a string, number, boolean, list or dict"
    )


_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _string(s: str) -> str:
    out = []
    for c in s:
        if c in _ESCAPES:
            out.append(_ESCAPES[c])
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\u{ord(c):04x}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def value_text(v: Any) -> str:
    """``v`` as a TOML value, for messages (its ``repr`` if TOML cannot
    write it)."""
    try:
        return _value(v, [])
    except ArgumentError:
        return repr(v)

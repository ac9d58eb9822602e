"""Finding the ``rwg`` binary the wheel installs."""

from __future__ import annotations

import os
import shutil
import sys
import sysconfig

from .errors import RwgNotFoundError

#: Environment variable naming the ``rwg`` binary to use (first choice).
BIN_VAR = "RWG_BIN"


def _user_scheme() -> str:
    if sys.version_info >= (3, 10):
        return sysconfig.get_preferred_scheme("user")
    return "nt_user" if os.name == "nt" else "posix_user"


def find_rwg_bin() -> str:
    """The path of the ``rwg`` binary: ``$RWG_BIN`` if set (the empty string
    is an error, not unset), else the one in
    this Python environment's scripts folder (where ``pip install`` puts the
    wheel's binary), else in the user scheme's scripts folder (``pip install
    --user``), else ``bin/`` beside the package (``pip install --target``),
    else ``rwg`` on PATH. Raises :class:`RwgNotFoundError` naming the places
    searched."""
    env = os.environ.get(BIN_VAR)
    if env == "":
        raise RwgNotFoundError(
            f"{BIN_VAR}=: expected the path of an rwg binary; {BIN_VAR} is set to the empty "
            f"string: unset it (`unset {BIN_VAR}`) for the default"
        )
    if env is not None:
        if not os.path.isfile(env):
            why = "a directory" if os.path.isdir(env) else "no such file"
            raise RwgNotFoundError(
                f"{BIN_VAR}={env}: {why}; point {BIN_VAR} at an rwg binary "
                "(e.g. target/release/rwg) or unset it"
            )
        if not os.access(env, os.X_OK):
            raise RwgNotFoundError(
                f"{BIN_VAR}={env}: not an executable file (no permission to run it); point "
                f"{BIN_VAR} at an rwg binary (e.g. target/release/rwg) or unset it"
            )
        return env
    exe = "rwg" + (sysconfig.get_config_var("EXE") or "")
    candidates = [os.path.join(sysconfig.get_path("scripts"), exe)]
    try:
        candidates.append(os.path.join(sysconfig.get_path("scripts", scheme=_user_scheme()), exe))
    except KeyError:
        pass
    pkg_root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    candidates.append(os.path.join(pkg_root, "bin", exe))
    for c in candidates:
        if os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    on_path = shutil.which(exe)
    if on_path:
        return on_path
    raise RwgNotFoundError(
        "cannot find the rwg binary: not in "
        + ", ".join(candidates)
        + f", nor on PATH; install the rwg wheel (pip install rwg-*.whl, or pip install . "
        f"in a clone), or set {BIN_VAR} to the binary"
    )


def start_error(binary: str, error: OSError) -> RwgNotFoundError:
    """The error of an ``rwg`` binary that the system cannot start (not a
    program for this machine, a broken interpreter line, ...)."""
    via = f" (from {BIN_VAR})" if os.environ.get(BIN_VAR) == binary else ""
    return RwgNotFoundError(
        f"cannot start {binary}{via}: {error.strerror or error}; it is not an rwg binary this "
        f"machine runs: reinstall the rwg wheel, or point {BIN_VAR} at target/release/rwg"
    )

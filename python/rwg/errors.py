"""The exceptions of the rwg package: every one is a :class:`RunError`."""

from __future__ import annotations

from typing import List, Optional, Sequence


class RunError(Exception):
    """Base class of every error of this package: a run directory that cannot be
    read, or an ``rwg`` command that failed."""


class ArgumentError(RunError, TypeError, ValueError):
    """An argument of the package's functions has the wrong type or value
    (the message names the argument and what it takes). Raised before
    anything runs or is read; also a ``TypeError`` and a ``ValueError``."""


class NotARunError(RunError):
    """The path is not an rwg run directory (no ``run.json``), or it is one shard
    of a study rather than a whole run."""


class RunInProgressError(RunError):
    """The run directory holds a study that is not finished: ``cells_done`` of
    ``cells_total`` cells are. Either ``rwg run`` is still writing it, or it
    stopped (Ctrl-C, a failure) and running it again resumes it."""

    def __init__(self, message: str, cells_done: int, cells_total: int):
        super().__init__(message)
        self.cells_done = cells_done
        self.cells_total = cells_total


class RunDamagedError(RunError):
    """A file of the run does not match the SHA-256 recorded for it, is missing
    or cannot be read (what ``rwg verify`` reports). ``problems`` holds one line
    per problem, each naming the file."""

    def __init__(self, message: str, problems: Sequence[str]):
        super().__init__(message)
        self.problems: List[str] = list(problems)


class RwgNotFoundError(RunError, FileNotFoundError):
    """The ``rwg`` binary was found neither through ``RWG_BIN``, nor in the
    Python environment's scripts folder, nor beside the package, nor on PATH."""


class RwgFailedError(RunError):
    """An ``rwg`` command exited with an error. The message is rwg's own (its
    ``error:`` lines on stderr); ``stderr`` holds all of its stderr,
    ``returncode`` its exit status and ``command`` the command line."""

    def __init__(
        self,
        message: str,
        returncode: int,
        stderr: str,
        command: Sequence[str],
        manifest_text: Optional[str] = None,
    ):
        super().__init__(message)
        self.returncode = returncode
        self.stderr = stderr
        self.command = list(command)
        self.manifest_text = manifest_text

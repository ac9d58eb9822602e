"""rwg from Python: run Random Weight Guessing studies with the ``rwg`` binary
this package ships with, and read their run directories into numpy and pandas.

    import rwg

    run = rwg.run("examples/quick.toml", out="runs/quick-py", samples=100)
    print(run.stats[["env", "arch", "bias", "best_mean", "p_solved"]])
    scores = run.scores("CartPole-v0", "0HL")   # networks x episodes
    episodes = run.tidy()                       # every episode, one row each (rwg.tidy: several runs)

See docs/python.md in the repository for the whole API.
"""

from ._binary import find_rwg_bin
from ._rundir import Run, load
from ._runner import run
from ._tidy import TIDY_COLUMNS, tidy
from .errors import (
    ArgumentError,
    NotARunError,
    RunDamagedError,
    RunError,
    RunInProgressError,
    RwgFailedError,
    RwgNotFoundError,
)

__all__ = [
    "load",
    "run",
    "tidy",
    "TIDY_COLUMNS",
    "Run",
    "find_rwg_bin",
    "RunError",
    "ArgumentError",
    "NotARunError",
    "RunInProgressError",
    "RunDamagedError",
    "RwgFailedError",
    "RwgNotFoundError",
]

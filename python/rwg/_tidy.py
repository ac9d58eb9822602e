"""Every episode of one or several runs as one tidy pandas frame: ``rwg.tidy``."""

from __future__ import annotations

import os
from typing import Any, Dict, List, Sequence

import numpy as np
import pandas as pd

from . import _args
from .errors import ArgumentError
from ._rundir import Run, check_score_rows, read_scores_csv

#: The columns of :func:`tidy`, in order (a run's ``scores.csv`` may add
#: further columns after them).
TIDY_COLUMNS = ["run", "env", "arch", "bias", "sample", "episode", "score", "steps"]
_TYPES = {
    "run": object,
    "env": object,
    "arch": object,
    "bias": bool,
    "sample": np.int64,
    "episode": np.int64,
    "score": np.float64,
    "steps": np.int64,
}


def _runs(runs: Any, where: str) -> List[Run]:
    """``runs`` (a :class:`Run`, a path, or a list or tuple of them) as
    loaded runs; a path is loaded with :func:`rwg.load`."""
    one = isinstance(runs, (Run, str, bytes, os.PathLike))
    items: Sequence[Any] = [runs] if one else runs
    if not isinstance(items, (list, tuple)):
        raise ArgumentError(
            f"{where}: runs takes a Run, a run directory's path, or a list of them, not {runs!r}"
        )
    if not items:
        raise ArgumentError(f"{where}: runs is empty; give at least one run")
    out = []
    for r in items:
        if isinstance(r, Run):
            out.append(r)
        else:
            p = _args.path(r, "runs", where, "a Run or a run directory's path")
            out.append(Run(p))
    for i, r in enumerate(out):
        for prev in out[:i]:
            if os.path.realpath(prev.path) == os.path.realpath(r.path):
                raise ArgumentError(
                    f"{where}: {r.path} is given twice; its rows would be listed twice under "
                    "one label"
                )
    return out


def _labels(runs: List[Run]) -> List[str]:
    """The runs' labels: their directory names, or their paths where two
    names are alike (as ``rwg compare`` names runs)."""
    names = [os.path.basename(os.path.normpath(r.path)) for r in runs]
    return names if len(set(names)) == len(names) else [r.path for r in runs]


def _cell_frame(run: Run, cell: Dict[str, Any], label: str) -> pd.DataFrame:
    """One cell's ``scores.csv`` with the run and cell columns in front."""
    path, data = run._cell_file(cell, "scores.csv")
    df = read_scores_csv(data, path, exact_header=False)
    check_score_rows(df, cell, path)
    n = len(df)
    front = pd.DataFrame(
        {
            "run": np.full(n, label, dtype=object),
            "env": np.full(n, cell["env"], dtype=object),
            "arch": np.full(n, cell["arch"], dtype=object),
            "bias": np.full(n, bool(cell["bias"]), dtype=bool),
        }
    )
    return pd.concat([front, df.reset_index(drop=True)], axis=1)


def tidy(runs: Any) -> pd.DataFrame:
    """Every episode of every cell of ``runs`` as one tidy DataFrame, one row
    per episode: ``run``, ``env``, ``arch``, ``bias``, ``sample``,
    ``episode``, ``score``, ``steps``, then any further column the runs'
    ``scores.csv`` files have (a run that lacks one gets NaN in it).

    ``runs`` is a :class:`Run`, a run directory's path (loaded with
    :func:`rwg.load`, verified), or a list or tuple of them. ``run`` is each
    run's directory name, or its absolute path where two names are alike.
    Rows come in the order of ``runs``, then of each run's cells, then by
    network and episode. The files are read as :meth:`Run.scores` reads
    them: checked against their recorded SHA-256.
    """
    where = "rwg.tidy"
    loaded = _runs(runs, where)
    frames = [
        _cell_frame(run, cell, label)
        for run, label in zip(loaded, _labels(loaded))
        for cell in run.cells
    ]
    if not frames:
        return pd.DataFrame({c: pd.Series(dtype=t) for c, t in _TYPES.items()})
    return pd.concat(frames, ignore_index=True).astype(_TYPES)

__all__ = ["tidy", "TIDY_COLUMNS"]

"""Reading a finished run directory: ``rwg.load`` and :class:`Run`."""

from __future__ import annotations

import io
import json
import os
import shlex
import subprocess
import sys
import warnings
from typing import Any, Dict, List, Optional

import numpy as np
import pandas as pd

from . import _args, _toml, _verify
from ._binary import find_rwg_bin, start_error
from .errors import (
    NotARunError,
    RunDamagedError,
    RunError,
    RunInProgressError,
    RwgNotFoundError,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python < 3.11 only
    import tomli as tomllib

#: The run format with checksums (``"format"`` in ``run.json``).
RUN_FORMAT = 2
SCORES_HEADER = ["sample", "episode", "score", "steps"]
SAMPLES_HEADER = ["sample", "mean", "variance", "std", "min", "max", "rank"]
# A cell whose env has non_finite = "end" (cell.json's non_finite_episodes):
# its files end with a non_finite column.
NON_FINITE = "non_finite"
_TEXT_COLUMNS = ["dir", "env", "arch", "hidden", "bias"]
# Every float as rwg wrote it (shortest round-trip form): pandas 3 parses
# exactly by default (and deprecates the option); earlier versions need it.
_EXACT = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}


def load(run_dir: "str | os.PathLike[str]", verify: bool = True) -> "Run":
    """Opens the finished run in ``run_dir`` (as written by ``rwg run`` or
    ``rwg merge``).

    With ``verify`` (the default) every file of the run is first checked
    against its recorded SHA-256, as ``rwg verify`` does. Raises
    :class:`NotARunError` for a directory that is not a run (or is a shard),
    :class:`RunDamagedError` for files that do not match their checksums,
    :class:`RunInProgressError` for a study not finished yet (``K of N cells``),
    :class:`ArgumentError` for a ``run_dir`` that is not a path or a
    ``verify`` that is not a bool. The path is made absolute; the returned
    :class:`Run` reads the files as loaded (see :meth:`Run.scores`).
    """
    return Run(run_dir, verify=verify)


def _read_json(path: str) -> Any:
    try:
        with open(path, "rb") as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        raise RunDamagedError(f"{path}: cannot be read: {e}", [f"{path}: {e}"]) from e


class Run:
    """A finished rwg run directory (see ``rwg.load``).

    Attributes:
        path: the run directory, made absolute when loaded.
        meta: ``run.json`` as a dict (version, seed, samples, episodes,
            weights, threads, times, env steps, ``cells``).
        cells: the cells of ``run.json``, one dict each (``dir``, ``env``,
            ``arch``, ``hidden``, ``bias``, ``n_weights``, ``solved``,
            ``samples``, ``episodes``, ...), in the order they ran.
        manifest: the run's ``manifest.toml`` (the resolved study) as a dict.
        stats: ``stats.csv`` as a pandas DataFrame, one row per cell (computed
            by ``rwg stats`` when the run was made with ``--no-report``).
    """

    def __init__(self, run_dir: "str | bytes | os.PathLike[str]", verify: bool = True):
        where = "rwg.load"
        # Absolute: the run read later is this one, whatever os.chdir does.
        self.path = _args.absolute(_args.path(run_dir, "run_dir=", where), "run_dir=", where)
        verify = _args.flag(verify, "verify", where)
        self.meta: Dict[str, Any] = self._read_meta()
        self.manifest: Dict[str, Any] = self._read_manifest()
        self.cells: List[Dict[str, Any]] = self._read_cells()
        self._verified = self.meta.get("format", 1) >= RUN_FORMAT
        if not self._verified:
            warnings.warn(
                f"{self.path}: run format {self.meta.get('format', 1)}: written by an older rwg "
                "without checksums, so nothing in it can be verified",
                stacklevel=3,
            )
        elif verify:
            self._verify_all()
        self._check_finished(len(self.cells))
        # The digests of the cells' files as loaded: what scores() and
        # samples() read later must be these bytes (not a run rwg wrote
        # there since).
        self._sums: Dict[str, Optional[Dict[str, str]]] = (
            {c["dir"]: self._cell_sums(c["dir"]) for c in self.cells} if self._verified else {}
        )
        self.stats: pd.DataFrame = self._read_stats()

    def _read_meta(self) -> Dict[str, Any]:
        """``run.json``, after checking that the directory is a whole run."""
        path = self.path
        run_json = os.path.join(path, "run.json")
        if not os.path.isdir(path):
            what = "a file, not a run directory" if os.path.exists(path) else "no such directory"
            raise NotARunError(
                f"{path}: {what}; give the run directory rwg run wrote "
                "(its --out, e.g. runs/quick)"
            )
        if not os.path.isfile(run_json):
            if os.path.isfile(os.path.join(path, "manifest.toml")):
                # rwg run writes run.json just after manifest.toml
                self.meta, self.manifest = {}, self._read_manifest()
                self._check_finished(0)
            raise NotARunError(
                f"{path}: not an rwg run directory (no run.json in it); give the directory "
                "rwg run wrote (its --out, e.g. runs/quick)"
            )
        meta = _read_json(run_json)
        if not isinstance(meta, dict) or not isinstance(meta.get("cells"), list):
            raise NotARunError(f"{run_json}: not an rwg run.json (no list of cells in it)")
        shard = meta.get("shard")
        if shard:
            raise NotARunError(
                f"{path}: shard {shard.get('index')}/{shard.get('count')} of a study, not a whole "
                "run; combine the shards with `rwg merge SHARD_DIR... --out DIR` and load DIR"
            )
        return meta

    def _read_manifest(self) -> Dict[str, Any]:
        manifest_path = os.path.join(self.path, "manifest.toml")
        try:
            with open(manifest_path, "rb") as f:
                return tomllib.load(f)
        except (OSError, tomllib.TOMLDecodeError) as e:
            raise RunDamagedError(
                f"{manifest_path}: cannot be read: {e}", [f"{manifest_path}: {e}"]
            ) from e

    def _read_cells(self) -> List[Dict[str, Any]]:
        """``run.json``'s cells, each with a directory name that stays in the run."""
        run_json = os.path.join(self.path, "run.json")
        cells = list(self.meta["cells"])
        for c in cells:
            d = c.get("dir") if isinstance(c, dict) else None
            if not isinstance(d, str) or d in ("", ".", "..") or "/" in d or "\\" in d:
                raise RunDamagedError(
                    f"{run_json}: a cell's dir {d!r} is not a cell directory name",
                    [f"{run_json}: cell dir {d!r}"],
                )
        return cells

    def _check_finished(self, done: int) -> None:
        """Raises :class:`RunInProgressError` unless all the study's cells
        are finished and the run recorded its end."""
        total = self._cells_total()
        path = self.path
        if done < total or self.meta.get("end_time") is None:
            resume = f"`rwg run {shlex.quote(os.path.join(path, 'manifest.toml'))} --out {shlex.quote(path)}`"
            state = (
                f"{done} of {total} cells finished"
                if done < total
                else f"all {total} cells finished, but the run has not recorded its end"
            )
            raise RunInProgressError(
                f"{path}: run in progress: {state} (rwg run is still writing it, or it "
                f"stopped: `rwg status {path}` tells; {resume} finishes it)",
                done,
                total,
            )

    def _cell_sums(self, cell_dir: str) -> Optional[Dict[str, str]]:
        """A finished cell's ``SHA256SUMS``; ``None`` where it cannot be read
        (reading the cell's files then says why)."""
        try:
            return _verify.read_sums(os.path.join(self.path, "cells", cell_dir, _verify.SUMS), strict=True)
        except _verify.SumsError:
            return None

    def _cells_total(self) -> int:
        """The number of cells of the study in ``manifest.toml`` (envs x
        architectures x bias settings); a manifest.toml whose lists are not
        lists (edited after rwg wrote it) is a damaged run."""
        m = self.manifest
        counts = []
        for key, default, what in [
            ("envs", [], "a list of [[envs]] tables"),
            ("architectures", [], "a list of [[architectures]] tables"),
            ("bias", [False], "a list of true/false"),
        ]:
            value = m.get(key, default)
            ok = isinstance(value, list) and (
                key != "bias" or all(isinstance(b, bool) for b in value)
            )
            if not ok:
                mp = os.path.join(self.path, "manifest.toml")
                msg = (
                    f"{mp}: {key} is {_toml.value_text(value)}, not {what} (the file was changed "
                    "after rwg wrote it; run.json's study holds the original)"
                )
                raise RunDamagedError(msg, [msg])
            counts.append(len(value))
        return counts[0] * counts[1] * counts[2]

    def _verify_all(self) -> None:
        problems: List[str] = []
        cells_dir = os.path.join(self.path, "cells")
        listed = {c["dir"] for c in self.cells}
        try:
            names = sorted(n for n in os.listdir(cells_dir) if os.path.isdir(os.path.join(cells_dir, n)))
        except FileNotFoundError:
            names = []
        except OSError as e:
            raise RunDamagedError(f"cannot read {cells_dir}: {e}", [f"{cells_dir}: {e}"]) from e
        for d in sorted(listed - set(names)):
            problems.append(
                f"{os.path.join(cells_dir, d, _verify.SUMS)}: missing: run.json lists cell {d} "
                "as finished"
            )
        for name in names:
            cdir = os.path.join(cells_dir, name)
            if name in listed:
                problems.extend(_verify.verify_cell_files(cdir))
            problems.extend(_verify.verify_blocks(cdir))
        if problems:
            raise RunDamagedError(
                f"{self.path}: {len(problems)} problem(s) with the run's files "
                "(`rwg verify` lists the same):\n  " + "\n  ".join(problems),
                problems,
            )

    def _read_stats(self) -> pd.DataFrame:
        stats_csv = os.path.join(self.path, "stats.csv")
        if os.path.isfile(stats_csv):
            with open(stats_csv, "rb") as f:
                return self._this_runs_stats(_stats_frame(f.read(), stats_csv), stats_csv)
        try:
            rwg = find_rwg_bin()
        except RwgNotFoundError as e:
            raise RunError(
                f"{stats_csv}: missing (the run was made with --no-report), and rwg cannot be "
                f"found to compute it: {e}. Run `rwg stats {self.path}` to write it."
            ) from e
        try:
            res = subprocess.run(
                [rwg, "stats", self.path, "--format", "csv", "--no-write"],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
            )
        except OSError as e:
            raise start_error(rwg, e) from e
        if res.returncode != 0:
            raise RunError(
                f"{stats_csv}: missing (the run was made with --no-report), and "
                f"`rwg stats {self.path} --format csv --no-write` failed: "
                + res.stderr.decode("utf-8", "replace").strip()
            )
        return _stats_frame(res.stdout, f"`rwg stats {self.path} --format csv`")

    def _this_runs_stats(self, df: pd.DataFrame, stats_csv: str) -> pd.DataFrame:
        """``df``, read from ``stats.csv``, if it holds this run's cells (each
        cell's dir, samples and episodes as ``run.json`` records them): a
        stats.csv left by another study, or an earlier run in the folder, is
        refused (as ``rwg verify`` refuses it)."""
        want = [(c["dir"], c["samples"], c["episodes"]) for c in self.cells]
        try:
            got = list(zip(df["dir"], df["samples"].astype(int), df["episodes"].astype(int)))
        except (KeyError, ValueError, TypeError):
            got = None
        if got != want:
            problem = (
                f"{stats_csv}: written for another run than run.json records (another "
                f"study, or an earlier run in this folder); `rwg stats {self.path}` writes "
                "the statistics of this run again"
            )
            raise RunDamagedError(problem, [problem])
        return df

    def cell(self, env: str, arch: str, bias: bool = False) -> Dict[str, Any]:
        """The ``run.json`` entry of the cell (env, architecture, bias); a
        ``KeyError`` lists the run's cells when there is none. ``bias`` is
        ``True`` or ``False`` (a numpy bool too); any other value raises
        :class:`ArgumentError`."""
        where = "Run.cell"
        env = _args.text(env, "env", where, "the env's id as in the manifest")
        arch = _args.text(arch, "arch", where, "the architecture's name as in the manifest")
        bias = _args.flag(bias, "bias", where)
        for c in self.cells:
            if c["env"] == env and c["arch"] == arch and bool(c["bias"]) == bias:
                return c
        have = ", ".join(f"({c['env']!r}, {c['arch']!r}, bias={c['bias']})" for c in self.cells)
        raise KeyError(f"{self.path}: no cell ({env!r}, {arch!r}, bias={bias}); the run has {have}")

    def _cell_file(self, cell: Dict[str, Any], name: str) -> "tuple[str, bytes]":
        """The bytes of a finished cell's file, checked against the digest
        the cell's ``SHA256SUMS`` held when the run was loaded."""
        cdir = os.path.join(self.path, "cells", cell["dir"])
        path = os.path.join(cdir, name)
        if not os.path.isdir(self.path):
            raise NotARunError(
                f"{self.path}: no longer exists (moved or deleted since it was loaded); "
                "rwg.load the run where it is now"
            )
        try:
            with open(path, "rb") as f:
                data = f.read()
        except OSError as e:
            raise RunDamagedError(f"cannot read {path}: {e}", [f"{path}: {e}"]) from e
        if not self._verified:
            return path, data
        sums = self._sums.get(cell["dir"])
        try:
            now = _verify.read_sums(os.path.join(cdir, _verify.SUMS), strict=True)
        except _verify.SumsError as e:
            raise RunDamagedError(str(e), [str(e)]) from e
        if sums is not None and now is not None and now != sums:
            raise RunError(
                f"{cdir}: the cell's files changed since the run was loaded (rwg wrote "
                "another run there, e.g. with --force-new); rwg.load it again to read the "
                "run it holds now"
            )
        want = (sums if sums is not None else now or {}).get(name)
        if want is None:
            msg = f"{path}: not listed in {os.path.join(cdir, _verify.SUMS)}, so it cannot be verified"
            raise RunDamagedError(msg, [msg])
        got = _verify.sha256_hex(data)
        if got != want:
            msg = _verify.mismatch(path, want, got)
            raise RunDamagedError(msg, [msg])
        return path, data

    def scores(self, env: str, arch: str, bias: bool = False) -> np.ndarray:
        """The cell's episode scores (``scores.csv``) as a float64 array of
        shape (networks, episodes): row ``n`` holds network ``n``'s scores in
        episode order. The array is the caller's own: writeable, new on
        every call. Raises :class:`RunError` if rwg wrote another run into
        the directory since it was loaded, :class:`NotARunError` if the
        directory was moved or deleted."""
        return self._episodes(env, arch, bias)["score"].astype(np.float64)

    def non_finite(self, env: str, arch: str, bias: bool = False) -> np.ndarray:
        """Which of the cell's episodes a value that was not finite ended
        (its env's ``non_finite = "end"``: ``scores.csv``'s ``non_finite``
        column), as a bool array shaped as :meth:`scores`. A cell with the
        default (``"stop"``) stops the study at such a value instead, so a
        finished one has none: all False."""
        columns = self._episodes(env, arch, bias)
        if NON_FINITE not in columns:
            return np.zeros(columns["score"].shape, dtype=bool)
        return columns[NON_FINITE].astype(bool)

    def _episodes(self, env: str, arch: str, bias: bool) -> Dict[str, np.ndarray]:
        """The cell's ``scores.csv`` columns, each shaped (networks, episodes)."""
        c = self.cell(env, arch, bias)
        path, data = self._cell_file(c, "scores.csv")
        header = SCORES_HEADER + ([NON_FINITE] if _flagged(c) else [])
        df = read_scores_csv(data, path, flagged=_flagged(c))
        check_score_rows(df, c, path)
        n, e = int(c["samples"]), int(c["episodes"])
        if _flagged(c) and not df[NON_FINITE].isin([0, 1]).all():
            msg = f"{path}: a non_finite value other than 0 or 1"
            raise RunDamagedError(msg, [msg])
        # copy=True: a writeable array whatever pandas version (pandas 3
        # hands out read-only views of its columns).
        return {k: df[k].to_numpy(copy=True).reshape(n, e) for k in header[2:]}

    def samples(self, env: str, arch: str, bias: bool = False) -> pd.DataFrame:
        """The cell's per-network statistics (``samples.csv``): a DataFrame
        indexed by ``sample`` with columns ``mean``, ``variance``, ``std``,
        ``min``, ``max`` and ``rank`` (0 = the worst mean), and for a cell
        with ``non_finite = "end"`` ``non_finite`` (the network's episodes a
        value that was not finite ended)."""
        c = self.cell(env, arch, bias)
        path, data = self._cell_file(c, "samples.csv")
        header = SAMPLES_HEADER + ([NON_FINITE] if _flagged(c) else [])
        types = {k: np.float64 for k in header}
        types.update(sample=np.int64, rank=np.int64, **{NON_FINITE: np.int64})
        df = _read_csv(data, path, header, {k: types[k] for k in header})
        n = int(c["samples"])
        if len(df) != n or not np.array_equal(df["sample"].to_numpy(), np.arange(n)):
            msg = f"{path}: {len(df)} rows, not networks 0 to {n - 1} in order as run.json records"
            raise RunDamagedError(msg, [msg])
        return df.set_index("sample")

    def tidy(self) -> pd.DataFrame:
        """Every episode of every cell as one tidy DataFrame: ``rwg.tidy(run)``."""
        from ._tidy import tidy

        return tidy(self)

    def __repr__(self) -> str:
        return (
            f"<rwg.Run {self.path!r}: {len(self.cells)} cells, {self.meta.get('samples')} networks "
            f"x {self.meta.get('episodes')} episodes, seed {self.meta.get('seed')}>"
        )


_SCORE_TYPES = {"sample": np.int64, "episode": np.int64, "score": np.float64, "steps": np.int64}


def read_scores_csv(
    data: bytes, path: str, exact_header: bool = True, flagged: bool = False
) -> pd.DataFrame:
    """A cell's ``scores.csv``: its header must be :data:`SCORES_HEADER`
    (with ``non_finite`` for a ``flagged`` cell), or (``exact_header=False``)
    start with it, further columns read as pandas reads them."""
    header = SCORES_HEADER + ([NON_FINITE] if flagged else [])
    types = dict(_SCORE_TYPES, **({NON_FINITE: np.int64} if flagged else {}))
    return _read_csv(data, path, header, types, exact_header)


def check_score_rows(df: pd.DataFrame, cell: Dict[str, Any], path: str) -> None:
    """Raises :class:`RunDamagedError` unless ``df`` holds the cell's
    networks x episodes, in order, as ``run.json`` records them."""
    n, e = int(cell["samples"]), int(cell["episodes"])
    want_sample = np.repeat(np.arange(n, dtype=np.int64), e)
    want_episode = np.tile(np.arange(e, dtype=np.int64), n)
    if len(df) != n * e or not (
        np.array_equal(df["sample"].to_numpy(), want_sample)
        and np.array_equal(df["episode"].to_numpy(), want_episode)
    ):
        msg = (
            f"{path}: {len(df)} rows, not the {n} networks x {e} episodes in order that "
            "run.json records for the cell"
        )
        raise RunDamagedError(msg, [msg])


def _flagged(cell: Dict[str, Any]) -> bool:
    """Whether the cell's files carry the non_finite column (its env has
    non_finite = "end": cell.json counts such episodes)."""
    return cell.get("non_finite_episodes") is not None


def _read_csv(
    data: bytes, path: str, header: List[str], types: Dict[str, Any], exact: bool = True
) -> pd.DataFrame:
    first = data.split(b"\n", 1)[0].decode("utf-8", "replace").strip()
    got = first.split(",")
    if (got != header) if exact else (got[: len(header)] != header):
        expected = ",".join(header) + ("" if exact else ",...")
        msg = f"{path}:1: header {first!r}, expected {expected!r}"
        raise RunDamagedError(msg, [msg])
    try:
        return pd.read_csv(io.BytesIO(data), dtype=types, **_EXACT)
    except (ValueError, pd.errors.ParserError) as e:
        raise RunDamagedError(f"{path}: {e}", [f"{path}: {e}"]) from e


def _stats_frame(data: bytes, source: str) -> pd.DataFrame:
    try:
        df = pd.read_csv(
            io.BytesIO(data),
            dtype={c: str for c in _TEXT_COLUMNS},
            keep_default_na=False,
            na_values=[""],
            **_EXACT,
        )
    except (ValueError, pd.errors.ParserError) as e:
        raise RunError(f"{source}: cannot be read as stats.csv: {e}") from e
    for c in _TEXT_COLUMNS:
        if c in df:
            df[c] = df[c].fillna("")
    if "bias" in df:
        df["bias"] = df["bias"].map({"true": True, "false": False}).astype(bool)
    return df

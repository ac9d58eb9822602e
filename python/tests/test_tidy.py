"""rwg.tidy: every episode of one or several runs as one tidy frame."""

import shutil

import numpy as np
import pandas as pd
import pytest

import rwg
from rwg import _verify


def test_one_run_is_every_episode_of_every_cell_in_order(small_run):
    run = rwg.load(small_run)
    df = rwg.tidy(run)
    assert list(df.columns) == rwg.TIDY_COLUMNS
    assert list(df.columns) == ["run", "env", "arch", "bias", "sample", "episode", "score", "steps"]
    assert [str(t) for t in df.dtypes] == [
        "object", "object", "object", "bool", "int64", "int64", "float64", "int64"
    ]
    assert len(df) == 8 * 40 * 3
    assert set(df["run"]) == {"run"}
    pd.testing.assert_frame_equal(df, run.tidy())
    # the cells in run.json's order, each its networks x episodes as scores() gives them
    for i, c in enumerate(run.cells):
        part = df.iloc[i * 120 : (i + 1) * 120]
        assert (part["env"] == c["env"]).all() and (part["arch"] == c["arch"]).all()
        assert (part["bias"] == c["bias"]).all()
        assert part["sample"].tolist() == list(np.repeat(np.arange(40), 3))
        assert part["episode"].tolist() == [0, 1, 2] * 40
        scores = run.scores(c["env"], c["arch"], c["bias"])
        assert np.array_equal(part["score"].to_numpy(), scores.reshape(-1))
        # the per-network means of the frame are samples.csv's
        means = part.groupby("sample")["score"].mean().to_numpy()
        want = run.samples(c["env"], c["arch"], c["bias"])["mean"].to_numpy()
        assert np.allclose(means, want, rtol=1e-12, atol=1e-12)


def test_several_runs_are_labelled_by_directory_or_by_path(small_run, tmp_path):
    other = tmp_path / "other"
    shutil.copytree(small_run, other)
    df = rwg.tidy([small_run, rwg.load(other)])
    assert list(df["run"].unique()) == ["run", "other"]
    assert len(df) == 2 * 960
    a, b = (df[df["run"] == r].drop(columns="run").reset_index(drop=True) for r in ("run", "other"))
    pd.testing.assert_frame_equal(a, b)
    # two runs both named "run": each is its absolute path
    twin = tmp_path / "x" / "run"
    shutil.copytree(small_run, twin)
    labels = list(rwg.tidy((str(small_run), twin))["run"].unique())
    assert labels == [str(small_run), str(twin)]


def test_further_columns_of_scores_csv_are_carried(run_copy):
    run = rwg.load(run_copy)
    c = run.cells[0]
    cdir = run_copy / "cells" / c["dir"]
    lines = (cdir / "scores.csv").read_text().splitlines()
    flagged = [lines[0] + ",flag"] + [f"{l},{int(i == 4)}" for i, l in enumerate(lines[1:])]
    data = ("\n".join(flagged) + "\n").encode()
    (cdir / "scores.csv").write_bytes(data)
    sums = (cdir / "SHA256SUMS").read_text().splitlines()
    sums = [f"{_verify.sha256_hex(data)}  scores.csv" if s.endswith("  scores.csv") else s for s in sums]
    (cdir / "SHA256SUMS").write_text("\n".join(sums) + "\n")
    df = rwg.tidy(run_copy)
    assert list(df.columns) == rwg.TIDY_COLUMNS + ["flag"]
    assert df["flag"].iloc[:120].tolist() == [0] * 4 + [1] + [0] * 115
    assert df["flag"].iloc[120:].isna().all()


def test_bad_runs_are_argument_errors(small_run):
    for bad, match in [
        (3, "runs takes a Run"),
        ([], "runs is empty"),
        ([small_run, 3], "runs takes a Run or a run directory's path, not 3"),
        ([small_run, str(small_run)], "is given twice"),
    ]:
        with pytest.raises(rwg.ArgumentError, match=match):
            rwg.tidy(bad)
    with pytest.raises(rwg.NotARunError):
        rwg.tidy(small_run.parent)


def test_a_damaged_scores_csv_is_named(run_copy):
    c = rwg.load(run_copy).cells[0]
    f = run_copy / "cells" / c["dir"] / "scores.csv"
    f.write_bytes(f.read_bytes().replace(b"\n0,1,", b"\n0,7,", 1))
    with pytest.raises(rwg.RunDamagedError, match="scores.csv"):
        rwg.tidy(run_copy)

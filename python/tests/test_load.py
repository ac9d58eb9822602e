"""rwg.load on finished, damaged, unfinished and non-run directories."""

import csv
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import rwg
from conftest import rwg_cli

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib


SMALL_ONE_CELL = """\
samples = 32
episodes = 2
[[architectures]]
name = "0HL"
hidden = []
[[envs]]
id = "CartPole-v1"
"""


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def same(got, text):
    """Whether the loaded number ``got`` is the CSV field ``text``, exactly
    (an empty field: NaN)."""
    if text == "":
        return math.isnan(got)
    return float(got) == float(text)


def test_a_finished_run_loads_with_the_values_of_its_files(small_run):
    run = rwg.load(small_run)
    with open(small_run / "run.json") as f:
        meta = json.load(f)
    with open(small_run / "manifest.toml", "rb") as f:
        assert run.manifest == tomllib.load(f)
    assert run.cells == meta["cells"] and run.meta == meta
    assert len(run.cells) == 8
    # stats.csv: one row per cell, every field exactly (strings as strings)
    want = rows(small_run / "stats.csv")
    assert list(run.stats.columns) == list(want[0].keys())
    assert len(run.stats) == len(want) == 8
    for i, r in enumerate(want):
        for col, text in r.items():
            got = run.stats[col].iloc[i]
            if col in ("dir", "env", "arch", "hidden"):
                assert got == text, (col, i)
            elif col == "bias":
                assert got == (text == "true"), (col, i)
            else:
                assert same(got, text), (col, i, got, text)
    assert run.stats["bias"].tolist() == [c["bias"] for c in meta["cells"]]
    for c in meta["cells"]:
        cdir = small_run / "cells" / c["dir"]
        scores = run.scores(c["env"], c["arch"], bias=c["bias"])
        assert scores.shape == (40, 3) and scores.dtype == np.float64
        for r in rows(cdir / "scores.csv"):
            assert scores[int(r["sample"]), int(r["episode"])] == float(r["score"])
        assert not run.non_finite(c["env"], c["arch"], c["bias"]).any()
        samples = run.samples(c["env"], c["arch"], c["bias"])
        assert list(samples.columns) == ["mean", "variance", "std", "min", "max", "rank"]
        assert samples.index.name == "sample"
        for r in rows(cdir / "samples.csv"):
            s = samples.loc[int(r["sample"])]
            for col in ["mean", "variance", "std", "min", "max"]:
                assert s[col] == float(r[col]), (c["dir"], r["sample"], col)
            assert s["rank"] == int(r["rank"])
        # the statistics the files share agree
        assert np.array_equal(samples["mean"].to_numpy(), scores.mean(axis=1))
    assert "8 cells" in repr(run)


NON_FINITE = """\
seed = 3
samples = 64
episodes = 2
bias = [true]
[weights]
scale = 1e307
[[architectures]]
name = "1HL"
hidden = [64]
[[envs]]
id = "CartPole-v1"
non_finite = "end"
"""


def test_a_cell_with_non_finite_end_gives_its_flags_and_counts(tmp_path):
    # weights of scale 1e307 into 64 units: some network outputs overflow,
    # which ends those episodes (flagged) with non_finite = "end"
    (tmp_path / "m.toml").write_text(NON_FINITE)
    rwg_cli("run", tmp_path / "m.toml", "--out", tmp_path / "run", "-q", "--no-report")
    run = rwg.load(tmp_path / "run")
    cdir = tmp_path / "run" / "cells" / run.cells[0]["dir"]
    flags = run.non_finite("CartPole-v1", "1HL", bias=True)
    scores = run.scores("CartPole-v1", "1HL", bias=True)
    assert flags.shape == scores.shape == (64, 2) and flags.dtype == bool
    for r in rows(cdir / "scores.csv"):
        n, e = int(r["sample"]), int(r["episode"])
        assert flags[n, e] == (r["non_finite"] == "1")
        assert scores[n, e] == float(r["score"])
    assert 0 < flags.sum() < flags.size
    assert flags.sum() == run.cells[0]["non_finite_episodes"]
    samples = run.samples("CartPole-v1", "1HL", bias=True)
    assert samples["non_finite"].tolist() == flags.sum(axis=1).tolist()
    assert run.stats["non_finite_episodes"].tolist() == [flags.sum()]


def test_an_unknown_cell_names_the_run_s_cells(small_run):
    run = rwg.load(small_run)
    with pytest.raises(KeyError, match=r"no cell \('CartPole-v0', '2HL', bias=False\); the run has"):
        run.scores("CartPole-v0", "2HL")
    assert run.scores("Pendulum-v0", "1HL-4", bias=True).shape == (40, 3)


def test_a_damaged_file_is_refused_naming_it(run_copy):
    cell = run_copy / "cells" / "Pendulum-v0__0HL__bias"
    data = bytearray((cell / "scores.csv").read_bytes())
    i = data.index(b"\n", 40) - 1
    data[i] = ord("7") if data[i] != ord("7") else ord("3")
    (cell / "scores.csv").write_bytes(bytes(data))
    with pytest.raises(rwg.RunDamagedError) as e:
        rwg.load(run_copy)
    assert len(e.value.problems) == 1
    assert f"{cell / 'scores.csv'}: checksum mismatch" in str(e.value)
    # unverified loading still checks what it reads
    run = rwg.load(run_copy, verify=False)
    run.scores("Pendulum-v0", "0HL", bias=False)
    with pytest.raises(rwg.RunDamagedError, match="scores.csv: checksum mismatch"):
        run.scores("Pendulum-v0", "0HL", bias=True)
    # rwg verify agrees
    res = rwg_cli("verify", run_copy, check=False)
    assert res.returncode == 1 and "checksum mismatch" in res.stdout + res.stderr


def test_a_finished_cell_without_its_checksums_is_refused(run_copy):
    os.remove(run_copy / "cells" / "CartPole-v0__1HL-4__nobias" / "SHA256SUMS")
    with pytest.raises(rwg.RunDamagedError, match=r"SHA256SUMS: missing: run.json lists"):
        rwg.load(run_copy)


def test_stats_are_computed_by_rwg_when_stats_csv_is_missing(small_run, run_copy):
    os.remove(run_copy / "stats.csv")
    os.remove(run_copy / "stats.json")
    run = rwg.load(run_copy)
    want = rwg.load(small_run).stats
    assert run.stats.drop(columns=[]).equals(want)
    assert not (run_copy / "stats.csv").exists(), "loading must not write into the run"


def test_a_stats_csv_of_another_run_is_refused(tmp_path, run_copy):
    other = tmp_path / "other"
    (tmp_path / "m.toml").write_text((run_copy / "manifest.toml").read_text())
    rwg_cli("run", tmp_path / "m.toml", "--out", other, "--samples", "33", "-q")
    shutil.copy(other / "stats.csv", run_copy / "stats.csv")
    with pytest.raises(rwg.RunDamagedError, match=r"stats.csv: written for another run"):
        rwg.load(run_copy)
    res = rwg_cli("verify", run_copy, check=False)
    assert res.returncode == 1 and "stats.csv: written for another run" in res.stdout


def test_a_run_that_did_not_record_its_end_is_in_progress(run_copy):
    # rwg writes end_time after the last cell: a run stopped in between
    meta = json.loads((run_copy / "run.json").read_text())
    meta["end_time"] = None
    (run_copy / "run.json").write_text(json.dumps(meta))
    with pytest.raises(rwg.RunInProgressError, match="all 8 cells finished, but the run has not") as e:
        rwg.load(run_copy)
    assert (e.value.cells_done, e.value.cells_total) == (8, 8)
    res = rwg_cli("run", run_copy / "manifest.toml", "--out", run_copy, "-q")
    assert json.loads((run_copy / "run.json").read_text())["end_time"] is not None, res.stderr
    assert len(rwg.load(run_copy).cells) == 8


def test_directories_that_are_not_runs_are_refused(tmp_path, small_run):
    with pytest.raises(rwg.NotARunError, match="no run.json"):
        rwg.load(tmp_path)
    with pytest.raises(rwg.NotARunError, match="no such directory"):
        rwg.load(tmp_path / "nothing")
    with pytest.raises(rwg.NotARunError, match="run.json: a file, not a run directory"):
        rwg.load(small_run / "run.json")
    # one shard of a study
    rwg_cli("run", small_run / "manifest.toml", "--shard", "0/2", "--out", tmp_path / "s0", "-q")
    with pytest.raises(rwg.NotARunError, match=r"shard 0/2 of a study.*rwg merge"):
        rwg.load(tmp_path / "s0")
    assert isinstance(rwg.NotARunError("x"), rwg.RunError)


LONG = """\
samples = 320
episodes = 6
[[architectures]]
name = "0HL"
hidden = []
[[architectures]]
name = "1HL-4"
hidden = [4]
[[envs]]
id = "CartPole-v0"
[[envs]]
id = "Acrobot-v1"
"""


def recorded_cells(out):
    """How many cells run.json lists as finished (0 while it is unreadable)."""
    try:
        with open(out / "run.json") as f:
            return len(json.load(f)["cells"])
    except (OSError, ValueError, KeyError):
        return 0


def test_a_run_in_progress_is_refused_naming_k_of_n_cells(tmp_path):
    (tmp_path / "long.toml").write_text(LONG)
    out = tmp_path / "run"
    env = dict(os.environ, RWG_COMMIT_LINGER="0")
    proc = subprocess.Popen(
        [rwg.find_rwg_bin(), "run", str(tmp_path / "long.toml"), "--out", str(out), "--threads", "2", "-q"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    acrobot = out / "cells" / "Acrobot-v1__0HL__nobias" / "blocks"
    try:
        deadline = time.monotonic() + 300
        # CartPole's two cells are finished and Acrobot's first has committed blocks
        while (
            not (acrobot / "SHA256SUMS").is_file()
            or (acrobot / "SHA256SUMS").stat().st_size < 200
            or recorded_cells(out) < 2  # recorded by a thread of its own, maybe later
        ):
            assert proc.poll() is None, "the study ended before it could be observed in progress"
            assert time.monotonic() < deadline, "no committed Acrobot block after 300 s"
            time.sleep(0.05)
        # while rwg writes it
        with pytest.raises(rwg.RunInProgressError) as e:
            rwg.load(out)
        assert 2 <= e.value.cells_done < 4 and e.value.cells_total == 4
        assert f"run in progress: {e.value.cells_done} of 4 cells finished" in str(e.value)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    with open(out / "run.json") as f:
        k = len(json.load(f)["cells"])
    with pytest.raises(rwg.RunInProgressError, match=f"{k} of 4 cells finished.*--out {re.escape(str(out))}` finishes it"):
        rwg.load(out)
    # a damaged committed block of the unfinished cell
    committed = (acrobot / "SHA256SUMS").read_text().split("\n")[0].split("  ")[1]
    with open(acrobot / committed, "ab") as f:
        f.write(b"0,0,1.0,1\n")
    with pytest.raises(rwg.RunDamagedError, match=re.escape(f"{acrobot / committed}: checksum mismatch")):
        rwg.load(out)
    shutil.rmtree(tmp_path)


def test_a_run_rewritten_after_load_is_never_read_as_the_loaded_one(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(SMALL_ONE_CELL)
    rwg_cli("run", study, "--out", tmp_path / "run", "--seed", "1", "-q")
    run = rwg.load(tmp_path / "run")
    before = run.scores("CartPole-v1", "0HL")
    rwg_cli("run", study, "--out", tmp_path / "run", "--seed", "2", "--force-new", "-q")
    with pytest.raises(rwg.RunError, match=r"changed since the run was loaded.*rwg.load it again"):
        run.scores("CartPole-v1", "0HL")
    with pytest.raises(rwg.RunError, match=r"changed since the run was loaded"):
        run.samples("CartPole-v1", "0HL")
    again = rwg.load(tmp_path / "run")
    assert again.meta["seed"] == 2 and not np.array_equal(again.scores("CartPole-v1", "0HL"), before)


def test_a_run_moved_after_load_says_so(run_copy, tmp_path):
    run = rwg.load(run_copy)
    run_copy.rename(tmp_path / "elsewhere")
    with pytest.raises(rwg.NotARunError, match=r"no longer exists \(moved or deleted since it was loaded\)"):
        run.scores("CartPole-v0", "0HL")
    assert rwg.load(tmp_path / "elsewhere").scores("CartPole-v0", "0HL").shape == (40, 3)


def test_a_relative_path_from_a_deleted_directory_is_an_argument_error(tmp_path, monkeypatch, small_run):
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    with pytest.raises(rwg.ArgumentError, match=r"run_dir= 'run' is relative and the current directory cannot be read"):
        rwg.load("run")
    assert len(rwg.load(small_run).cells) == 8


def test_a_run_that_is_starting_is_in_progress_not_a_non_run(run_copy):
    # What rwg run has written just before run.json: the run directory and its manifest.
    for p in ["run.json", "stats.csv"]:
        (run_copy / p).unlink()
    shutil.rmtree(run_copy / "cells")
    with pytest.raises(rwg.RunInProgressError, match=r"run in progress: 0 of 8 cells finished") as e:
        rwg.load(run_copy)
    assert (e.value.cells_done, e.value.cells_total) == (0, 8)

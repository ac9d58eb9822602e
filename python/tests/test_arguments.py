"""Every argument of rwg.run, rwg.load and Run's methods is checked: a bad
one raises the package's rwg.ArgumentError (also a TypeError and a
ValueError) naming it, never a bare Python error or the wrong cell; odd but
valid ones (numpy integers, Path and bytes paths, paths starting with "-")
work."""

import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import rwg
from conftest import SMALL, rwg_cli

TINY = {
    "samples": 8,
    "episodes": 2,
    "architectures": [{"name": "0HL", "hidden": []}],
    "envs": [{"id": "CartPole-v1"}],
}


def test_bias_must_be_a_bool(small_run):
    run = rwg.load(small_run)
    on = run.scores("CartPole-v0", "0HL", True)
    off = run.scores("CartPole-v0", "0HL", False)
    assert not np.array_equal(on, off)
    assert np.array_equal(run.scores("CartPole-v0", "0HL", np.bool_(True)), on)
    for bad in ["false", "true", 1, 0, None, [True]]:
        for method in (run.scores, run.samples, run.cell):
            with pytest.raises(rwg.ArgumentError, match=r"bias= takes True or False, not"):
                method("CartPole-v0", "0HL", bad)
    with pytest.raises(rwg.ArgumentError, match=r"env= takes the env's id"):
        run.scores(b"CartPole-v0", "0HL")
    with pytest.raises(rwg.ArgumentError, match=r"arch= takes the architecture's name"):
        run.samples("CartPole-v0", 0)
    assert issubclass(rwg.ArgumentError, (rwg.RunError, TypeError, ValueError))


def test_a_run_loaded_from_a_relative_path_stays_that_run_after_chdir(small_run, tmp_path, monkeypatch):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    shutil.copytree(small_run, a / "run")
    # b/run: another study under the same relative name
    (b / "s.toml").write_text(SMALL.replace("seed = 7", "seed = 8"))
    rwg_cli("run", b / "s.toml", "--out", b / "run", "-q")
    monkeypatch.chdir(a)
    run = rwg.load("run")
    want = run.scores("CartPole-v0", "0HL")
    assert run.path == str(a / "run")
    monkeypatch.chdir(b)
    assert np.array_equal(run.scores("CartPole-v0", "0HL"), want)
    assert run.samples("CartPole-v0", "0HL")["mean"].tolist() == want.mean(axis=1).tolist()


def test_scores_are_a_writeable_array_of_the_caller_s_own(small_run):
    run = rwg.load(small_run)
    s = run.scores("Pendulum-v0", "1HL-4", True)
    assert s.flags.writeable, f"read-only under pandas {pd.__version__}"
    s[0, 0] = 12345.0
    assert run.scores("Pendulum-v0", "1HL-4", True)[0, 0] != 12345.0


def test_paths_starting_with_a_dash_reach_rwg_as_paths(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("-study.toml").write_text(SMALL)
    run = rwg.run("-study.toml", out="-out", samples=8, episodes=1, quiet=True, no_report=True)
    assert run.path == str(tmp_path / "-out") and len(run.cells) == 8
    run = rwg.run(TINY, out="-tiny", quiet=True)
    assert run.path == str(tmp_path / "-tiny")
    assert rwg.load("-tiny").meta["samples"] == 8


def test_numpy_integers_path_out_keys_and_bytes_paths_are_taken(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run = rwg.run(
        dict(TINY, out=Path("from-key")),
        samples=np.int64(16),
        episodes=np.int32(1),
        seed=np.uint64(3),
        threads=np.int8(1),
        quiet=np.bool_(True),
    )
    assert run.path == str(tmp_path / "from-key")
    assert (run.meta["samples"], run.meta["episodes"], run.meta["seed"]) == (16, 1, 3)
    assert rwg.load(b"from-key").meta["seed"] == 3
    # an out key of None is no out key
    assert rwg.run(dict(TINY, out=None), out="kw", quiet=True).path == str(tmp_path / "kw")
    Path("t.toml").write_text(SMALL)
    run = rwg.run(b"t.toml", out=b"t-out", samples=8, episodes=1, quiet=True, no_report=True)
    assert run.path == str(tmp_path / "t-out")


def test_bad_overrides_are_refused_naming_them(tmp_path):
    out = tmp_path / "x"
    cases = [
        (dict(samples="many"), r"samples= takes a whole number, not 'many'"),
        (dict(samples=2.5), r"samples= takes a whole number, not 2.5"),
        (dict(samples=True), r"samples= takes a whole number, not True"),
        (dict(seed=-1), r"seed= must be 0 or more, not -1"),
        (dict(episodes=np.float64(3.0)), r"episodes= takes a whole number"),
        (dict(threads=[2]), r"threads= takes a whole number"),
        (dict(quiet="yes"), r"quiet= takes True or False, not 'yes'"),
        (dict(sample=3), r"unknown option sample=; the options are out, episodes"),
        (dict(shard="0/2"), r"shards are not run from Python"),
    ]
    for kwargs, message in cases:
        with pytest.raises(rwg.ArgumentError, match=message):
            rwg.run(TINY, out=out, **kwargs)
    with pytest.raises(rwg.ArgumentError, match=r"manifest= takes the path of a TOML manifest or a dict, not 42"):
        rwg.run(42, out=out)
    with pytest.raises(rwg.ArgumentError, match=r"out= takes the run directory's path, not 7"):
        rwg.run(TINY, out=7)
    with pytest.raises(rwg.ArgumentError, match=r"a dict needs a run directory"):
        rwg.run(TINY)
    with pytest.raises(rwg.ArgumentError, match=r"'out' key takes the run directory's path, not 3"):
        rwg.run(dict(TINY, out=3))
    with pytest.raises(rwg.ArgumentError, match=r"manifest key envs.solved: cannot write a set"):
        rwg.run(dict(TINY, envs=[{"id": "CartPole-v0", "solved": {1}}]), out=out)
    assert not out.exists()


def test_text_that_utf_8_cannot_hold_is_an_argument_error_naming_where(tmp_path):
    out = tmp_path / "x"
    cases = [
        (dict(TINY, envs=[{"id": "CartPole-v1\ud800"}]), r"manifest key envs.id: the string"),
        (dict(TINY, **{"note\udcff": 1}), r"manifest key \(top level\): the key"),
        (dict(TINY, architectures=[{"name": "a\udfff", "hidden": []}]), r"manifest key architectures.name"),
        (dict(TINY, envs=[{"id": "CartPole-v1", "kwargs": {"k": ["\ud800"]}}]), r"envs.kwargs.k"),
    ]
    for manifest, where in cases:
        with pytest.raises(rwg.ArgumentError, match=where + r".*lone surrogate"):
            rwg.run(manifest, out=out)
    with pytest.raises(rwg.ArgumentError, match=r"out= .*lone surrogate"):
        rwg.run(TINY, out=str(out) + "\ud800")
    with pytest.raises(rwg.ArgumentError, match=r"manifest= .*lone surrogate"):
        rwg.run(str(tmp_path / "m\ud800.toml"))
    with pytest.raises(rwg.ArgumentError, match=r"run_dir= .*lone surrogate"):
        rwg.load(str(tmp_path / "r\ud800"))
    assert not out.exists()
    # a file name's undecodable bytes (surrogate escapes) are a path still
    assert rwg.run(TINY, out=os.fsencode(str(out)) + b"\xff").path.endswith("x\udcff")


def test_deep_dicts_and_home_paths(tmp_path, monkeypatch):
    deep = cur = {}
    for _ in range(5000):
        cur["k"] = {}
        cur = cur["k"]
    with pytest.raises(rwg.ArgumentError, match=r"nest too deep to write as TOML"):
        rwg.run(dict(TINY, envs=[{"id": "CartPole-v1", "kwargs": deep}]), out=tmp_path / "d")
    # `~` is the home folder, as in pandas, not a folder named ~ in the current one
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)
    run = rwg.run(TINY, out="~/runs/tiny")
    assert run.path == str(tmp_path / "home" / "runs" / "tiny")
    assert not (tmp_path / "~").exists()
    assert rwg.load("~/runs/tiny").path == run.path


def test_load_s_bad_arguments_and_a_file_say_what_they_are(tmp_path, small_run):
    f = tmp_path / "a-file.txt"
    f.write_text("x")
    with pytest.raises(rwg.NotARunError, match=r"a-file.txt: a file, not a run directory"):
        rwg.load(f)
    with pytest.raises(rwg.NotARunError, match=r"no such directory"):
        rwg.load(tmp_path / "missing")
    with pytest.raises(rwg.ArgumentError, match=r"run_dir= takes the run directory's path, not 12"):
        rwg.load(12)
    with pytest.raises(rwg.ArgumentError, match=r"verify= takes True or False, not 'no'"):
        rwg.load(small_run, verify="no")


def test_a_manifest_toml_with_a_scalar_bias_is_a_damaged_run(run_copy):
    m = run_copy / "manifest.toml"
    text = m.read_text()
    assert "bias = [false, true]" in text
    m.write_text(text.replace("bias = [false, true]", "bias = true"))
    with pytest.raises(rwg.RunDamagedError, match=r"manifest.toml: bias is true, not a list of true/false"):
        rwg.load(run_copy)


def test_a_wrong_rwg_bin_is_rwg_not_found(tmp_path, monkeypatch):
    for bad in [tmp_path, tmp_path / "missing"]:
        monkeypatch.setenv("RWG_BIN", str(bad))
        with pytest.raises(rwg.RwgNotFoundError, match="RWG_BIN="):
            rwg.run(TINY, out=tmp_path / "x")
    text = tmp_path / "not-executable"
    text.write_text("#!/bin/sh\nexit 0\n")
    monkeypatch.setenv("RWG_BIN", str(text))
    with pytest.raises(rwg.RwgNotFoundError, match=r"RWG_BIN=.*not-executable: not an executable"):
        rwg.run(TINY, out=tmp_path / "x")
    # set to the empty string: not taken as unset
    monkeypatch.setenv("RWG_BIN", "")
    with pytest.raises(rwg.RwgNotFoundError, match=r"RWG_BIN is set to the empty string: unset it"):
        rwg.run(TINY, out=tmp_path / "x")
    garbage = tmp_path / "garbage"
    garbage.write_bytes(b"\x00\x01 not a program")
    garbage.chmod(0o755)
    monkeypatch.setenv("RWG_BIN", str(garbage))
    with pytest.raises(rwg.RwgNotFoundError, match=r"cannot start .*garbage"):
        rwg.run(TINY, out=tmp_path / "x")

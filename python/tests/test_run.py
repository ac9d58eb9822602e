"""rwg.run: dict and file manifests, overrides, failures, the interpreter of
gymnasium: envs, Ctrl-C."""

import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time

import pytest

import rwg
from conftest import SMALL, python_env, rwg_cli

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

STUDY = {
    "seed": 1,
    "samples": 1000,
    "episodes": 50,
    "bias": [False, True],
    "weights": {"distribution": "uniform", "scale": 0.5},
    "architectures": [{"name": "0HL", "hidden": []}, {"name": "1HL-3", "hidden": [3]}],
    "envs": [{"id": "MountainCar-v0", "solved": -110}, {"id": "Pendulum-v1"}],
}


def test_a_dict_manifest_with_overrides_gives_the_cli_s_bytes(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run = rwg.run(STUDY, out="api", samples=40, episodes=2, seed=9, threads=1, quiet=True)
    assert isinstance(run, rwg.Run) and run.path == str(tmp_path / "api")
    assert (run.meta["samples"], run.meta["episodes"], run.meta["seed"]) == (40, 2, 9)
    assert run.manifest["weights"] == {"distribution": "uniform", "scale": 0.5}
    assert len(run.cells) == 8 and len(run.stats) == 8
    assert run.scores("Pendulum-v1", "1HL-3", bias=True).shape == (40, 2)
    # the same study from a TOML file through the CLI, on other threads
    cli_study = dict(STUDY, samples=40, episodes=2, seed=9)
    from rwg import _toml

    (tmp_path / "same.toml").write_text(_toml.dumps(cli_study))
    rwg_cli("run", "same.toml", "--out", "cli", "--threads", "2", "-q")
    for c in run.cells:
        for f in ["scores.csv", "samples.csv"]:
            a = (tmp_path / "api" / "cells" / c["dir"] / f).read_bytes()
            assert a == (tmp_path / "cli" / "cells" / c["dir"] / f).read_bytes(), (c["dir"], f)
    assert (tmp_path / "api" / "stats.csv").read_bytes() == (tmp_path / "cli" / "stats.csv").read_bytes()
    # no temporary manifest is left behind; the run directory holds the study
    assert sorted(os.listdir(tmp_path)) == ["api", "cli", "same.toml"]
    # running it again finds it complete
    again = rwg.run(STUDY, out="api", samples=40, episodes=2, seed=9, quiet=True)
    assert again.stats.equals(run.stats)


def test_a_manifest_file_runs_into_its_out_with_no_report(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "small.toml").write_text('out = "runs/from-file"\n' + SMALL)
    run = rwg.run("small.toml", samples=32, no_report=True)
    assert run.path == str(tmp_path / "runs/from-file")
    assert not (tmp_path / "runs/from-file/stats.csv").exists()
    assert len(run.stats) == 8 and (run.stats["samples"] == 32).all()
    # rwg's summary reached sys.stdout, its progress sys.stderr
    out, err = capsys.readouterr()
    assert "CartPole-v0" in out and "networks" in err
    # without `out` anywhere: runs/NAME, as rwg picks
    (tmp_path / "plain.toml").write_text(SMALL)
    run = rwg.run(tmp_path / "plain.toml", samples=32, episodes=1, quiet=True)
    assert run.path == str(tmp_path / "runs" / "plain") and run.meta["episodes"] == 1


def test_options_are_checked_before_running(tmp_path):
    with pytest.raises(TypeError, match="unknown option sample=; the options are out, episodes"):
        rwg.run(STUDY, out=tmp_path / "x", sample=3)
    with pytest.raises(TypeError, match="no_report= takes True or False"):
        rwg.run(STUDY, out=tmp_path / "x", no_report="yes")
    with pytest.raises(TypeError, match="shards are not run from Python"):
        rwg.run(STUDY, out=tmp_path / "x", shard="0/2")
    with pytest.raises(ValueError, match="a dict needs a run directory|needs a run directory"):
        rwg.run(STUDY)
    with pytest.raises(TypeError, match=r"manifest key envs.solved: cannot write a set"):
        rwg.run(dict(STUDY, envs=[{"id": "CartPole-v0", "solved": {1}}]), out=tmp_path / "x")
    assert not (tmp_path / "x").exists()


def test_a_failure_raises_rwg_s_message(tmp_path, capsys):
    bad = dict(STUDY, envs=[{"id": "CartPole-v0"}, {"id": "Nope-v0"}])
    with pytest.raises(rwg.RwgFailedError) as e:
        rwg.run(bad, out=tmp_path / "bad")
    # the message is the exception's, not printed as well
    assert "unknown environment" not in capsys.readouterr().err
    msg = str(e.value)
    assert re.search(r"^error: .*bad\.toml:\d+:\d+: envs: unknown environment 'Nope-v0'", msg), msg
    # the manifest written from the dict is shown, numbered, for the line in the message
    line = int(re.search(r"bad\.toml:(\d+):", msg).group(1))
    assert re.search(rf"^ *{line}  id = \"Nope-v0\"$", msg, re.M), msg
    assert e.value.returncode == 1 and "unknown environment" in e.value.stderr
    assert e.value.command[1:3] == ["run", e.value.command[2]]
    with pytest.raises(rwg.RwgFailedError, match=r"^error: cannot read manifest .*missing\.toml"):
        rwg.run(tmp_path / "missing.toml", out=tmp_path / "m")
    assert isinstance(e.value, rwg.RunError)


def test_gymnasium_envs_run_in_this_interpreter(tmp_path, monkeypatch):
    # A python3 on PATH that would fail (and leave a mark) if rwg used it.
    fake = tmp_path / "bin"
    fake.mkdir()
    mark = tmp_path / "fake-python-ran"
    (fake / "python3").write_text(f"#!/bin/sh\ntouch {mark}\nexit 3\n")
    (fake / "python3").chmod(0o755)
    monkeypatch.setenv("PATH", f"{fake}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.delenv("RWG_PYTHON", raising=False)
    monkeypatch.setenv("PYTHONPATH", python_env()["PYTHONPATH"])
    study = {
        "samples": 8,
        "episodes": 2,
        "architectures": [{"name": "0HL", "hidden": []}],
        "envs": [{"id": "gymnasium:rwg_test_envs:Drift-v0"}],
    }
    run = rwg.run(study, out=tmp_path / "gym", threads=1, quiet=True)
    assert run.scores("gymnasium:rwg_test_envs:Drift-v0", "0HL").shape == (8, 2)
    assert not mark.exists()
    # RWG_PYTHON set by the user wins
    monkeypatch.setenv("RWG_PYTHON", str(fake / "python3"))
    with pytest.raises(rwg.RwgFailedError, match="error:"):
        rwg.run(study, out=tmp_path / "gym2", threads=1, quiet=True)
    assert mark.exists()


def test_on_a_terminal_rwg_draws_on_it_and_its_message_is_still_read(tmp_path):
    import pty

    script = textwrap.dedent(
        f"""
        import json, rwg
        study = {{"samples": 64, "episodes": 3, "architectures": [{{"name": "0HL", "hidden": []}}],
                 "envs": [{{"id": "CartPole-v1"}}]}}
        run = rwg.run(study, out={str(tmp_path / "ok")!r})
        print("ran", run.scores("CartPole-v1", "0HL").shape)
        study["envs"] = [{{"id": "Nope-v0"}}]
        try:
            rwg.run(study, out={str(tmp_path / "bad")!r})
        except rwg.RwgFailedError as e:
            print("message", json.dumps(str(e).splitlines()[0]))
        """
    )
    master, slave = pty.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-c", script],
        env=python_env(),
        stdout=subprocess.PIPE,
        stderr=slave,
        text=True,
    )
    os.close(slave)
    terminal = b""
    while True:
        try:
            chunk = os.read(master, 1 << 16)
        except OSError:
            break
        if not chunk:
            break
        terminal += chunk
    os.close(master)
    stdout, _ = proc.communicate(timeout=120)
    assert proc.returncode == 0, terminal.decode(errors="replace")
    shown = terminal.decode(errors="replace")
    # rwg saw a terminal (no plain progress lines); its error is the
    # exception's message, not shown on the terminal as well
    assert "a progress line every 5 s" not in shown and "networks" in shown, shown
    assert "unknown environment 'Nope-v0'" not in shown, shown
    assert "ran (64, 3)" in stdout
    # the exception's message is rwg's line, without the terminal's control characters
    line = json.loads(re.search(r"^message (.*)$", stdout, re.M).group(1))
    assert line.startswith("error: ") and "unknown environment 'Nope-v0'" in line, line
    assert "\x1b" not in line and "\r" not in line, line


INTERRUPTED = """\
samples = 192
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


def finished_cells(out):
    try:
        with open(out / "run.json") as f:
            return json.load(f)["cells"]
    except (OSError, ValueError):
        return []


def test_ctrl_c_stops_rwg_keeps_its_work_and_a_rerun_resumes(tmp_path):
    (tmp_path / "study.toml").write_text(INTERRUPTED)
    out = tmp_path / "run"
    script = textwrap.dedent(
        f"""
        import rwg
        rwg.run({str(tmp_path / 'study.toml')!r}, out={str(out)!r}, threads=2)
        print("rwg.run returned")
        """
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", script],
        env=python_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 300
    while not finished_cells(out):
        assert proc.poll() is None, f"rwg.run ended early: {proc.communicate()}"
        assert time.monotonic() < deadline, "no finished cell after 300 s"
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    # Python ended as on an uncaught KeyboardInterrupt, after rwg stopped
    assert proc.returncode == -signal.SIGINT, (proc.returncode, stderr)
    assert "KeyboardInterrupt" in stderr and "rwg.run returned" not in stdout
    # rwg got one SIGINT: it finished the blocks in flight (a second one quits at once)
    assert stderr.count("interrupted: finishing the blocks in flight") == 1, stderr
    assert "resume with: rwg run" in stderr or "Resume with:" in stderr, stderr
    pid = int(re.search(r"\d+", (out / "rwg.lock").read_text()).group(0))
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    with pytest.raises(rwg.RunInProgressError) as e:
        rwg.load(out)
    kept = finished_cells(out)
    assert 1 <= e.value.cells_done == len(kept) < 4 and e.value.cells_total == 4
    before = {c["dir"]: (out / "cells" / c["dir"] / "cell.json").read_bytes() for c in kept}
    # the rerun resumes: the cells finished before are kept as they were
    run = rwg.run(tmp_path / "study.toml", out=out, threads=2, quiet=True)
    assert len(run.cells) == 4 and run.meta["end_time"] is not None
    for d, cell_json in before.items():
        assert (out / "cells" / d / "cell.json").read_bytes() == cell_json, d
    assert run.scores("Acrobot-v1", "1HL-4").shape == (192, 6)
    assert tomllib.loads((out / "manifest.toml").read_text())["samples"] == 192

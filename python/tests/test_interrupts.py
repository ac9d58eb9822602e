"""rwg.run stopped and streamed wherever it runs: the command printed after
Ctrl-C works as printed for a dict manifest; a SIGINT raised by another
thread stops rwg at once, and one that comes too late never loses the
finished result; no stderr at all (pythonw, services) never blocks rwg."""

import os
import re
import signal
import subprocess
import sys
import textwrap
import time

import pytest

import rwg
from conftest import python_env

#: Enough work that a signal lands mid-run (blocks of 32 networks).
STUDY = {
    "seed": 5,
    "samples": 64,
    "episodes": 3,
    "architectures": [{"name": "0HL", "hidden": []}, {"name": "1HL-4", "hidden": [4]}],
    "envs": [{"id": "CartPole-v1"}, {"id": "Acrobot-v1", "max_episode_steps": 100}],
}


def python(script, **env):
    """Starts ``script`` in a new Python with the package importable."""
    return subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(script)],
        env=python_env(**env),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def finish(proc, out, timeout, why):
    """``proc``'s stdout and stderr within ``timeout`` s; else kills it and
    the rwg it started (a session of its own: it outlives Python) and fails
    with ``why``."""
    try:
        return proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, stderr = proc.communicate()
        try:
            pid = int(re.search(r"\d+", (out / "rwg.lock").read_text()).group(0))
            os.kill(pid, signal.SIGKILL)
        except (OSError, AttributeError):
            pass
        pytest.fail(f"{why}: {stderr}")


def shell_with_rwg(line, cwd):
    """Runs ``line`` in ``sh`` as a user pastes it, the rwg binary first on PATH."""
    bin_dir = os.path.dirname(os.path.abspath(rwg.find_rwg_bin()))
    env = dict(os.environ, PATH=bin_dir + os.pathsep + os.environ.get("PATH", ""))
    if os.path.basename(rwg.find_rwg_bin()) != "rwg":
        pytest.skip("the rwg binary is not named rwg: the printed command cannot name it")
    return subprocess.run(["sh", "-c", line], cwd=cwd, env=env, capture_output=True, text=True)


def test_after_ctrl_c_the_printed_command_finishes_a_dict_run(tmp_path):
    out = tmp_path / "run it's"
    proc = python(
        f"""
        import rwg
        rwg.run({STUDY!r}, out={str(out)!r}, samples=1000, seed=11, threads=2)
        """,
        RWG_COMMIT_LINGER=0,
    )
    first = out / "cells" / "CartPole-v1__0HL__nobias" / "blocks" / "b0000000.csv"
    deadline = time.monotonic() + 120
    while not first.exists():
        assert proc.poll() is None, f"rwg.run ended early: {proc.communicate()}"
        assert time.monotonic() < deadline, "no block after 120 s"
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == -signal.SIGINT, stderr
    line = re.search(r"Resume with:\n  (.*)", stderr).group(1)
    res = shell_with_rwg(line, tmp_path)
    assert res.returncode == 0, (line, res.stderr)
    ref = rwg.run(STUDY, out=tmp_path / "reference", samples=1000, seed=11, quiet=True)
    for c in ref.cells:
        for f in ["scores.csv", "samples.csv"]:
            a = (out / "cells" / c["dir"] / f).read_bytes()
            assert a == (tmp_path / "reference" / "cells" / c["dir"] / f).read_bytes(), (c["dir"], f)
    for f in ["stats.csv", "manifest.toml"]:
        assert (out / f).read_bytes() == (tmp_path / "reference" / f).read_bytes(), f


def test_sigint_from_another_thread_stops_rwg_at_once(tmp_path):
    out = tmp_path / "run"
    proc = python(
        f"""
        import signal, threading, time, rwg
        threading.Timer(1.0, signal.raise_signal, (signal.SIGINT,)).start()
        t0 = time.monotonic()
        try:
            rwg.run({STUDY!r}, out={str(out)!r}, samples=400000, threads=1, quiet=True)
            print("returned")
        except KeyboardInterrupt:
            print("interrupted after", round(time.monotonic() - t0, 1))
        """
    )
    stdout, stderr = finish(proc, out, 60, "rwg.run still running 60 s after the SIGINT")
    seconds = float(re.search(r"interrupted after ([\d.]+)", stdout).group(1))
    assert seconds < 15, (stdout, stderr)
    assert stderr.count("interrupted: finishing the blocks in flight") == 1, stderr
    with pytest.raises(rwg.RunInProgressError):
        rwg.load(out)


def test_a_sigint_that_comes_after_the_study_finished_loses_nothing(tmp_path):
    # rwg behind a shell that defers the SIGINT it gets until rwg finished:
    # the interrupt comes in time, the study finishes anyway.
    wrapper = tmp_path / "rwg-late"
    wrapper.write_text(
        "#!/bin/sh\ntrap 'echo wrapper got SIGINT >&2' INT\n"
        f"'{rwg.find_rwg_bin()}' \"$@\"\nstatus=$?\nexit $status\n"
    )
    wrapper.chmod(0o755)
    out = tmp_path / "run"
    proc = python(
        f"""
        import signal, threading, rwg
        threading.Timer(0.5, signal.raise_signal, (signal.SIGINT,)).start()
        run = rwg.run({STUDY!r}, out={str(out)!r}, samples=1000, threads=1, quiet=True)
        print("returned", len(run.cells), run.meta["samples"])
        """,
        RWG_BIN=wrapper,
    )
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    assert "wrapper got SIGINT" in stderr, stderr
    assert "returned 4 1000" in stdout, (stdout, stderr)
    assert "interrupted after rwg finished the study; its result is kept" in stderr, stderr


def test_without_stderr_or_stdout_rwg_never_blocks(tmp_path):
    # A line per block: far more than a pipe holds (64 KiB).
    out = tmp_path / "run"
    study = dict(STUDY, envs=[{"id": "CartPole-v1"}], architectures=[{"name": "0HL", "hidden": []}])
    proc = python(
        f"""
        import sys, rwg
        sys.stderr = None
        sys.stdout, real = None, sys.stdout
        run = rwg.run({study!r}, out={str(out)!r}, samples=25600, episodes=1, threads=2)
        real.write(f"returned {{run.meta['samples']}}\\n")
        """,
        RWG_PROGRESS_INTERVAL=0,
    )
    stdout, stderr = finish(proc, out, 120, "rwg.run blocked with sys.stderr = None")
    assert proc.returncode == 0 and "returned 25600" in stdout, (stdout, stderr)


def test_another_exception_while_rwg_runs_stops_it_before_it_is_raised(tmp_path):
    # A job runner's SIGTERM handler raising SystemExit: rwg (a session of
    # its own) must not go on running behind the exiting Python.
    out = tmp_path / "run"
    proc = python(
        f"""
        import signal, sys, threading, rwg
        signal.signal(signal.SIGTERM, lambda *a: sys.exit(3))
        threading.Timer(1.0, signal.raise_signal, (signal.SIGTERM,)).start()
        rwg.run({STUDY!r}, out={str(out)!r}, samples=400000, threads=1, quiet=True)
        """
    )
    _, stderr = finish(proc, out, 60, "rwg.run still running 60 s after SystemExit")
    assert proc.returncode == 3, stderr
    assert "interrupted: finishing the blocks in flight" in stderr, stderr
    pid = int(re.search(r"\d+", (out / "rwg.lock").read_text()).group(0))
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    with pytest.raises(rwg.RunInProgressError):
        rwg.load(out)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the parent-death signal is Linux's")
def test_rwg_ends_with_a_python_that_is_killed(tmp_path):
    # SIGKILL (a notebook kernel restarted, an out-of-memory kill) gives
    # Python no chance to stop rwg: rwg, in a session of its own, must not
    # run on orphaned, holding the run's lock
    out = tmp_path / "run"
    proc = python(
        f"""
        import rwg
        rwg.run({STUDY!r}, out={str(out)!r}, samples=400000, threads=1, quiet=True)
        """
    )
    lock = out / "rwg.lock"
    deadline = time.monotonic() + 60
    while not (lock.exists() and re.search(r"\d+", lock.read_text())):
        assert proc.poll() is None, f"rwg.run ended early: {proc.communicate()}"
        assert time.monotonic() < deadline, "no rwg.lock after 60 s"
        time.sleep(0.05)
    pid = int(re.search(r"\d+", lock.read_text()).group(0))
    proc.kill()
    proc.communicate()
    deadline = time.monotonic() + 30
    while "zombie" not in _state(pid) and _state(pid):
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            pytest.fail("rwg still running 30 s after the Python that started it was killed")
        time.sleep(0.05)
    assert (out / "manifest.toml").exists()


def _state(pid):
    """The state line of /proc/PID/status ("" once it is gone)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            return next((l for l in f if l.startswith("State:")), "").lower()
    except OSError:
        return ""

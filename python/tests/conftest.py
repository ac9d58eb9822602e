"""Shared fixtures of the rwg package's tests.

They run the real ``rwg`` binary: ``RWG_BIN`` names it (tests/python_api.rs
sets it to the test build's), else the one ``rwg.find_rwg_bin`` finds.
"""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

import rwg

REPO = Path(__file__).resolve().parents[2]
#: The test Gymnasium envs (gymnasium:rwg_test_envs:...).
TEST_ENVS = REPO / "tests" / "python"

SMALL = """\
seed = 7
samples = 40
episodes = 3
bias = [false, true]

[[architectures]]
name = "0HL"
hidden = []

[[architectures]]
name = "1HL-4"
hidden = [4]

[[envs]]
id = "CartPole-v0"
solved = 195

[[envs]]
id = "Pendulum-v0"
solved = -140
"""


def rwg_cli(*args, env=None, check=True):
    """Runs the rwg binary with ``args``; returns the CompletedProcess."""
    res = subprocess.run(
        [rwg.find_rwg_bin(), *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    if check and res.returncode != 0:
        raise AssertionError(f"rwg {args} failed ({res.returncode}):\n{res.stderr}")
    return res


@pytest.fixture(scope="session")
def small_run(tmp_path_factory):
    """A finished run of SMALL (8 cells, 40 networks x 3 episodes), made by the CLI."""
    d = tmp_path_factory.mktemp("small")
    (d / "small.toml").write_text(SMALL)
    rwg_cli("run", d / "small.toml", "--out", d / "run", "--threads", "2", "-q")
    return d / "run"


@pytest.fixture
def run_copy(small_run, tmp_path):
    """A copy of small_run that a test may damage."""
    dst = tmp_path / "run"
    shutil.copytree(small_run, dst)
    return dst


def python_env(**extra):
    """This process's environment with the rwg package and the test envs on
    PYTHONPATH, plus ``extra``."""
    env = dict(os.environ)
    paths = [str(Path(rwg.__file__).resolve().parents[1]), str(TEST_ENVS)]
    if env.get("PYTHONPATH"):
        paths.append(env["PYTHONPATH"])
    env["PYTHONPATH"] = os.pathsep.join(paths)
    env.update({k: str(v) for k, v in extra.items()})
    return env


__all__ = ["REPO", "TEST_ENVS", "SMALL", "rwg_cli", "python_env"]

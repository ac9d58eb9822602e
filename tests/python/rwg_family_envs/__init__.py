"""Test environments for rwg's Gymnasium worker processes as one family
(tests/cli_gym_workers.rs): envs whose behaviour depends on the process they
run in, and envs that hang where rwg's signals and timeouts must reach them.

Importing this module registers them with Gymnasium, so rwg reaches them as
`gymnasium:rwg_family_envs:NAME` (put tests/python on PYTHONPATH).

- `HashReset-v0`: Drift-like, but reset's observation depends on Python's
  `hash(str)`, which differs from process to process unless PYTHONHASHSEED
  is set.
- `Split-v0`: the first process that creates the file `marker` (a kwarg)
  gets one set of spaces, every later process another; `what` says which
  space differs: `bounds` (Box actions within ±1 vs ±100), `obs` (2 vs 3
  observation values), `discrete` (Discrete(2) vs Discrete(5)).
- `SplitLimit-v0`: registered when the module is imported, with a time limit
  of 60 steps in the first process that creates the file named by the
  environment variable RWG_TEST_SPLIT_MARKER, 70 in every later one.
- `Knob-v0`: its action bound is the environment variable RWG_TEST_KNOB
  (`a`: ±1, `b`: ±100, `c`: ±1), and with `a` its episode of reset seed
  `fail_seed` (a kwarg, a string: reset seeds exceed TOML's integers)
  raises at step 2, so that a run stops after its first blocks.
- `PidReset-v0`: reset's observation depends on the process id (a process-
  dependent reset that no hash seed fixes).
- `Mixed-v0`: the second instance made in a process has action bounds ±100,
  every other ±1.
- `Orphans-v0`: its first instance in a process starts `sleep 600` (which
  inherits the worker's stderr) and writes that process's id into a file in
  the folder `marker`; with `exit_seed` (a string) the worker exits with
  status 3 at step 3 of that seed's episode.
- `Stall-v0`: writes its process id into a file in the folder `marker` and
  sleeps for an hour: `where = "step"` at step 3 of the episode of reset
  seed `at_seed`, `where = "probe"` at its first step (in the probe rwg
  runs when a worker starts), `where = "make"` in its constructor.
"""

import os
import subprocess
import time

import gymnasium as gym
import numpy as np
from gymnasium import spaces

_FIRST = {}


def _first_process(marker):
    """Whether this process created `marker` (decided once per process)."""
    if marker not in _FIRST:
        try:
            fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            os.close(fd)
            _FIRST[marker] = True
        except FileExistsError:
            _FIRST[marker] = False
    return _FIRST[marker]


class Line(gym.Env):
    """A point on a line pushed by the action; `obs_dim` observation values."""

    def __init__(self, obs_dim=2, action_space=None):
        self.obs_dim = obs_dim
        self.observation_space = spaces.Box(-10.0, 10.0, (obs_dim,), np.float64)
        self.action_space = action_space or spaces.Box(-1.0, 1.0, (1,), np.float64)
        self.x = np.zeros(obs_dim)
        self.t = 0

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.x = self.np_random.uniform(-1.0, 1.0, self.obs_dim)
        self.t = 0
        return self.x.copy(), {}

    def push(self, action):
        if isinstance(self.action_space, spaces.Discrete):
            return 0.1 * (int(action) - 1)
        return 0.01 * float(np.asarray(action).reshape(-1)[0])

    def step(self, action):
        self.t += 1
        self.x = np.clip(self.x + self.push(action), -10.0, 10.0)
        reward = float(1.0 - abs(self.x[0] - 0.5))
        return self.x.copy(), reward, bool(abs(self.x[0]) > 2.0), False, {}


class HashReset(Line):
    def reset(self, *, seed=None, options=None):
        obs, info = super().reset(seed=seed, options=options)
        self.x[0] += (hash("rwg-family") % 1000) / 1000.0
        return self.x.copy(), info


class Split(Line):
    def __init__(self, marker="", what="bounds"):
        first = _first_process(marker)
        obs_dim, action = 2, None
        if what == "bounds":
            high = 1.0 if first else 100.0
            action = spaces.Box(-high, high, (1,), np.float64)
        elif what == "obs":
            obs_dim = 2 if first else 3
        elif what == "discrete":
            action = spaces.Discrete(2 if first else 5)
        super().__init__(obs_dim, action)


class PidReset(Line):
    def reset(self, *, seed=None, options=None):
        obs, info = super().reset(seed=seed, options=options)
        self.x[0] += (os.getpid() % 1000) / 1000.0
        return self.x.copy(), info


_MADE = [0]


class Mixed(Line):
    def __init__(self):
        _MADE[0] += 1
        high = 100.0 if _MADE[0] == 2 else 1.0
        super().__init__(2, spaces.Box(-high, high, (1,), np.float64))


class Orphans(Line):
    started = False

    def __init__(self, marker="", exit_seed="0"):
        super().__init__()
        self.exit_seed = int(exit_seed)
        self.armed = False
        if not Orphans.started:
            Orphans.started = True
            child = subprocess.Popen(["sleep", "600"])
            with open(os.path.join(marker, str(child.pid)), "w") as f:
                f.write("started\n")

    def reset(self, *, seed=None, options=None):
        self.armed = seed == self.exit_seed
        return super().reset(seed=seed, options=options)

    def step(self, action):
        out = super().step(action)
        if self.armed and self.t == 3:
            os._exit(3)
        return out


class Knob(Line):
    def __init__(self, fail_seed="0"):
        knob = os.environ.get("RWG_TEST_KNOB", "a")
        high = 100.0 if knob == "b" else 1.0
        super().__init__(2, spaces.Box(-high, high, (1,), np.float64))
        self.fails = knob == "a"
        self.fail_seed = int(fail_seed)
        self.armed = False

    def reset(self, *, seed=None, options=None):
        self.armed = self.fails and seed == self.fail_seed
        return super().reset(seed=seed, options=options)

    def step(self, action):
        out = super().step(action)
        if self.armed and self.t == 2:
            raise RuntimeError("deliberate failure of Knob-v0")
        return out


class Stall(Line):
    def __init__(self, marker="", where="step", at_seed="0"):
        self.marker, self.where, self.at_seed = marker, where, int(at_seed)
        if where == "make":
            self.stall()
        super().__init__()
        self.armed = False

    def stall(self):
        with open(os.path.join(self.marker, str(os.getpid())), "w") as f:
            f.write("stalled\n")
        time.sleep(3600)

    def reset(self, *, seed=None, options=None):
        self.armed = seed == self.at_seed
        return super().reset(seed=seed, options=options)

    def step(self, action):
        out = super().step(action)
        if self.where == "probe" or (self.where == "step" and self.armed and self.t == 3):
            self.stall()
        return out


gym.register("HashReset-v0", entry_point=HashReset, max_episode_steps=60)
gym.register("Split-v0", entry_point=Split, max_episode_steps=60)
if os.environ.get("RWG_TEST_SPLIT_MARKER"):
    _limit = 60 if _first_process(os.environ["RWG_TEST_SPLIT_MARKER"]) else 70
    gym.register("SplitLimit-v0", entry_point=Line, max_episode_steps=_limit)
gym.register("PidReset-v0", entry_point=PidReset, max_episode_steps=60)
gym.register("Mixed-v0", entry_point=Mixed, max_episode_steps=60)
gym.register("Orphans-v0", entry_point=Orphans, max_episode_steps=60)
gym.register("Knob-v0", entry_point=Knob, max_episode_steps=60)
gym.register("Stall-v0", entry_point=Stall, max_episode_steps=60)

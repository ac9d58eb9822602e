"""Test environments for what rwg's Gymnasium bridge must not take on trust
(tests/cli_gym_trust.rs): values an env returns, and processes it starts.

Importing this module registers them with Gymnasium, so rwg reaches them as
`gymnasium:rwg_trust_envs:NAME` (put tests/python on PYTHONPATH).

- `Trust-v0`: a point on a line (a Box(3) observation, 2 discrete actions,
  episodes of 5 steps) that misbehaves as `mode` says from step `at_step` of
  every episode (`at_step = 0`: in reset), or only in the episode of reset
  seed `at_seed` (a string: reset seeds exceed TOML's integers) when given:
  `term_str` / `trunc_str` (the flag as the string "False"), `term_none`
  (terminated None), `term_int` (terminated 0), `reward_pair` (a reward of two
  values), `reset3` (reset returns three values), `obs_f16` / `obs_i8` /
  `obs_bool` (observations of those dtypes: accepted), `sysexit` (SystemExit
  in step), `baseexc` (a BaseException subclass in step), `kbint`
  (KeyboardInterrupt in step), `cwrite` (writes bytes to fd 1 with C's write:
  accepted, they go to stderr), `close_stdin` (closes fd 0 and sys.stdin:
  accepted), `fork_exit` (forks a helper that sleeps, then the worker exits
  with status 4), `space_change` (the instance replaces its observation
  space with a Box(4) on reset), `big_obs` (`dim` observation values),
  `scalar_obs` (a Box of shape ()), `obs_tuple` (a Box observation as a
  Python tuple), `obs_object` (an array of dtype object), `info_none` (reset's
  info is None), `flood` (a MiB to stderr every step), `close_raises` (its
  episodes depend on its history, so rwg makes each afresh, and close()
  raises once it ran one), `slow_make` (every process but the first to create the file `marker`
  sleeps for an hour in its first gym.make).
- `Disc-v0`: a Discrete(4) observation (or, with `nested = true`, a Dict of a
  Box and that Discrete); from step `at_step` it observes `value` (-1 or 4).
- `Fresh-v0`: its episodes depend on the instance's earlier ones (so rwg
  makes every episode a fresh instance); the instances made after the
  first `after` in a process have a Box(4) observation space, not Box(3).
- `Helpers-v0`: its first instance in a process starts three `sleep 600`:
  one in the worker's process group, one in a session of its own (setsid),
  one double-forked daemon in a session of its own (re-parented away from
  the worker at once); their process ids go into files in the folder
  `marker`. At step 3 of the episode of `at_seed` it sleeps for an hour.
"""

import ctypes
import os
import subprocess
import sys
import time

import gymnasium as gym
import numpy as np
from gymnasium import spaces


_FIRST = {}


def _first_process(marker):
    """Whether this process created `marker` (decided once per process)."""
    if marker not in _FIRST:
        try:
            os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            _FIRST[marker] = True
        except FileExistsError:
            _FIRST[marker] = False
    return _FIRST[marker]


class Boom(BaseException):
    """Not an Exception: what an env should never raise."""


class Trust(gym.Env):
    def __init__(self, mode="", at_step=1, at_seed="", dim=3, marker=""):
        if mode == "slow_make" and not _first_process(marker):
            time.sleep(3600)
        self.mode, self.at_step = mode, int(at_step)
        self.at_seed = int(at_seed) if at_seed else None
        dtype = {"obs_f16": np.float16, "obs_i8": np.int8, "obs_bool": np.bool_}.get(
            mode, np.float64)
        lo, hi = (0, 1) if mode == "obs_bool" else (-5, 5)
        shape = () if mode == "scalar_obs" else (int(dim),)
        self.observation_space = spaces.Box(lo, hi, shape, dtype)
        self.action_space = spaces.Discrete(2)
        self.t = 0
        self.armed = False
        self.x = np.zeros(int(dim))
        self.episodes = 0

    def _obs(self):
        if self.mode == "scalar_obs":
            return np.array(self.x[0], self.observation_space.dtype)
        if self.mode == "obs_tuple":
            return tuple(float(v) for v in self.x)
        if self.mode == "obs_object":
            return self.x.astype(object)
        return self.x.astype(self.observation_space.dtype)

    def close(self):
        if self.mode == "close_raises" and self.episodes:
            raise RuntimeError("close() failed")

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        self.episodes += 1
        self.armed = self.at_seed is None or seed == self.at_seed
        self.x = self.np_random.uniform(-1, 1, self.x.shape)
        if self.armed and self.at_step == 0:
            if self.mode == "reset3":
                return self._obs(), {}, 0
            if self.mode == "space_change":
                self.observation_space = spaces.Box(-5, 5, (4,), np.float64)
            if self.mode == "close_stdin" and not sys.stdin.closed:
                os.close(0)
                sys.stdin.close()
        if self.mode == "info_none":
            return self._obs(), None
        return self._obs(), {}

    def step(self, action):
        self.t += 1
        if self.mode == "flood":
            sys.stderr.write("x" * (1 << 20) + "\n")
        if self.mode == "close_raises":
            self.x[1] += 0.001 * self.episodes  # episodes depend on the instance's history
        self.x = np.clip(self.x + 0.1 * (int(action) - 0.5), -5, 5)
        reward, term, trunc = float(self.x[0]), self.t >= 5, False
        if self.armed and self.t >= self.at_step:
            m = self.mode
            if m == "term_str":
                term = "False"
            elif m == "trunc_str":
                trunc = "False"
            elif m == "term_none":
                term = None
            elif m == "term_int":
                term = 0
            elif m == "reward_pair":
                reward = np.array([1.0, 2.0])
            elif m == "sysexit":
                sys.exit(5)
            elif m == "baseexc":
                raise Boom("not an Exception")
            elif m == "kbint":
                raise KeyboardInterrupt
            elif m == "cwrite":
                ctypes.CDLL(None).write(1, b"C wrote this to fd 1\n", 21)
            elif m == "fork_exit" and self.t == self.at_step:
                if os.fork() == 0:
                    time.sleep(600)  # a helper that keeps every pipe of the worker open
                    os._exit(0)
                os._exit(4)
        return self._obs(), reward, term, trunc, {}


class Disc(gym.Env):
    def __init__(self, value=-1, at_step=1, nested=False):
        self.value, self.at_step, self.nested = int(value), int(at_step), bool(nested)
        inner = spaces.Discrete(4)
        self.observation_space = (
            spaces.Dict({"pos": spaces.Box(-5, 5, (2,), np.float64), "cell": inner})
            if nested else inner)
        self.action_space = spaces.Discrete(2)
        self.t = 0

    def _obs(self):
        cell = self.value if self.t >= self.at_step else self.t % 4
        if self.nested:
            return {"pos": np.zeros(2), "cell": cell}
        return cell

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return self._obs(), {}

    def step(self, action):
        self.t += 1
        return self._obs(), 1.0, self.t >= 5, False, {}


class Fresh(Trust):
    made = 0

    def __init__(self, after=40):
        Fresh.made += 1
        super().__init__(dim=4 if Fresh.made > int(after) else 3)
        self.episodes = 0

    def reset(self, *, seed=None, options=None):
        self.episodes += 1
        return super().reset(seed=seed, options=options)

    def step(self, action):
        obs, r, term, trunc, info = super().step(action)
        return obs, r + 0.001 * self.episodes, term, trunc, info


class Helpers(Trust):
    started = False

    def __init__(self, marker="", at_seed="0"):
        super().__init__()
        self.hang_seed = int(at_seed)
        if not Helpers.started:
            Helpers.started = True
            pids = [subprocess.Popen(["sleep", "600"]).pid,
                    subprocess.Popen(["sleep", "600"], start_new_session=True).pid]
            # a daemon: fork, setsid, fork again; the grandchild reports its pid
            r, w = os.pipe()
            if os.fork() == 0:
                os.setsid()
                if os.fork() == 0:
                    os.write(w, str(os.getpid()).encode())
                    os.execvp("sleep", ["sleep", "600"])
                os._exit(0)
            os.close(w)
            pids.append(int(os.read(r, 32)))
            os.close(r)
            for p in pids:
                with open(os.path.join(marker, str(p)), "w") as f:
                    f.write("started\n")

    def reset(self, *, seed=None, options=None):
        self.hang = seed == self.hang_seed
        return super().reset(seed=seed, options=options)

    def step(self, action):
        out = super().step(action)
        if self.hang and self.t == 3:
            time.sleep(3600)
        return out


gym.register("Trust-v0", entry_point=Trust, max_episode_steps=60)
gym.register("Disc-v0", entry_point=Disc, max_episode_steps=60)
gym.register("Fresh-v0", entry_point=Fresh, max_episode_steps=60)
gym.register("Helpers-v0", entry_point=Helpers, max_episode_steps=60)

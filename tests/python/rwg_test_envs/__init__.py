"""Test environments for rwg's Gymnasium bridge (tests/cli_gym_bridge.rs).

Importing this module registers them with Gymnasium, so rwg reaches them as
`gymnasium:rwg_test_envs:NAME` (the module is imported first; put this folder
on PYTHONPATH).

- `Drift-v0`: a custom env with a Dict observation (a Box and a Discrete,
  flattened by rwg through gymnasium.spaces.flatten) and 3 discrete actions.
- `Faulty-v0`: behaves like Drift-v0 until the episode whose reset seed is
  `at_seed` (a string: reset seeds exceed TOML's integers) reaches step
  `at_step`; there it does what `mode` says: `raise` (RuntimeError in step),
  `nan` (a NaN observation), `shape` (an observation of another shape),
  `complex` (a complex observation),
  `segfault` (reads address 0 through ctypes), `hang` (sleeps for an hour),
  `reset_raise` (raises in that episode's reset).
- `Memory-v0`: Drift-v0 whose rewards depend on how many episodes the
  instance ran before (state kept across reset, as BipedalWalker-v3 keeps
  some): rwg must notice and give every episode a fresh instance.
- `Unseeded-v0`: ignores the seed (its reset draws from global state), so two
  `reset(seed=s)` differ: rwg must refuse it before running.
"""

import ctypes
import time

import gymnasium as gym
import numpy as np
from gymnasium import spaces


class Drift(gym.Env):
    def __init__(self):
        self.observation_space = spaces.Dict(
            {"pos": spaces.Box(-10.0, 10.0, (2,), np.float32), "phase": spaces.Discrete(3)}
        )
        self.action_space = spaces.Discrete(3)
        self.pos = np.zeros(2, np.float32)
        self.t = 0

    def _obs(self):
        return {"pos": self.pos.copy(), "phase": self.t % 3}

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.pos = self.np_random.uniform(-1.0, 1.0, 2).astype(np.float32)
        self.t = 0
        return self._obs(), {}

    def step(self, action):
        self.t += 1
        self.pos = np.clip(self.pos + np.float32(0.1) * (int(action) - 1), -10, 10).astype(np.float32)
        reward = float(1.0 - abs(float(self.pos[0]) - 0.5) + 0.1 * (self.t % 3))
        terminated = bool(abs(self.pos[0]) > 2.0)
        return self._obs(), reward, terminated, False, {}


class Faulty(Drift):
    def __init__(self, mode="raise", at_seed="0", at_step=3):
        super().__init__()
        self.mode, self.at_seed, self.at_step = mode, int(at_seed), int(at_step)
        self.armed = False

    def reset(self, *, seed=None, options=None):
        self.armed = seed == self.at_seed
        if self.armed and self.mode == "reset_raise":
            raise ValueError(f"reset_raise at seed {seed}")
        return super().reset(seed=seed, options=options)

    def step(self, action):
        obs, r, term, trunc, info = super().step(action)
        if self.armed and self.t == self.at_step:
            if self.mode == "raise":
                raise RuntimeError(f"deliberate failure at step {self.t}")
            if self.mode == "nan":
                obs["pos"][1] = np.nan
            if self.mode == "shape":
                obs = {"pos": np.zeros(5, np.float32), "phase": 0}
            if self.mode == "complex":
                obs["pos"] = obs["pos"] + 1j
            if self.mode == "segfault":
                ctypes.string_at(0)
            if self.mode == "hang":
                time.sleep(3600)
        return obs, r, term, trunc, info


class Unseeded(Drift):
    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.pos = np.random.uniform(-1.0, 1.0, 2).astype(np.float32)
        return self._obs(), {}


class Memory(Drift):
    def __init__(self):
        super().__init__()
        self.episodes = 0

    def reset(self, *, seed=None, options=None):
        self.episodes += 1
        return super().reset(seed=seed)

    def step(self, action):
        obs, r, term, trunc, info = super().step(action)
        return obs, r + 0.001 * self.episodes, term, trunc, info


gym.register("Memory-v0", entry_point=Memory, max_episode_steps=60)
gym.register("Drift-v0", entry_point=Drift, max_episode_steps=60, reward_threshold=50.0)
gym.register("Faulty-v0", entry_point=Faulty, max_episode_steps=60)
gym.register("Unseeded-v0", entry_point=Unseeded, max_episode_steps=60)


class Odd(gym.Env):
    """Values that must be refused where they enter rwg, one per `mode`:
    `huge_reward` (finite rewards of 1e308, whose episode sum overflows),
    `complex_obs` (complex observations in a float Box), `box0` (a Box(0)
    observation space), `old_reset` (reset returns the bare observation, the
    pre-0.26 Gym API), `old_step` (step returns the old 4-tuple), `str_obs`
    (observations as an array of strings), `str_reward` (rewards as strings),
    `box0_action` (a Box(0) action space), `obs_list` (observations as a plain
    list of the right length: accepted), `int_obs` (an integer Box: accepted),
    `nan_reset` (a NaN in every reset's observation), `inf_reward` (a reward of
    inf on the 3rd step), `term_array` (terminated as an array of two booleans).
    """

    def __init__(self, mode="huge_reward"):
        self.mode = mode
        shape = (0,) if mode == "box0" else (3,)
        dtype = np.int64 if mode == "int_obs" else np.float64
        self.observation_space = spaces.Box(-5, 5, shape, dtype)
        self.action_space = (
            spaces.Box(-1.0, 1.0, (0,)) if mode == "box0_action" else spaces.Discrete(2)
        )
        self.t = 0
        self.x = np.zeros(shape, dtype)

    def _obs(self):
        if self.mode == "complex_obs":
            return self.x.astype(np.complex128) + 1j
        if self.mode == "str_obs":
            return self.x.astype(str)
        if self.mode == "obs_list":
            return [float(v) for v in self.x]
        return self.x.copy()

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.x = self.np_random.integers(-2, 3, self.observation_space.shape).astype(
            self.observation_space.dtype
        )
        self.t = 0
        if self.mode == "nan_reset":
            self.x[0] = np.nan
        if self.mode == "old_reset":
            return self._obs()
        return self._obs(), {}

    def step(self, action):
        self.t += 1
        reward = 1e308 if self.mode == "huge_reward" else 1.0
        if self.mode == "str_reward":
            reward = "1.5"
        if self.mode == "inf_reward" and self.t == 3:
            reward = float("inf")
        done = self.t >= 5
        if self.mode == "term_array":
            done = np.array([False, done])
        if self.mode == "old_step":
            return self._obs(), reward, done, {}
        return self._obs(), reward, done, False, {}


class Kwargs(Drift):
    """Drift-v0 that writes `repr(kwargs)` (sorted by key) to the file `out`,
    so a test sees the values gym.make received."""

    def __init__(self, out, **kwargs):
        super().__init__()
        with open(out, "w") as f:
            f.write(repr(dict(sorted(kwargs.items()))))


gym.register("Odd-v0", entry_point=Odd, max_episode_steps=60)
gym.register("Kwargs-v0", entry_point=Kwargs, max_episode_steps=60)
gym.register("NanThreshold-v0", entry_point=Drift, max_episode_steps=60,
             reward_threshold=float("nan"))
gym.register("HugeLimit-v0", entry_point=Drift, max_episode_steps=2**40)
gym.register("InfThreshold-v0", entry_point=Drift, max_episode_steps=60,
             reward_threshold=float("inf"))

"""Small JAX envs for rwg-jax's tests (jax:rwg_jax_test_envs:NAME), in gymnax's
functional interface: NAME(**kwargs) -> (env, params)."""

import os

import jax
import jax.numpy as jnp
import numpy as np
from gymnax.environments import spaces


class Params:
    """Env params: the time limit only."""

    def __init__(self, max_steps_in_episode):
        self.max_steps_in_episode = max_steps_in_episode


class Line:
    """A point on a line: obs [x, t], action 0/1 moves it left/right by 0.1,
    reward x; done when |x| > 1. x starts uniform in [-0.5, 0.5]. With
    `nan_at` (a step), the observation (`what="obs"`) or the reward
    (`what="reward"`) is NaN from that step on."""

    def __init__(self, nan_at=None, what="obs"):
        self.nan_at, self.what = nan_at, what

    def reset(self, key, params):
        x = jax.random.uniform(key, (), minval=-0.5, maxval=0.5)
        return jnp.stack([x, 0.0]), (x, jnp.int32(0))

    def step(self, key, state, action, params):
        x, t = state
        x = x + 0.1 * (2 * action - 1).astype(jnp.float32)
        t = t + 1
        obs, reward = jnp.stack([x, t.astype(jnp.float32)]), x
        if self.nan_at is not None:
            bad = t >= self.nan_at
            if self.what == "obs":
                obs = jnp.where(bad, jnp.nan, obs)
            else:
                reward = jnp.where(bad, jnp.nan, reward)
        return obs, (x, t), reward, jnp.abs(x) > 1.0, {}

    def observation_space(self, params):
        return spaces.Box(-2.0, 2.0, (2,))

    def action_space(self, params):
        return spaces.Discrete(2)


def line(max_steps=50, nan_at=None, what="obs"):
    return Line(nan_at, what), Params(max_steps)


def no_limit():
    """A Line whose params have no time limit."""
    return Line(), object()


class DictObs(Line):
    def observation_space(self, params):
        return spaces.Dict({"x": spaces.Box(-2.0, 2.0, (1,)), "t": spaces.Discrete(50)})


def dict_obs():
    return DictObs(), Params(50)


class Dying(Line):
    """A Line whose process exits (status 3) at step 2 of an episode."""

    def step(self, key, state, action, params):
        out = super().step(key, state, action, params)

        def die(t):
            if (np.asarray(t) >= 2).any():
                os._exit(3)

        jax.debug.callback(die, out[1][1])
        return out


def dying():
    return Dying(), Params(50)

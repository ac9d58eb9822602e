"""A JAX env of your own for rwg: `id = "jax:point_mass:make_env"`, with this folder on
PYTHONPATH. A mass on a line, pushed by a force in [-1, 1]; the reward is minus its
squared distance from 0 (and a little of its speed); done when it leaves [-4, 4]."""
from typing import NamedTuple

import jax
import jax.numpy as jnp


class Params(NamedTuple):
    dt: float = 0.05
    max_steps_in_episode: int = 200  # the time limit rwg reads


class Box(NamedTuple):  # a space rwg reads: .low, .high, .shape
    low: jax.Array
    high: jax.Array
    shape: tuple


class PointMass:
    def reset(self, key, params):
        state = jax.random.uniform(key, (2,), minval=-1.0, maxval=1.0)  # position, speed
        return state, state

    def step(self, key, state, action, params):
        x, v = state
        v = v + params.dt * jnp.clip(action[0], -1.0, 1.0)
        x = x + params.dt * v
        state = jnp.stack([x, v])
        reward = -(x * x + 0.1 * v * v)
        return state, state, reward, jnp.abs(x) > 4.0, {}

    def observation_space(self, params):
        return Box(jnp.full(2, -jnp.inf), jnp.full(2, jnp.inf), (2,))

    def action_space(self, params):
        return Box(jnp.full(1, -1.0), jnp.full(1, 1.0), (1,))


def make_env(**kwargs):
    return PointMass(), Params(**kwargs)

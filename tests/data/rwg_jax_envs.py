"""JAX envs of rwg's end-to-end tests (tests/cli_jax.rs), written to the
functional interface of a `jax:module:callable` env: the callable returns
`(env, params)`; `env.reset(key, params) -> (obs, state)`,
`env.step(key, state, action, params) -> (obs, state, reward, done, info)`,
`env.observation_space(params)`, `env.action_space(params)`.

`make_slider`: a point on a line pushed by a force in [-2, 2], rewarded for
staying near 0, done when it leaves [-3, 3]. With `nan_file`, a file holding
one of rwg's reset seeds: the episode reset from that seed observes NaN from
its first step on (read when the env is made, so deleting the file "fixes"
the env without changing the study). With `blowup` g > 0, the physics blow
up: the velocity grows g-fold each step and nothing ends the episode but the
time limit, so the reward 1 - x^2 runs off to minus infinity (a float32
overflow) or beyond what rwg takes (-1e100, in float64).
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp


class Box(NamedTuple):
    """A box space as the interface reads one: `.low`, `.high`, `.shape`."""

    low: jax.Array
    high: jax.Array
    shape: tuple


class Params(NamedTuple):
    """The env's parameters; rwg reads the time limit from them."""

    max_steps_in_episode: int = 60


class State(NamedTuple):
    """Position, velocity, and whether the episode observes NaN."""

    x: jax.Array
    v: jax.Array
    poison: jax.Array


def _key_words(key):
    """A key's data as uint32 words, for a typed or a raw key."""
    if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
        return jax.random.key_data(key)
    return key


class Slider:
    """The slider env (see the module's doc)."""

    def __init__(self, poisoned_reset_key, blowup=0.0):
        self.poisoned = poisoned_reset_key
        self.blowup = blowup

    def _obs(self, s):
        o = jnp.stack([s.x, s.v])
        return jnp.where(s.poison, jnp.nan, o)

    def reset(self, key, params):
        x = jax.random.uniform(key, (), minval=-1.0, maxval=1.0)
        if self.poisoned is None:
            poison = jnp.array(False)
        else:
            poison = jnp.all(_key_words(key) == self.poisoned)
        s = State(x, jnp.zeros_like(x), poison)
        return jnp.stack([s.x, s.v]), s

    def step(self, key, state, action, params):
        force = jnp.clip(jnp.ravel(action)[0], -2.0, 2.0)
        v = state.v + 0.1 * force + 0.01 * jax.random.normal(key, (), state.x.dtype)
        if self.blowup > 0:
            v = self.blowup * v + state.x
        x = state.x + 0.1 * v
        s = State(x, v, state.poison)
        done = jnp.abs(x) > 3.0 if self.blowup <= 0 else jnp.array(False)
        return self._obs(s), s, 1.0 - x * x, done, {}

    def observation_space(self, params):
        inf = jnp.full((2,), jnp.inf)
        return Box(-inf, inf, (2,))

    def action_space(self, params):
        return Box(jnp.array([-2.0]), jnp.array([2.0]), (1,))


def make_slider(nan_file=None, max_steps_in_episode=60, blowup=0.0):
    """The slider env and its params (see the module's doc)."""
    poisoned = None
    if nan_file is not None:
        try:
            with open(nan_file) as f:
                r = int(f.read().strip())
        except FileNotFoundError:
            r = None
        if r is not None:
            # rwg's key of reset seed r, split as rwg splits it: the reset's key
            key = jnp.array([r >> 32, r & 0xFFFFFFFF], dtype=jnp.uint32)
            poisoned = _key_words(jax.random.split(key)[0])
    return Slider(poisoned, blowup), Params(max_steps_in_episode=max_steps_in_episode)


class WrongSize(Slider):
    """A slider whose observation space declares `declared` values (it
    observes 2), or whose reward is `reward_values` values."""

    def __init__(self, declared, reward_values):
        super().__init__(None)
        self.declared, self.reward_values = declared, reward_values

    def step(self, key, state, action, params):
        obs, s, r, done, info = super().step(key, state, action, params)
        return obs, s, jnp.full((self.reward_values,), r) if self.reward_values else r, done, info

    def observation_space(self, params):
        inf = jnp.full((self.declared,), jnp.inf)
        return Box(-inf, inf, (self.declared,))


def make_wrong_size(declared=2, reward_values=0):
    """An env whose spaces or reward do not match what it computes."""
    return WrongSize(declared, reward_values), Params()


class Dying(Slider):
    """A slider whose worker process exits (status 3) at step 2 of an episode."""

    def step(self, key, state, action, params):
        out = super().step(key, state, action, params)

        def die(v):
            import os

            import numpy as np

            if (np.asarray(v) != 0.0).any():
                os._exit(3)

        jax.debug.callback(die, state.v)
        return out


def make_dying():
    """The dying slider and its params."""
    return Dying(None), Params()


class Raising(Slider):
    """A slider whose step raises when traced."""

    def step(self, key, state, action, params):
        raise RuntimeError("a deliberate failure in step")


def make_raising():
    """The raising slider and its params."""
    return Raising(None), Params()


class Choices(NamedTuple):
    """A discrete space as the interface reads one: `.n` (here any value)."""

    n: object


class Actions(Slider):
    """A slider whose action space is `kind`: `multi` (a MultiDiscrete-like
    space, `.n` an array), `none` (Discrete(0)), `half` (n = 2.5) or
    `misfit` (a Box whose bounds do not fit its shape)."""

    def __init__(self, kind):
        super().__init__(None)
        self.kind = kind

    def action_space(self, params):
        if self.kind == "misfit":
            return Box(jnp.array([-1.0, -1.0]), jnp.array([1.0, 1.0]), (3,))
        return Choices({"multi": jnp.array([3, 4]), "none": 0, "half": 2.5}[self.kind])


def make_actions(kind):
    """A slider with the odd action space `kind` (see Actions)."""
    return Actions(kind), Params()


class Countdown(NamedTuple):
    """A slider's state and the steps left."""

    x: jax.Array
    left: jax.Array


class Timer(Slider):
    """A slider whose episode ends when a countdown reaches 0, whatever the
    actions: the countdown starts at 5 (`drawn` false), or at a number from
    3 to 9 its reset draws from the key (`drawn` true)."""

    def __init__(self, drawn):
        super().__init__(None)
        self.drawn = drawn

    def reset(self, key, params):
        k_x, k_left = jax.random.split(key)
        x = jax.random.uniform(k_x, (), minval=-1.0, maxval=1.0)
        left = jax.random.randint(k_left, (), 3, 10) if self.drawn else jnp.int32(5)
        return jnp.stack([x, x]), Countdown(x, left)

    def step(self, key, state, action, params):
        x = state.x + 0.1 * jnp.clip(jnp.ravel(action)[0], -2.0, 2.0)
        s = Countdown(x, state.left - 1)
        return jnp.stack([x, x]), s, 1.0 - x * x, s.left <= 0, {}


def make_timer(drawn=False):
    """The countdown slider (see Timer), with a time limit of 60."""
    return Timer(bool(drawn)), Params()


def _running(pid):
    """Whether process `pid` runs (a zombie, ended but not yet reaped, does
    not: its memory is freed)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def make_witness(log, watch=""):
    """The 5-step countdown slider; each make appends a line to the file
    `log`: this worker's pid, then those of the pids in the file `watch`
    (another witness's log) still running."""
    import os

    seen = []
    if watch and os.path.exists(watch):
        with open(watch) as f:
            seen = [int(line.split()[0]) for line in f if line.strip()]
    alive = [p for p in seen if _running(p)]
    with open(log, "a") as f:
        f.write(" ".join(str(p) for p in [os.getpid()] + alive) + "\n")
    return Timer(False), Params()


make_watcher = make_witness

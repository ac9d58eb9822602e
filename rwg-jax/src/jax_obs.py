"""Structured observations: an observation that is an array of any rank, a
named tuple, a dict or a nested pytree becomes one vector of the study's
precision, in one stable order, and is described leaf by leaf.

The order is JAX's pytree order (`jax.tree_util.tree_flatten_with_path`):
named tuple and dataclass fields in the order they are declared, dict keys
sorted, list and tuple items by index; each leaf flattened row-major (C
order). Booleans and integers become 0/1 and their values in the precision.
A leaf's name is its path (`grid`, `agent.position`, `['state']`); a bare
array's name is `obs`."""

from rwg_pipe import fail


class ObsBox:
    """The flattened observation as rwg's policy sees it: `dim` values with
    bounds (booleans [0, 1], every other leaf unbounded), and the leaves it
    is made of (name, shape, dtype)."""

    def __init__(self, leaves):
        import numpy as np

        self.leaves = leaves
        lows, highs = [], []
        for _, shape, dtype in leaves:
            size = int(np.prod(shape, dtype=np.int64))
            lo, hi = (0.0, 1.0) if dtype == "bool" else (-np.inf, np.inf)
            lows.append(np.full(size, lo))
            highs.append(np.full(size, hi))
        self.low = np.concatenate(lows) if lows else np.zeros(0)
        self.high = np.concatenate(highs) if highs else np.zeros(0)
        self.shape = (int(self.low.size),)

    def __repr__(self):
        return ", ".join(f"{n} {d}[{','.join(str(s) for s in shape)}]"
                         for n, shape, d in self.leaves)


def leaf_name(jax, path):
    """`grid`, `agent.position`, `['state']`: a leaf's path as text."""
    if not path:
        return "obs"
    text = jax.tree_util.keystr(path)
    return text[1:] if text.startswith(".") else text


def leaves_of(jax, abstract_obs):
    """[(name, shape, dtype)] of an observation's leaves (shapes and dtypes
    from `jax.eval_shape`), in the flattening order."""
    flat, _ = jax.tree_util.tree_flatten_with_path(abstract_obs)
    return [(leaf_name(jax, p), tuple(int(s) for s in x.shape), str(x.dtype)) for p, x in flat]


def flatten_fn(jax, dt):
    """obs pytree -> one vector of dtype `dt`, in the flattening order."""
    jnp = jax.numpy

    def flatten(obs):
        parts = [jnp.ravel(jnp.asarray(x)).astype(dt) for x in jax.tree_util.tree_leaves(obs)]
        return parts[0] if len(parts) == 1 else jnp.concatenate(parts)

    return flatten


def largest_leaf(leaves):
    """The text naming the largest leaf: `grid float32[63,63,3], 11907 values`."""
    import numpy as np

    name, shape, dtype = max(leaves, key=lambda l: int(np.prod(l[1], dtype=np.int64)))
    size = int(np.prod(shape, dtype=np.int64))
    return f"{name} {dtype}[{','.join(str(s) for s in shape)}], {size} values"


def check_reward(jax, env):
    """One reward per step (a scalar), as rwg sums them: a family's env with
    a reward per agent is refused here, before anything is compiled."""
    import numpy as np

    def one_step(key):
        obs, state = env.reset(key)
        zero = np.zeros(getattr(env.act_space, "shape", ()) if hasattr(env.act_space, "low") else (),
                        dtype=np.float32 if hasattr(env.act_space, "low") else np.int32)
        return env.step(key, state, zero)[2]

    try:
        reward = jax.eval_shape(one_step, jax.random.PRNGKey(0))
    except BaseException:  # noqa: BLE001 -- the compile reports what the step does wrong
        return
    if tuple(reward.shape) != ():
        fail("space", f"the env's reward has shape {tuple(reward.shape)}: rwg sums one reward (a "
                      f"scalar) per step, so multi-agent envs (a reward per agent) are not single "
                      f"networks' tasks")


def structured(jax, env, dt):
    """`env` with its observations flattened (when the family gave no space
    of its own: `env.obs_space is None`) and its leaves described; the
    leaves as the ready message lists them."""
    abstract = jax.eval_shape(lambda k: env.reset(k)[0], jax.random.PRNGKey(0))
    leaves = leaves_of(jax, abstract)
    if not leaves:
        fail("space", "the observation has no arrays in it: rwg's networks need at least one input")
    check_reward(jax, env)
    if env.obs_space is None:
        env.obs_space = ObsBox(leaves)
        flatten = flatten_fn(jax, dt)
        reset, step = env.reset, env.step

        def reset_flat(key):
            obs, state = reset(key)
            return flatten(obs), state

        def step_flat(key, state, action):
            obs, state, reward, done = step(key, state, action)
            return flatten(obs), state, reward, done

        env.reset, env.step = reset_flat, step_flat
    described = [{"name": n, "shape": list(s), "dtype": d} for n, s, d in leaves]
    return env, described, leaves

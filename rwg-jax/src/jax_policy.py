"""rwg's policy in JAX: the env's spaces checked and described for rwg (the
ready message's fields), the network x = tanh(W @ [x, 1]) per layer with its
action map (argmax, or the box's bounds), and the uniformly random actions of
a random cell with the key of each step's draw."""

from rwg_pipe import fail, floats
from rwg_jax_worker_common import fail_exc


def refuse_composite(space, what):
    if hasattr(space, "spaces") or type(space).__name__ in ("Dict", "Tuple"):
        fail("space", f"{what} space {space!r} is a {type(space).__name__} space: rwg takes "
                      f"Discrete and Box spaces (or objects with .n or .low/.high/.shape); "
                      f"give the env a flat one")


def discrete_n(space, what):
    """A discrete space's `.n` as a whole number of 1 or more, or a `space`
    failure saying what it is instead (a MultiDiscrete-like array, 0, 2.5)."""
    import numpy as np

    n = np.asarray(space.n)
    if n.ndim != 0:
        fail("space", f"{what} space {space!r} has {n.size} discrete choices (.n = {n.tolist()}),"
                      f" a MultiDiscrete space: rwg takes one Discrete(n) choice or a Box; give "
                      f"the env one of those")
    if not (np.issubdtype(n.dtype, np.number) and not np.issubdtype(n.dtype, np.bool_)
            and float(n).is_integer() and n >= 1):
        fail("space", f"{what} space {space!r} has n = {space.n!r}: rwg takes a Discrete(n) with "
                      f"a whole n of 1 or more")
    return int(n)


def box_bounds(space, what):
    """A box space's (shape, low, high), the bounds flat, or a `space`
    failure when they do not fit its shape."""
    import numpy as np

    shape = tuple(int(s) for s in space.shape)
    low, high = np.asarray(space.low, dtype=np.float64), np.asarray(space.high, dtype=np.float64)
    try:
        return (shape, np.broadcast_to(low, shape).reshape(-1),
                np.broadcast_to(high, shape).reshape(-1))
    except ValueError:
        fail("space", f"{what} space {space!r} has bounds of shape {low.shape} and {high.shape}, "
                      f"which do not fit its shape {shape}")


def space_text(space):
    """How env.json records a space: its repr, or, for a class without a
    repr of its own (whose default names a memory address, different in
    every process, so a resume would see "another env"), its type and its
    fields."""
    import numpy as np

    text = repr(space)
    if " object at 0x" not in text:
        return text
    fields = []
    for name in ("n", "shape", "dtype", "low", "high"):
        if not hasattr(space, name):
            continue
        v = getattr(space, name)
        if name in ("low", "high"):
            a = np.asarray(v)
            v = a.tolist() if a.size <= 8 else f"{a.dtype}{list(a.shape)} from {a.min()} to {a.max()}"
        fields.append(f"{name}={v}")
    kind = type(space)
    return f"{kind.__module__}.{kind.__qualname__}({', '.join(fields)})"


def describe_spaces(env, max_obs, leaves):
    """The R message's space fields, and (discrete n, box low, box high,
    action shape) for the policy. `leaves`: the observation's (name, shape,
    dtype), named when it is too large."""
    import numpy as np

    obs, act = env.obs_space, env.act_space
    refuse_composite(obs, "observation")
    refuse_composite(act, "action")
    if hasattr(obs, "low") and hasattr(obs, "shape"):
        shape, low, high = box_bounds(obs, "observation")
    elif hasattr(obs, "n"):
        shape, low, high = (1,), np.zeros(1), np.array([discrete_n(obs, "observation") - 1.0])
    else:
        fail("space", f"observation space {obs!r} has neither .low/.high/.shape nor .n")
    dim = int(np.prod(shape, dtype=np.int64))
    if dim == 0 or dim > max_obs:
        from rwg_jax_worker_obs import largest_leaf

        fail("space", f"the observation has {dim} values (largest leaf: {largest_leaf(leaves)}); "
                      f"rwg's networks take 1 to {max_obs} inputs (a [4,4] network on {max_obs} "
                      f"inputs already has {4 * max_obs + 20} weights, drawn and sent for every "
                      f"network); give the env a smaller observation (a symbolic rather than a "
                      f"pixel one)")
    fields = {"obs_shape": list(shape), "obs_dim": dim, "obs_low": floats(low),
              "obs_high": floats(high), "observation_space": space_text(obs),
              "action_space": space_text(act)}
    if hasattr(act, "n") and not hasattr(act, "low"):
        n = discrete_n(act, "action")
        fields["action"] = {"discrete": n}
        return fields, (n, None, None, None)
    if not (hasattr(act, "low") and hasattr(act, "high") and hasattr(act, "shape")):
        fail("space", f"action space {act!r} has neither .n nor .low/.high/.shape")
    ashape, alow, ahigh = box_bounds(act, "action")
    if alow.size == 0 or not (np.all(np.isfinite(alow)) and np.all(np.isfinite(ahigh))):
        fail("space", f"action space {act!r} has non-finite bounds (or no values); rwg maps "
                      f"tanh outputs onto the bounds, so every dimension needs finite ones")
    fields["action"] = {"box": {"low": floats(alow), "high": floats(ahigh), "shape": list(ashape)}}
    return fields, (None, alow, ahigh, ashape)


def check_sizes(jax, env, dt, space, obs_shape, obs_dim):
    """Traces (does not run) a reset and a step with the action rwg's
    policy gives: observations of `obs_dim` values, or a `space` failure
    naming both sizes (not XLA's message about the layer they meet; the
    reward's shape is `check_reward`'s)."""
    import numpy as np

    jnp = jax.numpy
    n, _, _, ashape = space
    action = jnp.int32(0) if n is not None else jnp.zeros(ashape, dt)

    def first_step(key_data):
        key = jax.random.wrap_key_data(key_data, impl="threefry2x32")
        k_reset, k_steps = jax.random.split(key)
        obs, state = env.reset(k_reset)
        out = env.step(jax.random.fold_in(k_steps, 0), state, action)
        return obs, out[0]

    try:
        shapes = jax.eval_shape(first_step, jax.ShapeDtypeStruct((2,), jnp.uint32))
    except BaseException as e:  # noqa: BLE001 -- the env's own code, traced
        fail_exc("make", "tracing the env's reset and a first step", e)
    for what, x in (("reset", shapes[0]), ("step", shapes[1])):
        shapes_of = [tuple(int(d) for d in leaf.shape) for leaf in jax.tree_util.tree_leaves(x)]
        size = sum(int(np.prod(s, dtype=np.int64)) for s in shapes_of)
        if size != obs_dim:
            shape = shapes_of[0] if len(shapes_of) == 1 else f"{len(shapes_of)} arrays"
            fail("space", f"the env's {what} returns an observation of {size} values (shape "
                          f"{shape}) where its observation space declares {obs_dim} (shape "
                          f"{tuple(obs_shape)}); fix the env's spaces or what it computes")


#: Layers with at most this many inputs (the bias's 1 included) compute
#: W @ x as a chain of multiplies and adds; wider ones call XLA's dot.
CHAIN_INPUTS = 64


def matvec(jnp, W, x):
    """W @ x. For a layer of at most `CHAIN_INPUTS` inputs, a chain in a
    fixed order, ((W[:, 0] * x[0] + W[:, 1] * x[1]) + ...), each product and
    sum rounded on its own: elementwise work, which runs faster than XLA's
    batched dot on a CPU at these sizes and whose order of summation is
    fixed (the dot picks its own, and its use of fused multiply-adds, by
    the arrays' shapes). A wider layer (a pixel or symbolic observation)
    calls the dot."""
    if W.shape[1] > CHAIN_INPUTS:
        return W @ x
    acc = W[:, 0] * x[0]
    for k in range(1, W.shape[1]):
        acc = acc + W[:, k] * x[k]
    return acc


def policy_fn(jnp, layers, bias, dt, space):
    """rwg's policy: x = tanh(W @ [x, 1]) per layer (`matvec`); argmax or
    the box map. `legal` (a bool per action, or None): the argmax is over
    the legal actions only; where none is legal, over all (plain argmax)."""
    n, low, high, ashape = space
    if n is None:
        symmetric = bool((low == -high).all())
        lo, hi = jnp.asarray(low, dt), jnp.asarray(high, dt)

    def policy(Ws, obs, legal=None, key=None):
        x = jnp.ravel(obs).astype(dt)
        for W in Ws:
            if bias:
                x = jnp.concatenate([x, jnp.ones((1,), dt)])
            x = jnp.tanh(matvec(jnp, W, x))
        if n is not None:
            if legal is not None:
                legal = jnp.asarray(legal, bool)
                x = jnp.where(legal | ~jnp.any(legal), x, -jnp.inf)
            return jnp.argmax(x).astype(jnp.int32)
        a = hi * x if symmetric else lo + (x + 1) / 2 * (hi - lo)
        return a.reshape(ashape)

    policy.needs_key = False
    return policy


def random_policy_fn(jax, dt, space):
    """Uniformly random actions, one draw u = uniform(key) in [0, 1) per
    value: a discrete action is the floor(u * k)-th of the k legal ones (of
    all n where the family gives no legal actions or none is legal); a box
    action is low + (high - low) * u per value. No weights (`Ws` is empty)."""
    jnp = jax.numpy
    n, low, high, ashape = space
    if n is None:
        lo, hi = jnp.asarray(low, dt), jnp.asarray(high, dt)

    def policy(Ws, obs, legal, key):
        if n is None:
            u = jax.random.uniform(key, lo.shape, dt)
            return (lo + (hi - lo) * u).reshape(ashape)
        u = jax.random.uniform(key, (), dt)
        if legal is None:
            return jnp.minimum((u * n).astype(jnp.int32), n - 1)
        legal = jnp.asarray(legal, bool)
        legal = legal | ~jnp.any(legal)
        k = jnp.sum(legal, dtype=jnp.int32)
        i = jnp.minimum((u * k).astype(jnp.int32), k - 1)
        return jnp.argmax(jnp.cumsum(legal, dtype=jnp.int32) > i).astype(jnp.int32)

    policy.needs_key = True
    return policy


def action_key(jax, k_steps, t, T):
    """The key of step `t`'s random action: `k_steps`'s child T + t (the
    env's own step keys are its children 0 to T - 1; T < 2**31)."""
    jnp = jax.numpy
    return jax.random.fold_in(k_steps, jnp.uint32(T) + jnp.asarray(t).astype(jnp.uint32))

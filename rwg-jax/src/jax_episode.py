"""The compiled program of a cell: lanes that never idle.

A chunk holds N networks x E episodes ("items"). The program runs them on L
lanes (the cell's `lanes`): each lane runs one episode at a time, and a lane
whose episode ended takes the chunk's next item inside the compiled loop, so
no lane waits for the chunk's longest episode. A lane that ends waits until
`refill` lanes have ended (or none runs any more); then every waiting lane
writes its result and takes an item at once, so the bookkeeping is paid once
per group. An env whose episodes all end at the same step whatever the actions
(`fixed_length`: Pendulum, which ends only at its time limit) runs
`plain_program` instead: the lanes take L items at a time and step until all
have ended, with no refill to count and a smaller program to compile.

Every per-episode computation has the shape of the L lanes, whatever N (the
resets run L at a time too), and the arithmetic of a lane does not depend on
its place: an episode's return is the same bits whichever chunk, lane or
networks_per_call computes it, and whichever of the two programs runs it (the
step of a lane is the same computation in both). Only L (and the cell: env,
architecture, precision, device kind, versions) fixes the bits.
"""

from rwg_pipe import fail
from rwg_jax_worker_common import FAULT_OBS, FAULT_RETURN, FAULT_REWARD, MAX_RETURN
from rwg_jax_worker_policy import action_key, policy_fn, random_policy_fn

import struct


def lane_fns(jax, env, policy, dt):
    """(reset, step) of one lane: reset(key data) -> (obs, state, step key
    data, fault); step(W, obs, state, step key data, t) -> (obs, state,
    reward, done, fault bits). The policy sees the env's legal actions where
    the env has them."""
    jnp = jax.numpy

    def not_finite(x):
        return ~jnp.all(jnp.isfinite(jnp.asarray(x)))

    def bit(cond, b):
        return jnp.where(cond, b, 0).astype(jnp.uint8)

    def reset(key_data):
        key = jax.random.wrap_key_data(key_data, impl="threefry2x32")
        k_reset, k_steps = jax.random.split(key)
        obs, state = env.reset(k_reset)
        return obs, state, jax.random.key_data(k_steps), bit(not_finite(obs), FAULT_OBS)

    def step(Ws, obs, state, k_steps, t):
        k_steps = jax.random.wrap_key_data(k_steps, impl="threefry2x32")
        # a random cell's action key: the item's step key's child T + t
        akey = action_key(jax, k_steps, t, env.max_steps) if policy.needs_key else None
        a = policy(Ws, obs, env.legal(state) if env.legal else None, akey)
        key = jax.random.fold_in(k_steps, t)
        obs, state, r, d = env.step(key, state, a)
        r = jnp.asarray(r).astype(dt)
        fault = bit(not_finite(obs), FAULT_OBS) | bit(not_finite(r), FAULT_REWARD)
        return obs, state, r, jnp.asarray(d, bool), fault

    return reset, step


def step_fn(jax, env, policy, dt, end):
    """One step of every lane: (weights, obs, state, step keys, t, return,
    fault, done) -> (obs, state, t, return, fault, done); a lane that has
    ended steps too, its results left as they were. With `end`, a value that
    is not finite (or a return beyond MAX_RETURN) ends the episode."""
    jnp = jax.numpy
    T = env.max_steps
    vstep = jax.vmap(lane_fns(jax, env, policy, dt)[1])

    def lanes_step(WL, obs, state, ks, t, ret, fault, done):
        obs, state, r, d, f = vstep(WL, obs, state, ks, t)
        run = ~done
        total_r = ret + r
        t = jnp.where(run, t + 1, t)
        f = fault | f
        if end:
            ok = jnp.isfinite(total_r) & (jnp.abs(total_r) <= jnp.asarray(MAX_RETURN, dt))
            bad_r = ~jnp.isfinite(r)
            f = f | jnp.where(ok | bad_r, 0, FAULT_RETURN).astype(jnp.uint8)
            cut = f != 0
            total_r = jnp.where(cut, ret, total_r)
            d = d | cut
        ret = jnp.where(run, total_r, ret)
        fault = jnp.where(run, f, fault)
        done = done | (d | (t >= T))
        return obs, state, t, ret, fault, done

    return lanes_step


def plain_program(jax, env, policy, dt, N, E, L, end=False):
    """The program of an env whose episodes all end at the same step
    (`fixed_length`): same arguments and results as `chunk_program`, the
    same bits. The chunk's items run L at a time (a block): the block's
    resets, then steps until every lane has ended, then the next block."""
    jnp, lax = jax.numpy, jax.lax
    M = N * E
    blocks = -(-M // L)
    vreset = jax.vmap(lane_fns(jax, env, policy, dt)[0])
    lanes_step = step_fn(jax, env, policy, dt, end)

    def program(Ws, keys, n, refill_at):
        total = n * E
        flat = jnp.zeros((blocks * L, 2), jnp.uint32).at[:M].set(keys.reshape(M, 2))
        out = (jnp.zeros((blocks * L,), dt), jnp.zeros((blocks * L,), jnp.int32),
               jnp.zeros((blocks * L,), jnp.uint8))

        def block(b, out):
            item = b * L + jnp.arange(L, dtype=jnp.int32)
            obs, state, ks, fault = vreset(lax.dynamic_slice_in_dim(flat, b * L, L))
            WL = [W[jnp.minimum(item // E, N - 1)] for W in Ws]
            done = item >= total
            if end:
                done = done | (fault != 0)
            c = (obs, state, jnp.zeros((L,), jnp.int32), jnp.zeros((L,), dt), fault, done)
            _, _, t, ret, fault, _ = lax.while_loop(
                lambda c: jnp.any(~c[5]), lambda c: lanes_step(WL, c[0], c[1], ks, *c[2:]), c)
            return tuple(lax.dynamic_update_slice_in_dim(o, v, b * L, 0)
                         for o, v in zip(out, (ret, t, fault)))

        # a trip count known only when the chunk runs: the same loop for every N
        out = lax.fori_loop(0, (total + L - 1) // L, block, out)
        ret, length, fault = (o[:M].reshape(N, E) for o in out)
        return ret, length, fault, (total + L - 1) // L

    return program


def chunk_program(jax, env, policy, dt, N, E, L, end=False):
    """The chunk's program: (weights per layer (N, out, in), keys (N, E, 2),
    n networks, refill) -> (returns, lengths, faults) (N, E), loop trips.
    With `end` (non_finite = "end"), an episode ends at its first value that
    is not finite (or a return beyond MAX_RETURN), that step counted, its
    reward left out; a reset's non-finite observation ends it at step 0."""
    jnp, lax = jax.numpy, jax.lax
    M = N * E
    blocks = -(-M // L)
    vreset = jax.vmap(lane_fns(jax, env, policy, dt)[0])
    lanes_step = step_fn(jax, env, policy, dt, end)
    tree = jax.tree_util

    def lanes_where(mask, a, b):
        return tree.tree_map(
            lambda x, y: jnp.where(mask.reshape((L,) + (1,) * (x.ndim - 1)), x, y), a, b)

    def resets(keys, total):
        """Every item's reset, computed L items at a time (the lanes' shape)."""
        flat = jnp.zeros((blocks * L, 2), jnp.uint32).at[:M].set(keys.reshape(M, 2))
        shape = jax.eval_shape(vreset, flat[:L])
        out = tree.tree_map(lambda s: jnp.zeros((blocks,) + s.shape, s.dtype), shape)

        def one(b, out):
            got = vreset(lax.dynamic_slice_in_dim(flat, b * L, L))
            return tree.tree_map(lambda o, g: o.at[b].set(g), out, got)

        # a trip count known only when the chunk runs: the same loop for every N
        out = lax.fori_loop(0, (total + L - 1) // L, one, out)
        return tree.tree_map(lambda o: o.reshape((blocks * L,) + o.shape[2:]), out)

    def refill(c, Ws, start, total):
        """Lanes that ended write their result; every lane without an
        episode takes the next item, if any."""
        (item, obs, state, ks, t, ret, fault, done, WL, nxt, out) = c
        ended = done & (item < total)
        at = jnp.where(ended, item, blocks * L)  # out of bounds: dropped
        out = tuple(o.at[at].set(v, mode="drop") for o, v in zip(out, (ret, t, fault)))
        rank = jnp.cumsum(done, dtype=jnp.int32) - 1
        new = jnp.where(done, nxt + rank, item)
        take = done & (new < total)
        i = jnp.minimum(new, blocks * L - 1)
        obs0, state0, ks0, f0 = tree.tree_map(lambda x: x[i], start)
        gW = [W[jnp.minimum(i // E, N - 1)] for W in Ws]
        obs, state = lanes_where(take, (obs0, state0), (obs, state))
        ks = jnp.where(take[:, None], ks0, ks)
        WL = lanes_where(take, gW, WL)
        t = jnp.where(done, 0, t)
        ret = jnp.where(done, jnp.zeros((), dt), ret)
        fault = jnp.where(take, f0, jnp.where(done, 0, fault).astype(jnp.uint8))
        nxt = jnp.minimum(nxt + jnp.sum(done, dtype=jnp.int32), total)
        done = done & ~take
        if end:
            done = done | (take & (f0 != 0))
        return (new, obs, state, ks, t, ret, fault, done, WL, nxt, out)

    def program(Ws, keys, n, refill_at):
        total = n * E
        start = resets(keys, total)
        obs, state = tree.tree_map(lambda x: x[:L], start[:2])
        out = (jnp.zeros((blocks * L,), dt), jnp.zeros((blocks * L,), jnp.int32),
               jnp.zeros((blocks * L,), jnp.uint8))
        # every lane ended and without an item: the first trip steps none
        # (its results are dropped) and refills them all (one refill in the
        # program instead of a second one before the loop: less to compile)
        c = (jnp.full((L,), blocks * L, jnp.int32), obs, state, jnp.zeros((L, 2), jnp.uint32),
             jnp.zeros((L,), jnp.int32), jnp.zeros((L,), dt), jnp.zeros((L,), jnp.uint8),
             jnp.ones((L,), bool), [jnp.zeros((L,) + W.shape[1:], dt) for W in Ws],
             jnp.int32(0), out)

        def cond(lc):
            return jnp.any(lc[0][0] < total) | (lc[1] == 0)

        def body(lc):
            c, trips = lc
            (item, obs, state, ks, t, ret, fault, done, WL, nxt, out) = c
            obs, state, t, ret, fault, done = lanes_step(WL, obs, state, ks, t, ret, fault, done)
            c = (item, obs, state, ks, t, ret, fault, done, WL, nxt, out)
            waiting = jnp.sum(done & (item < total), dtype=jnp.int32)
            now = (waiting >= refill_at) | jnp.all(done)
            c = lax.cond(now, lambda c: refill(c, Ws, start, total), lambda c: c, c)
            return c, trips + 1

        c, trips = lax.while_loop(cond, body, (c, jnp.int32(0)))
        ret, length, fault = (o[:M].reshape(N, E) for o in c[-1])
        return ret, length, fault, trips

    return program


def _input_deps(jaxpr, outs):
    """The indices of `jaxpr`'s inputs that its outputs `outs` depend on: a
    walk back over its equations, into the jaxpr of a call (`pjit`,
    `custom_jvp_call`, ...); any other equation with a jaxpr inside (a loop,
    a cond) counts every input as a dependency of every output."""
    def var(v):
        return not hasattr(v, "val")  # a Literal has a value, a Var has none

    need = {v for i in outs for v in [jaxpr.outvars[i]] if var(v)}
    for eqn in reversed(jaxpr.eqns):
        hit = [k for k, v in enumerate(eqn.outvars) if v in need]
        if not hit:
            continue
        inner = None
        for name in ("jaxpr", "call_jaxpr", "fun_jaxpr"):
            j = eqn.params.get(name)
            j = getattr(j, "jaxpr", j)
            if hasattr(j, "eqns") and len(j.invars) == len(eqn.invars) \
                    and len(j.outvars) == len(eqn.outvars):
                inner = j
                break
        ins = (range(len(eqn.invars)) if inner is None else _input_deps(inner, hit))
        need.update(eqn.invars[i] for i in ins if var(eqn.invars[i]))
    return {i for i, v in enumerate(jaxpr.invars) if v in need}


def fixed_length(jax, env, dt, space):
    """(True, why) when every episode of `env` ends at the same step whatever
    the actions and keys, else (False, why): its `done` depends on no action,
    no key and, through the state the step carries, on no value its reset
    draws from the key (Pendulum's step counter, a task that ends only at the
    time limit). Found from the traced reset and step; conservative (a loop
    or cond inside counts as depending on all its inputs), so it may say no
    of an env whose episodes all have one length, never yes of one whose
    episodes do not."""
    jnp, tree = jax.numpy, jax.tree_util
    n, _, _, ashape = space
    action = jax.ShapeDtypeStruct((), jnp.int32) if n is not None else \
        jax.ShapeDtypeStruct(tuple(ashape), dt)
    key = jax.ShapeDtypeStruct((2,), jnp.uint32)

    def wrap(k):
        return jax.random.wrap_key_data(k, impl="threefry2x32")

    try:
        # one trace of the reset: its jaxpr, and the state's leaves and tree
        r, state = jax.make_jaxpr(lambda k: env.reset(wrap(k))[1], return_shape=True)(key)
        leaves, shape = tree.tree_flatten(state)

        def step(k, a, *state):
            _, s, _, d = env.step(wrap(k), tree.tree_unflatten(shape, state), a)
            return [jnp.asarray(d)] + tree.tree_leaves(s)

        st = jax.make_jaxpr(step)(key, action, *leaves)
    except BaseException as e:  # noqa: BLE001 -- the env's own code; lanes are always right
        return False, f"its step could not be analysed ({type(e).__name__})"
    if len(st.jaxpr.outvars) != 1 + len(leaves):
        return False, "its step returns a state of another structure than its reset's"
    # the state leaves `done` depends on, and those they are computed from
    deps = _input_deps(st.jaxpr, [0])
    seen = set()
    while True:
        if 1 in deps:
            return False, "its episodes end on what the actions do"
        if 0 in deps:
            return False, "its episodes end on what the step draws from its key"
        new = {i - 2 for i in deps} - seen
        if not new:
            break
        seen |= new
        deps = _input_deps(st.jaxpr, [1 + i for i in new])
    if _input_deps(r.jaxpr, sorted(seen)):
        return False, "its episodes end on what its reset draws"
    return True, "every episode ends at the same step, whatever the actions"


def cell_layers(space, obs_dim, cell):
    """The cell's layer shapes (out, in[+1]) and weights per network."""
    hidden, bias = [int(h) for h in cell["hidden"]], bool(cell["bias"])
    random = cell.get("policy", "network") == "random"
    n_out = space[0] if space[0] is not None else len(space[1])
    sizes = [] if random else [obs_dim] + hidden + [n_out]
    layers = [(sizes[i + 1], sizes[i] + int(bias)) for i in range(len(sizes) - 1)]
    nw = sum(o * i for o, i in layers)
    if nw != int(cell["n_weights"]):
        fail("protocol", f"rwg counts {cell['n_weights']} weights, the worker {nw} "
                         f"(layers {layers})")
    return layers, nw


class Compiled:
    """A cell's program compiled for each of the worker's devices."""

    def __init__(self, calls, layers, nw, N, E, refill_at):
        self.calls, self.layers, self.nw = calls, layers, nw
        self.N, self.E, self.refill_at = N, E, refill_at


def compile_cell(jax, env, devs, dt, space, obs_dim, cell):
    """The cell's program (see the module's doc), compiled once per device."""
    jnp = jax.numpy
    layers, nw = cell_layers(space, obs_dim, cell)
    N, E, L = int(cell["networks"]), int(cell["episodes"]), int(cell["lanes"])
    random = cell.get("policy", "network") == "random"
    bias = bool(cell["bias"])
    policy = random_policy_fn(jax, dt, space) if random else policy_fn(jnp, layers, bias, dt,
                                                                         space)
    end = cell.get("non_finite") == "end"
    make = plain_program if getattr(env, "fixed_length", False) else chunk_program
    program = jax.jit(make(jax, env, policy, dt, N, E, L, end))
    calls = []
    with jax.default_matmul_precision(cell["matmul_precision"]):
        for dev in devs:
            sh = jax.sharding.SingleDeviceSharding(dev)
            specs = ([jax.ShapeDtypeStruct((N, o, i), dt, sharding=sh) for o, i in layers],
                     jax.ShapeDtypeStruct((N, E, 2), jnp.uint32, sharding=sh),
                     jax.ShapeDtypeStruct((), jnp.int32, sharding=sh),
                     jax.ShapeDtypeStruct((), jnp.int32, sharding=sh))
            calls.append((dev, program.lower(*specs).compile()))
    return Compiled(calls, layers, nw, N, E, max(1, int(cell.get("refill", L // 8))))


def dispatch_chunk(jax, dt, compiled, payload, k):
    """Starts a B message's chunk on device `k % devices` (JAX runs it
    asynchronously); returns what `outcome` needs."""
    import numpy as np

    c = compiled
    n, e = struct.unpack_from("<II", payload, 0)
    if not (1 <= n <= c.N) or e != c.E:
        fail("protocol", f"a chunk of {n} networks x {e} episodes for a cell of {c.N} x {c.E}")
    w = np.frombuffer(payload, dtype="<f8", count=n * c.nw, offset=8).reshape(n, c.nw)
    seeds = np.frombuffer(payload, dtype="<u8", count=n * e, offset=8 + 8 * n * c.nw)
    wp = np.zeros((c.N, c.nw), dtype=np.float64)
    wp[:n] = w
    keys = np.zeros((c.N * c.E, 2), dtype=np.uint32)
    keys[:n * e, 0] = (seeds >> np.uint64(32)).astype(np.uint32)
    keys[:n * e, 1] = (seeds & np.uint64(0xFFFFFFFF)).astype(np.uint32)
    dev, fn = c.calls[k % len(c.calls)]
    Ws, off = [], 0
    for o, i in c.layers:
        Ws.append(wp[:, off:off + o * i].reshape(c.N, o, i).astype(dt))
        off += o * i
    args = jax.device_put((Ws, keys.reshape(c.N, c.E, 2), np.int32(n), np.int32(c.refill_at)),
                          dev)
    return n, fn(*args)


def outcome(pending):
    """The O message's parts of a dispatched chunk (waits for its results)."""
    import numpy as np

    n, (ret, length, fault, _trips) = pending
    ret = np.asarray(ret)[:n].astype("<f8").reshape(-1)
    length = np.asarray(length)[:n].astype("<u4").reshape(-1)
    fault = np.asarray(fault)[:n].astype(np.uint8).reshape(-1)
    pad = (-fault.size) % 8
    return ret.tobytes(), length.tobytes(), fault.tobytes() + bytes(pad)

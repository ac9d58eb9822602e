"""The compiled program of a cell: one episode as a `lax.while_loop`, vmapped
over episodes and networks and compiled once at the cell's padded shape, and a
chunk of networks run through it."""

from rwg_pipe import fail
from rwg_jax_worker_common import FAULT_OBS, FAULT_RETURN, FAULT_REWARD, MAX_RETURN
from rwg_jax_worker_policy import policy_fn

import struct


def episode_fn(jax, env, policy, dt, end=False):
    """One episode: (returns, length, fault bits) of network Ws from key data.
    With `end` (non_finite = "end"), the episode ends at its first value that
    is not finite (or a return beyond MAX_RETURN), that step counted, its
    reward left out; a reset's non-finite observation ends it at step 0."""
    jnp, lax = jax.numpy, jax.lax
    T = env.max_steps

    def not_finite(x):
        return ~jnp.all(jnp.isfinite(jnp.asarray(x)))

    def episode(Ws, key_data):
        key = jax.random.wrap_key_data(key_data, impl="threefry2x32")
        k_reset, k_steps = jax.random.split(key)
        obs, state = env.reset(k_reset)
        fault = jnp.where(not_finite(obs), FAULT_OBS, 0).astype(jnp.uint8)

        def cond(c):
            return ~c[5]

        def body(c):
            obs, state, t, ret, fault, _ = c
            a = policy(Ws, obs, env.legal(state) if env.legal else None)
            obs, state, r, d = env.step(jax.random.fold_in(k_steps, t), state, a)
            r = jnp.asarray(r).astype(dt)
            fault = fault | jnp.where(not_finite(obs), FAULT_OBS, 0).astype(jnp.uint8)
            fault = fault | jnp.where(not_finite(r), FAULT_REWARD, 0).astype(jnp.uint8)
            t = t + 1
            done = jnp.logical_or(jnp.asarray(d, bool), t >= T)
            if not end:
                return obs, state, t, ret + r, fault, done
            total = ret + r
            ok = jnp.isfinite(total) & (jnp.abs(total) <= jnp.asarray(MAX_RETURN, dt))
            fault = fault | jnp.where(ok | not_finite(r), 0, FAULT_RETURN).astype(jnp.uint8)
            cut = fault != 0
            return obs, state, t, jnp.where(cut, ret, total), fault, done | cut

        done0 = jnp.bool_(T <= 0)
        if end:
            done0 = done0 | (fault != 0)
        init = (obs, state, jnp.int32(0), jnp.zeros((), dt), fault, done0)
        _, _, t, ret, fault, _ = lax.while_loop(cond, body, init)
        return ret, t, fault

    return episode


def compile_cell(jax, env, dev, dt, space, obs_dim, cell):
    """The compiled call of a cell and its layer shapes."""
    jnp = jax.numpy
    hidden, bias = [int(h) for h in cell["hidden"]], bool(cell["bias"])
    N, E = int(cell["networks"]), int(cell["episodes"])
    n_out = space[0] if space[0] is not None else len(space[1])
    sizes = [obs_dim] + hidden + [n_out]
    layers = [(sizes[i + 1], sizes[i] + int(bias)) for i in range(len(sizes) - 1)]
    nw = sum(o * i for o, i in layers)
    if nw != int(cell["n_weights"]):
        fail("protocol", f"rwg counts {cell['n_weights']} weights, the worker {nw} "
                         f"(layers {layers})")
    end = cell.get("non_finite") == "end"
    episode = episode_fn(jax, env, policy_fn(jnp, layers, bias, dt, space), dt, end)
    call = jax.jit(jax.vmap(jax.vmap(episode, in_axes=(None, 0)), in_axes=(0, 0)))
    sharding = jax.sharding.SingleDeviceSharding(dev)
    specs = ([jax.ShapeDtypeStruct((N, o, i), dt, sharding=sharding) for o, i in layers],
             jax.ShapeDtypeStruct((N, E, 2), jnp.uint32, sharding=sharding))
    return call.lower(*specs).compile(), layers, nw, N, E


def run_chunk(jax, dev, dt, compiled, payload):
    """The O message's parts for a B message's payload."""
    import numpy as np

    fn, layers, nw, N, E = compiled
    n, e = struct.unpack_from("<II", payload, 0)
    if not (1 <= n <= N) or e != E:
        fail("protocol", f"a chunk of {n} networks x {e} episodes for a cell of {N} x {E}")
    w = np.frombuffer(payload, dtype="<f8", count=n * nw, offset=8).reshape(n, nw)
    seeds = np.frombuffer(payload, dtype="<u8", count=n * e, offset=8 + 8 * n * nw).reshape(n, e)
    wp = np.zeros((N, nw), dtype=np.float64)
    wp[:n] = w
    keys = np.zeros((N, E, 2), dtype=np.uint32)
    keys[:n, :, 0] = (seeds >> np.uint64(32)).astype(np.uint32)
    keys[:n, :, 1] = (seeds & np.uint64(0xFFFFFFFF)).astype(np.uint32)
    Ws, off = [], 0
    for o, i in layers:
        Ws.append(jax.device_put(wp[:, off:off + o * i].reshape(N, o, i).astype(dt), dev))
        off += o * i
    ret, length, fault = fn(Ws, jax.device_put(keys, dev))
    ret = np.asarray(ret)[:n].astype("<f8").reshape(-1)
    length = np.asarray(length)[:n].astype("<u4").reshape(-1)
    fault = np.asarray(fault)[:n].astype(np.uint8).reshape(-1)
    pad = (-fault.size) % 8
    return ret.tobytes(), length.tobytes(), fault.tobytes() + bytes(pad)

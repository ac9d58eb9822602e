"""rwg's JAX worker: runs rwg's policy on a JAX env, one compiled call per chunk.

rwg starts this program through rwg-worker's loader (python -c LOAD WORKER
rwg_pipe PIPE) and speaks the protocol of rwg-jax (framing as
docs/bridge-protocol.md, by rwg_pipe) over the child's stdin/stdout: a hello
(H) naming the env, a cell (C) naming the architecture to compile, chunks (B)
of networks' weights and reset seeds; it answers ready (R), compiled (K) and
the chunk's outcome (O): per episode its return, length and fault bits.
Everything the env prints goes to stderr: rwg_pipe, imported first, keeps
private duplicates of the original stdin/stdout for the protocol and
redirects fd 0/1 before jax is imported.
"""

from rwg_pipe import (  # the pipe first: it redirects fd 0/1
    decode_kwargs,
    fail,
    floats,
    progress,
    read_msg,
    send_json,
    write_msg,
)

import json
import os
import struct
import sys
import time
import traceback

PROTOCOL = 1
# XLA on CPU with one thread: rwg runs one worker per thread of its own.
ONE_THREAD_XLA = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
FAULT_OBS = 1
FAULT_REWARD = 2

# progress() kinds: b"m" importing and making the env, b"c" compiling.


def fail_exc(kind, what, e):
    """fail() for the exception `e` raised while doing `what`; an XLA
    RESOURCE_EXHAUSTED becomes `oom` with what to do."""
    text = f"{type(e).__name__}: {e}"
    if "RESOURCE_EXHAUSTED" in text or "out of memory" in text.lower():
        fail("oom", f"{what} ran out of device memory ({text.splitlines()[0]}); lower "
                    f"networks_per_call in the manifest's [[envs]] entry", traceback.format_exc())
    fail(kind, f"{what} raised {text}", traceback.format_exc())


def import_jax(precision):
    """jax, configured for `precision` before anything is traced."""
    os.environ.setdefault("XLA_FLAGS", ONE_THREAD_XLA)
    try:
        import jax
    except ImportError as e:
        fail("import", f"jax is not installed for {sys.executable} ({e}); install it with "
                       f"`{sys.executable} -m pip install jax` (CPU) or "
                       f"`{sys.executable} -m pip install \"jax[cuda12]\"` (NVIDIA GPU)",
             traceback.format_exc())
    jax.config.update("jax_enable_x64", precision == "float64")
    return jax


def pick_device(jax, name):
    """`jax.devices(kind)[index]` for "kind[:index]", default jax.devices()[0]."""
    try:
        if name is None:
            return jax.devices()[0]
        kind, _, index = name.partition(":")
        return jax.devices(kind)[int(index or 0)]
    except BaseException as e:  # noqa: BLE001 -- unknown backend, index out of range
        try:
            known = ", ".join(f"{d.platform}:{d.id} ({d.device_kind})" for d in jax.devices())
        except BaseException:  # noqa: BLE001
            known = "none"
        fail("device", f"no JAX device {name!r} ({type(e).__name__}: {e}); this JAX has: {known}")


def version_of(dist):
    import importlib.metadata

    try:
        return importlib.metadata.version(dist)
    except BaseException:  # noqa: BLE001 -- not an installed distribution
        return None


class Adapted:
    """An env as the episode loop drives it: reset(key) -> (obs, state),
    step(key, state, action) -> (obs, state, reward, done); its spaces and
    time limit; `versions` of what made it."""

    def __init__(self, reset, step, obs_space, act_space, max_steps, versions):
        self.reset, self.step = reset, step
        self.obs_space, self.act_space = obs_space, act_space
        self.max_steps, self.versions = max_steps, versions


def gymnax_step(env, params):
    """gymnax's raw step (no auto-reset) where the env has one."""
    raw = getattr(env, "step_env", None) or env.step

    def step(key, state, action):
        out = raw(key, state, action, params)
        if len(out) == 6:  # (obs, state, reward, terminated, truncated, info)
            return out[0], out[1], out[2], out[3] | out[4]
        return out[0], out[1], out[2], out[3]

    return step


def replace_params(params, kwargs, where):
    """`params.replace(**kwargs)`, refusing fields params does not have."""
    import dataclasses

    if not kwargs:
        return params
    try:
        fields = [f.name for f in dataclasses.fields(params)]
    except TypeError:
        fields = None
    if fields is not None:
        unknown = sorted(k for k in kwargs if k not in fields)
        if unknown:
            fail("make", f"{where} has no field {', '.join(unknown)}; its fields are: "
                         f"{', '.join(fields)}")
    try:
        return params.replace(**kwargs)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"{where}.replace(**{kwargs!r})", e)


def limit_of(params, max_steps, what):
    if max_steps is not None:
        return int(max_steps)
    t = getattr(params, "max_steps_in_episode", None)
    if t is None:
        fail("make", f"{what} has no params.max_steps_in_episode: give max_episode_steps in the "
                     f"manifest's [[envs]] entry")
    return int(t)


def make_gymnax(name, kwargs, max_steps):
    try:
        import gymnax
    except ImportError as e:
        fail("import", f"gymnax is not installed for {sys.executable} ({e}); install it with "
                       f"`{sys.executable} -m pip install gymnax`", traceback.format_exc())
    known = list(gymnax.registered_envs)
    if name not in known:
        fail("unknown-env", f"gymnax has no environment {name!r}; its environments are: "
                            f"{', '.join(known)}")
    try:
        env, params = gymnax.make(name)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"gymnax.make({name!r})", e)
    params = replace_params(params, kwargs, f"gymnax {name}'s env params")
    if max_steps is not None and hasattr(params, "max_steps_in_episode"):
        params = params.replace(max_steps_in_episode=int(max_steps))
    return Adapted(lambda k: env.reset(k, params), gymnax_step(env, params),
                   env.observation_space(params), env.action_space(params),
                   limit_of(params, max_steps, f"gymnax {name}"),
                   {"gymnax": version_of("gymnax")})


class BraxBox:
    """A brax env's observation or action space, in gymnax's Box terms."""

    def __init__(self, bound, size):
        import numpy as np

        self.low = np.full((size,), -bound)
        self.high = np.full((size,), bound)
        self.shape = (size,)

    def __repr__(self):
        return f"Box({self.low[0]}, {self.high[0]}, {self.shape})"


def make_brax(name, kwargs, max_steps):
    try:
        import brax.envs
    except ImportError as e:
        fail("import", f"brax is not installed for {sys.executable} ({e}); install it with "
                       f"`{sys.executable} -m pip install brax`", traceback.format_exc())
    known = sorted(getattr(brax.envs, "_envs", {}))
    if known and name not in known:
        fail("unknown-env", f"brax has no environment {name!r}; its environments are: "
                            f"{', '.join(known)}")
    try:
        env = brax.envs.get_environment(name, **kwargs)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"brax.envs.get_environment({name!r}, **{kwargs!r})", e)

    def reset(key):
        s = env.reset(key)
        return s.obs, s

    def step(key, state, action):
        s = env.step(state, action)
        return s.obs, s, s.reward, s.done > 0.5

    return Adapted(reset, step, BraxBox(float("inf"), int(env.observation_size)),
                   BraxBox(1.0, int(env.action_size)),
                   int(max_steps) if max_steps is not None else 1000,
                   {"brax": version_of("brax")})


def make_custom(target, kwargs, max_steps):
    import importlib

    module, _, attr = target.partition(":")
    if not module or not attr:
        fail("make", f"jax:{target} is not jax:module:callable (e.g. jax:my_pkg.envs:make_env)")
    try:
        mod = importlib.import_module(module)
    except ImportError as e:
        fail("import", f"cannot import module {module!r} ({type(e).__name__}: {e}); install the "
                       f"package that provides it (`{sys.executable} -m pip install ...`) or put "
                       f"its folder on PYTHONPATH", traceback.format_exc())
    except BaseException as e:  # noqa: BLE001
        fail_exc("import", f"import {module}", e)
    fn = getattr(mod, attr, None)
    if not callable(fn):
        fail("make", f"module {module} has no callable {attr!r}")
    try:
        env, params = fn(**kwargs)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"{target}(**{kwargs!r})", e)
    return Adapted(lambda k: env.reset(k, params), gymnax_step(env, params),
                   env.observation_space(params), env.action_space(params),
                   limit_of(params, max_steps, f"jax:{target}"),
                   {"module": version_of(module.split(".")[0])})


def refuse_composite(space, what):
    if hasattr(space, "spaces") or type(space).__name__ in ("Dict", "Tuple"):
        fail("space", f"{what} space {space!r} is a {type(space).__name__} space: rwg takes "
                      f"Discrete and Box spaces (or objects with .n or .low/.high/.shape); "
                      f"give the env a flat one")


def describe_spaces(env, max_obs):
    """The R message's space fields, and (discrete n, box low, box high,
    action shape) for the policy."""
    import numpy as np

    obs, act = env.obs_space, env.act_space
    refuse_composite(obs, "observation")
    refuse_composite(act, "action")
    if hasattr(obs, "low") and hasattr(obs, "shape"):
        shape = tuple(int(s) for s in obs.shape)
        low = np.broadcast_to(np.asarray(obs.low, dtype=np.float64), shape).reshape(-1)
        high = np.broadcast_to(np.asarray(obs.high, dtype=np.float64), shape).reshape(-1)
    elif hasattr(obs, "n"):
        shape, low, high = (1,), np.zeros(1), np.array([float(obs.n) - 1])
    else:
        fail("space", f"observation space {obs!r} has neither .low/.high/.shape nor .n")
    dim = int(np.prod(shape, dtype=np.int64))
    if dim == 0 or dim > max_obs:
        fail("space", f"observation space {obs!r} has {dim} values; rwg takes 1 to {max_obs}")
    fields = {"obs_shape": list(shape), "obs_dim": dim, "obs_low": floats(low),
              "obs_high": floats(high), "observation_space": repr(obs), "action_space": repr(act)}
    if hasattr(act, "n") and not hasattr(act, "low"):
        fields["action"] = {"discrete": int(act.n)}
        return fields, (int(act.n), None, None, None)
    if not (hasattr(act, "low") and hasattr(act, "high") and hasattr(act, "shape")):
        fail("space", f"action space {act!r} has neither .n nor .low/.high/.shape")
    ashape = tuple(int(s) for s in act.shape)
    alow = np.broadcast_to(np.asarray(act.low, dtype=np.float64), ashape).reshape(-1)
    ahigh = np.broadcast_to(np.asarray(act.high, dtype=np.float64), ashape).reshape(-1)
    if alow.size == 0 or not (np.all(np.isfinite(alow)) and np.all(np.isfinite(ahigh))):
        fail("space", f"action space {act!r} has non-finite bounds (or no values); rwg maps "
                      f"tanh outputs onto the bounds, so every dimension needs finite ones")
    fields["action"] = {"box": {"low": floats(alow), "high": floats(ahigh), "shape": list(ashape)}}
    return fields, (None, alow, ahigh, ashape)


def policy_fn(jnp, layers, bias, dt, space):
    """rwg's policy: x = tanh(W @ [x, 1]) per layer; argmax or the box map."""
    n, low, high, ashape = space
    if n is None:
        symmetric = bool((low == -high).all())
        lo, hi = jnp.asarray(low, dt), jnp.asarray(high, dt)

    def policy(Ws, obs):
        x = jnp.ravel(obs).astype(dt)
        for W in Ws:
            if bias:
                x = jnp.concatenate([x, jnp.ones((1,), dt)])
            x = jnp.tanh(W @ x)
        if n is not None:
            return jnp.argmax(x).astype(jnp.int32)
        a = hi * x if symmetric else lo + (x + 1) / 2 * (hi - lo)
        return a.reshape(ashape)

    return policy


def episode_fn(jax, env, policy, dt):
    """One episode: (returns, length, fault bits) of network Ws from key data."""
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
            a = policy(Ws, obs)
            obs, state, r, d = env.step(jax.random.fold_in(k_steps, t), state, a)
            r = jnp.asarray(r).astype(dt)
            fault = fault | jnp.where(not_finite(obs), FAULT_OBS, 0).astype(jnp.uint8)
            fault = fault | jnp.where(not_finite(r), FAULT_REWARD, 0).astype(jnp.uint8)
            t = t + 1
            done = jnp.logical_or(jnp.asarray(d, bool), t >= T)
            return obs, state, t, ret + r, fault, done

        init = (obs, state, jnp.int32(0), jnp.zeros((), dt), fault, jnp.bool_(T <= 0))
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
    episode = episode_fn(jax, env, policy_fn(jnp, layers, bias, dt, space), dt)
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


def start(hello):
    """Imports, picks the device, makes the env: (jax, device, dtype, env, R fields, space)."""
    precision = hello.get("precision", "float32")
    if precision not in ("float32", "float64"):
        fail("protocol", f"precision {precision!r}")
    progress(b"m")
    jax = import_jax(precision)
    dev = pick_device(jax, hello.get("device"))
    dt = jax.numpy.float64 if precision == "float64" else jax.numpy.float32
    kwargs = {k: decode_kwargs(v) for k, v in (hello.get("kwargs") or {}).items()}
    source, name, max_steps = hello["source"], hello["env"], hello.get("max_episode_steps")
    make = {"gymnax": make_gymnax, "brax": make_brax, "jax": make_custom}.get(source)
    if make is None:
        fail("protocol", f"source {source!r}")
    with jax.default_device(dev):
        env = make(name, kwargs, max_steps)
    if env.max_steps < 1 or env.max_steps >= 2**31:
        fail("make", f"time limit {env.max_steps}: rwg takes 1 to {2**31 - 1} steps")
    fields, space = describe_spaces(env, int(hello.get("max_obs", 4096)))
    import jaxlib

    versions = {"python": sys.version.split()[0], "jax": jax.__version__,
                "jaxlib": getattr(jaxlib, "__version__", None) or version_of("jaxlib")}
    versions.update(env.versions)
    fields.update({"max_episode_steps": env.max_steps, "precision": precision,
                   "versions": {k: v for k, v in versions.items() if v is not None},
                   "device": f"{dev.platform}:{dev.id}", "device_kind": dev.device_kind,
                   "platform": dev.platform})
    return jax, dev, dt, env, fields, space


def serve(jax, dev, dt, env, space, obs_dim):
    compiled, cache = None, {}
    while True:
        tag, payload = read_msg()
        if tag == ord("Q"):
            sys.exit(0)
        if tag == ord("C"):
            cell = json.loads(payload.decode())
            key = json.dumps(cell, sort_keys=True)
            t0 = time.perf_counter()
            if key not in cache:
                try:
                    cache[key] = compile_cell(jax, env, dev, dt, space, obs_dim, cell)
                except SystemExit:
                    raise
                except BaseException as e:  # noqa: BLE001
                    fail_exc("compile", f"compiling the episode of {cell}", e)
            compiled = cache[key]
            send_json(ord("K"), {"compile_s": time.perf_counter() - t0})
        elif tag == ord("B"):
            if compiled is None:
                fail("protocol", "a chunk before any cell")
            try:
                parts = run_chunk(jax, dev, dt, compiled, payload)
            except SystemExit:
                raise
            except BaseException as e:  # noqa: BLE001
                fail_exc("run", "running a chunk", e)
            write_msg(ord("O"), *parts)
        else:
            fail("protocol", f"unexpected message {chr(tag)!r}")


def main():
    tag, payload = read_msg()
    if tag != ord("H"):
        fail("protocol", "expected a hello message")
    hello = json.loads(payload.decode())
    if hello.get("protocol") != PROTOCOL:
        fail("protocol", f"rwg speaks protocol {hello.get('protocol')}, this worker {PROTOCOL}")
    jax, dev, dt, env, fields, space = start(hello)
    send_json(ord("R"), fields)
    serve(jax, dev, dt, env, space, fields["obs_dim"])


try:
    main()
except SystemExit:
    raise
except BaseException as e:  # noqa: BLE001 -- report anything else before exiting
    fail("python", f"the worker failed: {type(e).__name__}: {e}", traceback.format_exc())

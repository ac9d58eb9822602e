#!/usr/bin/env python3
"""Recompute one episode of an rwg JAX env (gymnax:, brax:, jax:) in JAX, without rwg.

    python examples/jax-replay.py RUN_DIR --env gymnax:CartPole-v1 --arch 2HL-4-4 --sample 3 --episode 0
    python examples/jax-replay.py --weights net.json --episode 0 [--precision float32] [--kwargs JSON]
    python examples/jax-replay.py --weights net.json --reset-seed R

With RUN_DIR it asks `rwg replay --export-weights` (rwg on PATH, or --rwg) for the
network's weights and reset seeds, reads the env's kwargs, precisions, device and
lanes from the run, prints the episode's return and length beside the ones in the
cell's scores.csv, and exits 1 if they differ. With --weights (a file of
`rwg replay --export-weights`) the options give what the run would have.

It runs rwg's arithmetic (docs/jax.md, "Keys and policy"): key data [r >> 32,
r & 0xFFFFFFFF]; k_reset, k_steps = split(key); step t uses fold_in(k_steps, t); per
layer x = tanh(W @ concat(x, [1])) (bias) or tanh(W @ x), W @ x as a left-to-right chain
of products and sums for at most 64 inputs (`matvec`); argmax, or high * tanh(y)
for a symmetric box, else low + (tanh(y) + 1) / 2 * (high - low); the return summed
in the precision, the episode ended at the first done or at the time limit; on a CPU,
float32 sin and cos as rwg computes them (`install_sincos`). It runs
them by rwg's own program (`lane_program`: the lanes that never idle), the network's
episodes alone: on the device kind and versions of the run the bits are the run's.
Needs jax, and gymnax or brax for their envs.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import tomllib


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("run_dir", nargs="?", help="an rwg run directory")
    p.add_argument("--env", help="the env id as the manifest writes it (with RUN_DIR)")
    p.add_argument("--arch", help="the architecture's name (with RUN_DIR)")
    p.add_argument("--bias", choices=["true", "false"], help="when the run has both")
    p.add_argument("--sample", type=int, help="the network (with RUN_DIR)")
    p.add_argument("--episode", type=int, help="the episode (index into the reset seeds)")
    p.add_argument("--rwg", default="rwg", help="the rwg binary (with RUN_DIR)")
    p.add_argument("--weights", help="a file written by rwg replay --export-weights")
    p.add_argument("--reset-seed", type=int, help="reset seed (with --weights)")
    p.add_argument("--kwargs", default="{}", help="the env entry's kwargs, as JSON")
    p.add_argument("--max-episode-steps", type=int, help="the time limit (default: the export's)")
    p.add_argument("--precision", default="float32", choices=["float32", "float64"])
    p.add_argument("--device", help='"cpu", "gpu", "gpu:1"... (default: jax.devices()[0])')
    p.add_argument("--matmul-precision", default="highest", choices=["highest", "high", "default"])
    p.add_argument("--lanes", type=int,
                   help="as the run's env.json (default: 512 on a CPU, 65536 otherwise)")
    a = p.parse_args()
    if (a.run_dir is None) == (a.weights is None):
        p.error("give a run directory or --weights FILE, not both")
    if a.run_dir and None in (a.env, a.arch, a.sample, a.episode):
        p.error("with a run directory, give --env, --arch, --sample and --episode")
    if a.weights and (a.episode is None) == (a.reset_seed is None):
        p.error("with --weights, give --episode or --reset-seed")
    return a


def from_run(a):
    """The export of the network, and the run's settings for its env."""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "net.json")
        cmd = [a.rwg, "replay", a.run_dir, "--env", a.env, "--arch", a.arch,
               "--sample", str(a.sample), "--export-weights", path]
        cmd += ["--bias", a.bias] if a.bias else []
        # rwg replay also reruns the network's episodes; only its export is used
        done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if done.returncode != 0:
            sys.exit(f"{' '.join(cmd)} failed:\n{done.stderr}")
        with open(path) as f:
            export = json.load(f)
    with open(os.path.join(a.run_dir, "manifest.toml"), "rb") as f:
        entry = next(e for e in tomllib.load(f)["envs"] if e["id"] == export["env"])
    cell = None
    for d in sorted(os.listdir(os.path.join(a.run_dir, "cells"))):
        with open(os.path.join(a.run_dir, "cells", d, "cell.json")) as f:
            c = json.load(f)
        if (c["env"], c["arch"], c["bias"]) == (export["env"], export["arch"], export["bias"]):
            cell = os.path.join(a.run_dir, "cells", d)
    with open(os.path.join(cell, "env.json")) as f:
        record = json.load(f)["jax"]
    with open(os.path.join(cell, "scores.csv")) as f:
        row = next(r for r in f if r.startswith(f"{a.sample},{a.episode},"))
    stored = row.strip().split(",")[2:4]
    setting = dict(kwargs=entry.get("kwargs", {}), precision=record["precision"],
                   matmul_precision=record["matmul_precision"], device=entry.get("device"),
                   lanes=record["lanes"])
    return export, setting, (float(stored[0]), int(stored[1]))


def make_env(env_id, kwargs, limit):
    """(reset(key) -> (obs, state), step(key, state, action) -> (obs, state, r, done),
    the action space as (n, None, None, None) or (None, low, high, shape), the env's
    own time limit)."""
    source, name = env_id.split(":", 1)
    if source == "brax":
        from brax import envs
        env = envs.get_environment(name, **kwargs)
        reset = lambda k: (lambda s: (s.obs, s))(env.reset(k))  # noqa: E731
        step = lambda k, s, a: (lambda s: (s.obs, s, s.reward, s.done > 0.5))(env.step(s, a))  # noqa: E731,E501
        ones = [1.0] * env.action_size
        return reset, step, (None, [-x for x in ones], ones, (len(ones),)), 1000
    if source == "gymnax":
        import gymnax
        env, params = gymnax.make(name)
        params = params.replace(**kwargs)
        if limit and hasattr(params, "max_steps_in_episode"):  # rwg's time limit, gymnax's too
            params = params.replace(max_steps_in_episode=limit)
    else:
        import importlib
        module, fn = name.rsplit(":", 1)
        env, params = getattr(importlib.import_module(module), fn)(**kwargs)
    raw = getattr(env, "step_env", env.step)
    reset = lambda k: env.reset(k, params)  # noqa: E731

    def step(k, s, a):
        out = raw(k, s, a, params)  # (obs, state, reward, done, info), or with truncated
        return out[:3] + ((out[3] | out[4]) if len(out) == 6 else out[3],)

    space = env.action_space(params)
    if hasattr(space, "n") and not hasattr(space, "low"):
        action = (int(space.n), None, None, None)
    else:
        action = (None, space.low, space.high, tuple(int(s) for s in space.shape))
    return reset, step, action, getattr(params, "max_steps_in_episode", None)


def lane_program(reset, step, act, dtype, T, N, E, L):
    """rwg's compiled program of a cell (docs/jax.md, "Keys and policy"), as
    rwg's worker writes it: N networks x E episodes on L lanes; a lane whose
    episode ended waits until `refill_at` lanes have, or none runs, then every
    waiting lane writes its result and takes the next episode. Every
    per-episode computation has the lanes' shape, so an episode's bits do not
    depend on N or on which lane runs it; they do depend on L (and on this
    exact program: XLA fuses it as a whole)."""
    jnp, lax, tree = jax.numpy, jax.lax, jax.tree_util
    M = N * E
    blocks = -(-M // L)

    def not_finite(x):
        return ~jnp.all(jnp.isfinite(jnp.asarray(x)))

    def bit(cond, b):
        return jnp.where(cond, b, 0).astype(jnp.uint8)

    def reset1(key_data):
        key = jax.random.wrap_key_data(key_data, impl="threefry2x32")
        k_reset, k_steps = jax.random.split(key)
        obs, state = reset(k_reset)
        return obs, state, jax.random.key_data(k_steps), bit(not_finite(obs), 1)

    def step1(Ws, obs, state, k_steps, t):
        a = act(Ws, obs)
        key = jax.random.fold_in(jax.random.wrap_key_data(k_steps, impl="threefry2x32"), t)
        obs, state, r, d = step(key, state, a)
        r = jnp.asarray(r).astype(dtype)
        return obs, state, r, jnp.asarray(d, bool), bit(not_finite(obs), 1) | bit(not_finite(r), 2)

    vreset, vstep = jax.vmap(reset1), jax.vmap(step1)

    def lanes_where(mask, a, b):
        return tree.tree_map(
            lambda x, y: jnp.where(mask.reshape((L,) + (1,) * (x.ndim - 1)), x, y), a, b)

    def resets(keys, total):
        flat = jnp.zeros((blocks * L, 2), jnp.uint32).at[:M].set(keys.reshape(M, 2))
        shape = jax.eval_shape(vreset, flat[:L])
        out = tree.tree_map(lambda s: jnp.zeros((blocks,) + s.shape, s.dtype), shape)

        def one(b, out):
            got = vreset(lax.dynamic_slice_in_dim(flat, b * L, L))
            return tree.tree_map(lambda o, g: o.at[b].set(g), out, got)

        out = lax.fori_loop(0, (total + L - 1) // L, one, out)
        return tree.tree_map(lambda o: o.reshape((blocks * L,) + o.shape[2:]), out)

    def refill(c, Ws, start, total):
        (item, obs, state, ks, t, ret, fault, done, WL, nxt, out) = c
        ended = done & (item < total)
        at = jnp.where(ended, item, blocks * L)
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
        ret = jnp.where(done, jnp.zeros((), dtype), ret)
        fault = jnp.where(take, f0, jnp.where(done, 0, fault).astype(jnp.uint8))
        nxt = jnp.minimum(nxt + jnp.sum(done, dtype=jnp.int32), total)
        return (new, obs, state, ks, t, ret, fault, done & ~take, WL, nxt, out)

    def program(Ws, keys, n, refill_at):
        total = n * E
        start = resets(keys, total)
        obs, state = tree.tree_map(lambda x: x[:L], start[:2])
        out = (jnp.zeros((blocks * L,), dtype), jnp.zeros((blocks * L,), jnp.int32),
               jnp.zeros((blocks * L,), jnp.uint8))
        c = (jnp.full((L,), blocks * L, jnp.int32), obs, state, jnp.zeros((L, 2), jnp.uint32),
             jnp.zeros((L,), jnp.int32), jnp.zeros((L,), dtype), jnp.zeros((L,), jnp.uint8),
             jnp.ones((L,), bool), [jnp.zeros((L,) + W.shape[1:], dtype) for W in Ws],
             jnp.int32(0), out)
        c = refill(c, Ws, start, total)

        def body(lc):
            c, trips = lc
            (item, obs, state, ks, t, ret, fault, done, WL, nxt, out) = c
            obs, state, r, d, f = vstep(WL, obs, state, ks, t)
            run = ~done
            ret = jnp.where(run, ret + r, ret)
            t = jnp.where(run, t + 1, t)
            fault = jnp.where(run, fault | f, fault)
            done = done | (d | (t >= T))
            c = (item, obs, state, ks, t, ret, fault, done, WL, nxt, out)
            waiting = jnp.sum(done & (item < total), dtype=jnp.int32)
            now = (waiting >= refill_at) | jnp.all(done)
            c = lax.cond(now, lambda c: refill(c, Ws, start, total), lambda c: c, c)
            return c, trips + 1

        c, trips = lax.while_loop(lambda lc: jnp.any(lc[0][0] < total), body,
                                  (c, jnp.int32(0)))
        ret, length, fault = (o[:M].reshape(N, E) for o in c[-1])
        return ret, length, fault, trips

    return jax.jit(program)


def replay(export, setting, reset_seed, seeds):
    """(return, length) of the network's episode from `reset_seed`, by rwg's
    program with the run's lanes (the network alone: its episodes are
    `seeds`)."""
    if setting["precision"] == "float64":
        jax.config.update("jax_enable_x64", True)
    dtype = jnp.dtype(setting["precision"])
    reset, step, (n, low, high, shape), limit = make_env(
        export["env"], setting["kwargs"], export.get("max_episode_steps"))
    T = export.get("max_episode_steps") or limit
    bias = export["bias"]
    if n is None:  # the bounds in the action's shape, flat (a scalar bound is broadcast)
        low, high = (np.broadcast_to(np.asarray(b, np.float64), shape).reshape(-1)
                     for b in (low, high))
        symmetric = bool((low == -high).all())
        low, high = jnp.asarray(low, dtype), jnp.asarray(high, dtype)

    def matvec(W, x):
        """W @ x: for at most 64 inputs, ((W[:, 0] * x[0] + W[:, 1] * x[1]) + ...)."""
        if W.shape[1] > 64:
            return W @ x
        acc = W[:, 0] * x[0]
        for k in range(1, W.shape[1]):
            acc = acc + W[:, k] * x[k]
        return acc

    def act(Ws, obs):
        x = jnp.ravel(obs).astype(dtype)
        for W in Ws:
            if bias:
                x = jnp.concatenate([x, jnp.ones((1,), dtype)])
            x = jnp.tanh(matvec(W, x))
        if n is not None:
            return jnp.argmax(x).astype(jnp.int32)
        return (high * x if symmetric else low + (x + 1) / 2 * (high - low)).reshape(shape)

    dev = jax.devices()[0]
    if setting["device"]:
        kind, _, i = setting["device"].partition(":")
        dev = jax.local_devices(backend=kind)[int(i or 0)]
    L = setting["lanes"] or (512 if dev.platform == "cpu" else 65536)
    E = len(seeds)
    Ws = [np.asarray(layer["weights"], np.float64).astype(dtype)[None] for layer in export["layers"]]
    # the key data of reset seed r: uint32 words [r >> 32, r & 0xFFFFFFFF] (numpy, exact)
    words = np.array([[r >> 32, r & 0xFFFFFFFF] for r in seeds], np.uint32).reshape(1, E, 2)
    with jax.default_matmul_precision(setting["matmul_precision"]):
        f = lane_program(reset, step, act, dtype, T, 1, E, L)
        args = jax.device_put((Ws, words, np.int32(1), np.int32(max(1, L // 8))), dev)
        rets, lens, faults, _ = f(*args)
    e = seeds.index(reset_seed)
    rets, lens, faults = np.asarray(rets, np.float64), np.asarray(lens), np.asarray(faults)
    if faults[0, e]:
        what = "observation" if faults[0, e] & 1 else "reward"
        print(f"the episode saw a non-finite {what}", file=sys.stderr)
    return float(rets[0, e]), int(lens[0, e]), dev


def install_sincos(jax):
    """float32 sin and cos on a CPU as rwg's workers lower them: |x| <= 65536
    reduced in float64 to r in [-pi/4, pi/4] (x - k * pi/2, pi/2 in two
    parts), then Cephes' sinf and cosf polynomials of r in float32; any other
    element (beyond, infinite, NaN) by XLA's own lowering (the C library). Where
    this JAX lacks what that needs, rwg's workers keep XLA's own, and so does this."""
    from functools import partial
    try:
        from jax.extend.core import Primitive
        from jax.interpreters import mlir
        mlir._lowerings[jax.lax.sin_p], mlir._lowerings[jax.lax.cos_p], jax.enable_x64
    except (ImportError, AttributeError, KeyError):
        return

    jnp, lax, f32, f64 = jax.numpy, jax.lax, jax.numpy.float32, jax.numpy.float64
    pio2 = (float.fromhex("0x1.921fb544p0"), float.fromhex("0x1.0b4611a626331p-34"))
    sin_c = (-1.6666654611e-1, 8.3321608736e-3, -1.9515295891e-4)
    cos_c = (4.166664568298827e-2, -1.388731625493765e-3, 2.443315711809948e-5)

    def fast(x, cos):
        with jax.enable_x64(True):
            x64 = x.astype(f64)
            k = jnp.round(x64 * f64(0.63661977236758134308))
            r = ((x64 - k * f64(pio2[0])) - k * f64(pio2[1])).astype(f32)
            k = k.astype(jnp.int32)
        z = r * r
        s = r + r * z * (f32(sin_c[0]) + z * (f32(sin_c[1]) + z * f32(sin_c[2])))
        c = f32(1.0) - f32(0.5) * z + z * z * (f32(cos_c[0]) + z * (f32(cos_c[1]) + z * f32(cos_c[2])))
        q = (k + (1 if cos else 0)) & 3
        v = jnp.where((q & 1) == 0, s, c)
        return jnp.where(q >= 2, -v, v)

    for prim, cos in ((lax.sin_p, False), (lax.cos_p, True)):
        xla = mlir._lowerings[prim]
        xla = getattr(xla, "rule", xla)
        libm = Primitive(f"replay_libm_{prim.name}")
        libm.def_abstract_eval(lambda x, **params: x)
        mlir.register_lowering(libm, xla)

        def impl(x, cos=cos, libm=libm, **params):
            out = ~(jnp.abs(x) <= f32(65536.0))
            return lax.cond(jnp.any(out),
                            lambda x: jnp.where(out, libm.bind(x, **params), fast(x, cos)),
                            partial(fast, cos=cos), x)

        def lower(ctx, x, impl=impl, xla=xla, **params):
            if str(ctx.avals_in[0].dtype) == "float32":
                return mlir.lower_fun(partial(impl, **params), multiple_results=False)(ctx, x)
            return xla(ctx, x, **params)

        mlir.register_lowering(prim, lower, platform="cpu")


def main():
    a = parse_args()
    stored = None
    if a.run_dir:
        export, setting, stored = from_run(a)
    else:
        with open(a.weights) as f:
            export = json.load(f)
        if a.max_episode_steps:
            export["max_episode_steps"] = a.max_episode_steps
        setting = dict(kwargs=json.loads(a.kwargs), precision=a.precision,
                       matmul_precision=a.matmul_precision, device=a.device, lanes=a.lanes)
    seeds = list(export["reset_seeds"])
    seed = seeds[a.episode] if a.episode is not None else a.reset_seed
    if seed not in seeds:
        seeds[0] = seed
    ret, length, dev = replay(export, setting, seed, seeds)
    print(f"return {ret!r} length {length} (reset seed {seed}, {setting['precision']}, "
          f"{dev}, jax {jax.__version__})")
    if stored is not None:
        same = stored == (ret, length)
        print(f"scores.csv: return {stored[0]!r} length {stored[1]}: "
              f"{'the same' if same else 'DIFFERENT'}")
        sys.exit(0 if same else 1)


if __name__ == "__main__":
    # XLA as rwg's workers run it: one thread on a CPU, no kernel chosen by timing
    # on a GPU, and from jaxlib 0.6 XLA's older CPU fusion code (unless XLA_FLAGS
    # names these flags)
    import importlib.metadata
    flags = os.environ.get("XLA_FLAGS", "")
    rwg_flags = [("xla_cpu_multi_thread_eigen", "--xla_cpu_multi_thread_eigen=false "
                                                "intra_op_parallelism_threads=1"),
                 ("xla_gpu_deterministic_ops", "--xla_gpu_deterministic_ops=true")]
    try:
        jaxlib = tuple(int(x) for x in importlib.metadata.version("jaxlib").split(".")[:2])
    except (importlib.metadata.PackageNotFoundError, ValueError):
        jaxlib = (0, 0)
    if jaxlib >= (0, 6):
        rwg_flags.append(("xla_cpu_use_fusion_emitters", "--xla_cpu_use_fusion_emitters=false"))
    for name, flag in rwg_flags:
        if name not in flags:
            flags = f"{flags} {flag}".strip()
    os.environ["XLA_FLAGS"] = flags
    import jax
    import jax.numpy as jnp
    import numpy as np
    install_sincos(jax)
    main()

#!/usr/bin/env python3
"""Recompute one episode of an rwg JAX env (gymnax:, brax:, jax:) in JAX, without rwg.

    python examples/jax-replay.py RUN_DIR --env gymnax:CartPole-v1 --arch 2HL-4-4 --sample 3 --episode 0
    python examples/jax-replay.py --weights net.json --episode 0 [--precision float32] [--kwargs JSON]
    python examples/jax-replay.py --weights net.json --reset-seed R

With RUN_DIR it asks `rwg replay --export-weights` (rwg on PATH, or --rwg) for the
network's weights and reset seeds, reads the env's kwargs, precision, device and
networks_per_call from the run, prints the episode's return and length beside the
ones in the cell's scores.csv, and exits 1 if they differ. With --weights (a file of
`rwg replay --export-weights`) the options give what the run would have.

It runs rwg's arithmetic (docs/jax.md, "Keys and policy"): key data [r >> 32,
r & 0xFFFFFFFF]; k_reset, k_steps = split(key); step t uses fold_in(k_steps, t); per
layer x = tanh(W @ concat(x, [1])) (bias) or tanh(W @ x); argmax, or high * tanh(y)
for a symmetric box, else low + (tanh(y) + 1) / 2 * (high - low); the return summed
in the precision, the episode ended at the first done or at the time limit. It
computes at the shape rwg compiles (networks_per_call networks x the cell's episodes,
every network this one), so on the device and versions of the run the bits are the
run's. Needs jax, and gymnax or brax for their envs.
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
    p.add_argument("--networks-per-call", type=int,
                   help="as the run's (default: 256 on a CPU, 4096 otherwise)")
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
                   device=entry.get("device"), networks_per_call=record["networks_per_call"])
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


def replay(export, setting, reset_seed, lanes):
    """(return, length) of the network's episode from `reset_seed`, at rwg's shape."""
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

    def act(Ws, obs):
        x = jnp.ravel(obs).astype(dtype)
        for W in Ws:
            x = jnp.tanh(W @ (jnp.concatenate([x, jnp.ones(1, dtype)]) if bias else x))
        if n is not None:
            return jnp.argmax(x).astype(jnp.int32)
        return (high * x if symmetric else low + (x + 1) / 2 * (high - low)).reshape(shape)

    def not_finite(x):
        return ~jnp.all(jnp.isfinite(jnp.asarray(x)))

    def episode(Ws, key_data):
        key = jax.random.wrap_key_data(key_data, impl="threefry2x32")
        k_reset, k_steps = jax.random.split(key)
        obs, state = reset(k_reset)

        # rwg's fault bits (1: a non-finite observation, 2: reward) are computed and
        # returned as rwg's worker does: without them XLA fuses the program otherwise,
        # and a float64 return can differ in its last bit (a multiply-add contracted).
        fault = jnp.where(not_finite(obs), 1, 0).astype(jnp.uint8)

        def body(c):  # a lane stops at its first done; vmap keeps a stopped lane's values
            obs, state, t, ret, fault, _ = c
            obs, state, r, d = step(jax.random.fold_in(k_steps, t), state, act(Ws, obs))
            r = jnp.asarray(r).astype(dtype)
            fault = fault | jnp.where(not_finite(obs), 1, 0).astype(jnp.uint8)
            fault = fault | jnp.where(not_finite(r), 2, 0).astype(jnp.uint8)
            t = t + 1
            return obs, state, t, ret + r, fault, jnp.asarray(d, bool) | (t >= T)

        c = (obs, state, jnp.int32(0), jnp.zeros((), dtype), fault, jnp.bool_(False))
        _, _, t, ret, fault, _ = jax.lax.while_loop(lambda c: ~c[5], body, c)
        return ret, t, fault

    dev = jax.devices()[0]
    if setting["device"]:
        kind, _, i = setting["device"].partition(":")
        dev = jax.devices(kind)[int(i or 0)]
    N = setting["networks_per_call"] or (256 if dev.platform == "cpu" else 4096)
    Ws = [jnp.broadcast_to(np.asarray(layer["weights"], np.float64).astype(dtype),
                           (N,) + tuple(layer["shape"])) for layer in export["layers"]]
    words = [[r >> 32, r & 0xFFFFFFFF] for r in lanes]
    keys = jnp.broadcast_to(jnp.asarray(words, jnp.uint32), (N, len(lanes), 2))
    f = jax.jit(jax.vmap(jax.vmap(episode, in_axes=(None, 0)), in_axes=(0, 0)))
    rets, lens, faults = f(*jax.device_put((Ws, keys), dev))
    rets, lens = np.asarray(rets, np.float64), np.asarray(lens)
    e = lanes.index(reset_seed)
    if not ((rets[:, e] == rets[0, e]).all() and (lens[:, e] == lens[0, e]).all()):
        sys.exit("the copies of the network disagree: this JAX computes a lane by its place")
    if faults[0, e]:
        what = "observation" if faults[0, e] & 1 else "reward"
        print(f"the episode saw a non-finite {what}", file=sys.stderr)
    return float(rets[0, e]), int(lens[0, e]), dev


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
        setting = dict(kwargs=json.loads(a.kwargs), precision=a.precision, device=a.device,
                       networks_per_call=a.networks_per_call)
    lanes = list(export["reset_seeds"])
    seed = lanes[a.episode] if a.episode is not None else a.reset_seed
    if seed not in lanes:
        lanes[0] = seed
    ret, length, dev = replay(export, setting, seed, lanes)
    print(f"return {ret!r} length {length} (reset seed {seed}, {setting['precision']}, "
          f"{dev}, jax {jax.__version__})")
    if stored is not None:
        same = stored == (ret, length)
        print(f"scores.csv: return {stored[0]!r} length {stored[1]}: "
              f"{'the same' if same else 'DIFFERENT'}")
        sys.exit(0 if same else 1)


if __name__ == "__main__":
    # on a CPU, XLA as rwg's workers run it: one thread (unless XLA_FLAGS is set)
    os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false "
                                       "intra_op_parallelism_threads=1")
    import jax
    import jax.numpy as jnp
    import numpy as np
    main()

"""rwg's JAX worker: runs rwg's policy on a JAX env, one compiled call per chunk.

rwg starts this program through rwg-worker's loader (python -c LOAD WORKER
rwg_pipe PIPE) and speaks the protocol of rwg-jax (framing as
docs/bridge-protocol.md, by rwg_pipe) over the child's stdin/stdout: a hello
(H) naming the env, a cell (C) naming the architecture to compile, chunks (B)
of networks' weights and reset seeds, a flush (F); it answers ready (R),
compiled (K) and chunks' outcomes (O): per episode its return, length and fault
bits. A chunk is dispatched to a device as soon as it is read (JAX runs it
asynchronously) and its outcome written when rwg asks for it: a B message says
how many of the oldest chunks in flight to answer after it, F answers them all,
so the next chunk is on the device while rwg reads the last one's results.
Everything the env prints goes to stderr: rwg_pipe, imported first, keeps
private duplicates of the original stdin/stdout for the protocol and
redirects fd 0/1 before jax is imported.
"""

from rwg_pipe import (  # the pipe first: it redirects fd 0/1
    decode_kwargs,
    fail,
    progress,
    read_msg,
    send_json,
    write_msg,
)
from rwg_jax_worker_common import fail_exc, import_family, version_of
from rwg_jax_worker_trig import install as install_trig
from rwg_jax_worker_families import MAKERS
from rwg_jax_worker_obs import structured
from rwg_jax_worker_policy import check_sizes, describe_spaces
from rwg_jax_worker_episode import compile_cell, dispatch_chunk, fixed_length, outcome

import collections
import json
import os
import struct
import sys
import time
import traceback

PROTOCOL = 1
# XLA's flags rwg sets unless XLA_FLAGS names them: on a CPU one thread (rwg
# runs a worker per thread of its own); on a GPU no choice of kernel by timing
# (autotuning), so two GPUs of one kind run the same program.
RWG_XLA_FLAGS = {
    "xla_cpu_multi_thread_eigen":
        "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
    "xla_gpu_deterministic_ops": "--xla_gpu_deterministic_ops=true",
}
# And from jaxlib 0.6 (XLA aborts on a flag it does not know): on a CPU, XLA's
# older fusion code instead of its MLIR fusion emitters, which compiles rwg's
# programs faster and runs them as fast or faster.
FUSION_EMITTERS = ("xla_cpu_use_fusion_emitters", "--xla_cpu_use_fusion_emitters=false")


def rwg_xla_flags():
    """RWG_XLA_FLAGS, with FUSION_EMITTERS for the jaxlib installed."""
    flags = dict(RWG_XLA_FLAGS)
    try:
        major, minor = (int(x) for x in (version_of("jaxlib") or "0.0").split(".")[:2])
    except ValueError:
        major, minor = 0, 0
    if (major, minor) >= (0, 6):
        flags[FUSION_EMITTERS[0]] = FUSION_EMITTERS[1]
    return flags

# progress() kinds: b"m" importing and making the env, b"c" compiling.


def import_jax(precision, cache_dir):
    """jax, configured for `precision` and the compilation cache before
    anything is traced."""
    flags = os.environ.get("XLA_FLAGS", "")
    for name, flag in rwg_xla_flags().items():
        if name not in flags:
            flags = f"{flags} {flag}".strip()
    os.environ["XLA_FLAGS"] = flags
    try:
        import jax
    except BaseException as e:  # noqa: BLE001
        import importlib.util

        if importlib.util.find_spec("jax") is not None:
            import_family("jax", "jax", "JAX")  # installed but failing: says why
        fail("import", f"jax is not installed for {sys.executable} ({e}); install it with "
                       f"`{sys.executable} -m pip install jax` (CPU) or "
                       f"`{sys.executable} -m pip install \"jax[cuda12]\"` (NVIDIA GPU)",
             traceback.format_exc())
    jax.config.update("jax_enable_x64", precision == "float64")
    if cache_dir:
        # every compiled program is kept: a resume or a shard compiles nothing
        jax.config.update("jax_compilation_cache_dir", cache_dir)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    return jax


def pick_devices(jax, name):
    """The devices a worker runs: for "kind:index" that one; for "kind" (or
    no name: JAX's default kind) every local device of that kind of the
    first one's model."""
    try:
        kind, _, index = (name or "").partition(":")
        devs = jax.local_devices(backend=kind or None)
        if index:
            return [devs[int(index)]]
        return [d for d in devs if d.device_kind == devs[0].device_kind]
    except BaseException as e:  # noqa: BLE001 -- unknown backend, index out of range
        try:
            known = ", ".join(f"{d.platform}:{d.id} ({d.device_kind})" for d in jax.devices())
        except BaseException:  # noqa: BLE001
            known = "none"
        fail("device", f"no JAX device {name!r} ({type(e).__name__}: {e}); this JAX has: {known}")


def action_mask(env, hello):
    """How the policy picks a discrete action, recorded with the cell:
    `legal` (argmax over the legal actions the family gives), `off` (the
    family gives them, the manifest turned them off: plain argmax), `none`
    (the family gives none). Drops the env's legal actions when not used."""
    if env.legal is None or space_is_box(env):
        env.legal = None
        return "none"
    if hello.get("action_mask", True):
        return "legal"
    env.legal = None
    return "off"


def space_is_box(env):
    return hasattr(env.act_space, "low")


def start(hello):
    """Imports, picks the devices, makes the env: (jax, devices, dtype, env, R
    fields, space)."""
    precision = hello.get("precision", "float32")
    if precision not in ("float32", "float64"):
        fail("protocol", f"precision {precision!r}")
    progress(b"m")
    jax = import_jax(precision, hello.get("compile_cache"))
    # float32 sin and cos on a CPU a whole array at a time (rwg's own
    # polynomials, not XLA's bits: jax_trig.py)
    install_trig(jax)
    devs = pick_devices(jax, hello.get("device"))
    dev = devs[0]
    dt = jax.numpy.float64 if precision == "float64" else jax.numpy.float32
    kwargs = {k: decode_kwargs(v) for k, v in (hello.get("kwargs") or {}).items()}
    source, name, max_steps = hello["source"], hello["env"], hello.get("max_episode_steps")
    make = MAKERS.get(source)
    if make is None:
        fail("protocol", f"source {source!r}")
    with jax.default_device(dev):
        env = make(name, kwargs, max_steps, hello.get("package") or source)
        env, described, leaves = structured(jax, env, dt)
    if env.max_steps < 1 or env.max_steps >= 2**31:
        fail("make", f"time limit {env.max_steps}: rwg takes 1 to {2**31 - 1} steps")
    fields, space = describe_spaces(env, int(hello.get("max_obs", 4096)), leaves)
    fields.update({"observation_leaves": described, "action_mask": action_mask(env, hello),
                   "settings": {str(k): str(v) for k, v in env.settings.items()}})
    with jax.default_device(dev):
        check_sizes(jax, env, dt, space, fields["obs_shape"], fields["obs_dim"])
    fields["item_bytes"] = start_bytes(jax, env, dev)
    with jax.default_device(dev):
        env.fixed_length, why = fixed_length(jax, env, dt, space)
    fields["episode_loop"] = {"loop": "plain" if env.fixed_length else "lanes", "why": why}
    import jaxlib

    versions = {"python": sys.version.split()[0], "jax": jax.__version__,
                "jaxlib": getattr(jaxlib, "__version__", None) or version_of("jaxlib")}
    versions.update(env.versions)
    if getattr(env, "source", None):
        fields["source"] = env.source
    fields.update({"max_episode_steps": env.max_steps, "precision": precision,
                   "versions": {k: v for k, v in versions.items() if v is not None},
                   "device": ", ".join(f"{d.platform}:{d.id}" for d in devs),
                   "devices": len(devs), "device_kind": dev.device_kind,
                   "platform": dev.platform, "memory": device_memory(dev)})
    return jax, devs, dt, env, fields, space


def start_bytes(jax, env, dev):
    """Bytes of an episode's start (observation and state), from a trace of
    the env's reset (nothing runs)."""
    import numpy as np

    def reset(key_data):
        return env.reset(jax.random.wrap_key_data(key_data, impl="threefry2x32"))

    try:
        with jax.default_device(dev):
            out = jax.eval_shape(reset, jax.ShapeDtypeStruct((2,), jax.numpy.uint32))
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", "tracing the env's reset", e)
    return sum(int(np.prod(x.shape)) * x.dtype.itemsize for x in jax.tree_util.tree_leaves(out))


def device_memory(dev):
    """The device's memory in bytes as its allocator sees it, or None (a CPU)."""
    try:
        stats = dev.memory_stats() or {}
    except BaseException:  # noqa: BLE001 -- not every backend reports it
        return None
    limit = stats.get("bytes_limit")
    return int(limit) if limit else None


def answer(flight, count):
    """Writes the outcomes of the `count` oldest chunks in flight."""
    for _ in range(min(count, len(flight))):
        try:
            parts = outcome(flight.popleft())
        except SystemExit:
            raise
        except BaseException as e:  # noqa: BLE001
            fail_exc("run", "running a chunk", e)
        write_msg(ord("O"), *parts)


def serve(jax, devs, dt, env, space, obs_dim):
    compiled, cache, flight, sent = None, {}, collections.deque(), 0
    while True:
        tag, payload = read_msg()
        if tag == ord("Q"):
            sys.exit(0)
        if tag == ord("C"):
            if flight:
                fail("protocol", "a cell while chunks are in flight")
            cell = json.loads(payload.decode())
            key = json.dumps(cell, sort_keys=True)
            t0 = time.perf_counter()
            if key not in cache:
                try:
                    cache[key] = compile_cell(jax, env, devs, dt, space, obs_dim, cell)
                except SystemExit:
                    raise
                except BaseException as e:  # noqa: BLE001
                    fail_exc("compile", f"compiling the episode of {cell}", e)
            compiled = cache[key]
            send_json(ord("K"), {"compile_s": time.perf_counter() - t0})
        elif tag == ord("B"):
            if compiled is None:
                fail("protocol", "a chunk before any cell")
            (answers,) = struct.unpack_from("<I", payload, 0)
            try:
                flight.append(dispatch_chunk(jax, dt, compiled, memoryview(payload)[8:], sent))
            except SystemExit:
                raise
            except BaseException as e:  # noqa: BLE001
                fail_exc("run", "running a chunk", e)
            sent += 1
            answer(flight, answers)
        elif tag == ord("F"):
            answer(flight, len(flight))
        else:
            fail("protocol", f"unexpected message {chr(tag)!r}")


def main():
    tag, payload = read_msg()
    if tag != ord("H"):
        fail("protocol", "expected a hello message")
    hello = json.loads(payload.decode())
    if hello.get("protocol") != PROTOCOL:
        fail("protocol", f"rwg speaks protocol {hello.get('protocol')}, this worker {PROTOCOL}")
    jax, devs, dt, env, fields, space = start(hello)
    send_json(ord("R"), fields)
    serve(jax, devs, dt, env, space, fields["obs_dim"])


try:
    main()
except SystemExit:
    raise
except BaseException as e:  # noqa: BLE001 -- report anything else before exiting
    fail("python", f"the worker failed: {type(e).__name__}: {e}", traceback.format_exc())

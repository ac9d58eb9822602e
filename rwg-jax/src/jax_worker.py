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
    progress,
    read_msg,
    send_json,
    write_msg,
)
from rwg_jax_worker_common import fail_exc, import_family, version_of
from rwg_jax_worker_families import MAKERS
from rwg_jax_worker_obs import structured
from rwg_jax_worker_policy import check_sizes, describe_spaces
from rwg_jax_worker_episode import compile_cell, run_chunk

import json
import os
import sys
import time
import traceback

PROTOCOL = 1
# XLA on CPU with one thread: rwg runs one worker per thread of its own.
ONE_THREAD_XLA = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"

# progress() kinds: b"m" importing and making the env, b"c" compiling.


def import_jax(precision):
    """jax, configured for `precision` before anything is traced."""
    os.environ.setdefault("XLA_FLAGS", ONE_THREAD_XLA)
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
    import jaxlib

    versions = {"python": sys.version.split()[0], "jax": jax.__version__,
                "jaxlib": getattr(jaxlib, "__version__", None) or version_of("jaxlib")}
    versions.update(env.versions)
    if getattr(env, "source", None):
        fields["source"] = env.source
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

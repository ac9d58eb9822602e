"""Checks rwg's float32 sin and cos on a CPU (the module named by argv[1]).

- in its range (|x| <= FAST_LIMIT) within 2 units in the last place of the
  exact value, and not XLA's own lowering (which calls the C library);
- beyond it, infinities and NaNs: XLA's own bits;
- an element's value the same whatever else its array holds;
- float64 keeps XLA's own lowering.
Exits non-zero with what failed.
"""

import importlib.util
import sys

import numpy as np
import jax
import jax.numpy as jnp

spec = importlib.util.spec_from_file_location("jax_trig", sys.argv[1])
trig = importlib.util.module_from_spec(spec)
spec.loader.exec_module(trig)

rng = np.random.default_rng(0)
inside = np.concatenate([rng.uniform(-20, 20, 20000), rng.uniform(-trig.FAST_LIMIT, trig.FAST_LIMIT, 20000),
                         [0.0, -0.0, 1e-30, np.pi / 2, -np.pi, trig.FAST_LIMIT, -trig.FAST_LIMIT]])
inside = inside.astype(np.float32)
outside = np.array([np.nextafter(np.float32(trig.FAST_LIMIT), np.float32(np.inf)), -1e5, 3e5, 1e30, -3.4e38,
                    np.inf, -np.inf, np.nan], np.float32)
mixed = np.concatenate([inside, outside])
rng.shuffle(mixed)


def both(x):
    return tuple(np.asarray(a) for a in jax.jit(lambda v: (jnp.sin(v), jnp.cos(v)))(x))


xla = both(mixed)
with jax.enable_x64(True):
    x64 = mixed.astype(np.float64)
    xla64 = both(x64)
trig.install(jax)
ours = both(mixed)
ours_inside = both(inside)
bits = lambda a: np.asarray(a).view(np.uint32 if a.dtype == np.float32 else np.uint64)
failures = []
out = ~(np.abs(mixed) <= trig.FAST_LIMIT)
pos = {float(v): i for i, v in enumerate(inside)}
for name, f, o, x, oi in zip(("sin", "cos"), (np.sin, np.cos), ours, xla, ours_inside):
    if not np.array_equal(bits(o)[out], bits(x)[out]):
        failures.append(f"{name}: beyond {trig.FAST_LIMIT}, infinities, NaNs: not XLA's bits")
    exact = f(mixed[~out].astype(np.float64))
    ulps = np.abs(o[~out].astype(np.float64) - exact) / np.spacing(np.abs(exact).astype(np.float32)).astype(np.float64)
    if not ulps.max() <= 2.0:
        i = int(np.argmax(ulps))
        failures.append(f"{name}({mixed[~out][i]!r}) is {ulps[i]:.2f} ulp off")
    if np.array_equal(bits(o)[~out], bits(x)[~out]):
        failures.append(f"{name}: the same bits as XLA's own lowering everywhere: not installed?")
    # each element as when its array held no element out of range
    alone = np.array([oi[pos[float(v)]] for v in mixed[~out]], np.float32)
    if not np.array_equal(bits(o)[~out], bits(alone)):
        failures.append(f"{name}: an element's value depends on the others in its array")
with jax.enable_x64(True):
    ours64 = both(x64)
for name, a, b in zip(("sin", "cos"), ours64, xla64):
    if not np.array_equal(bits(a), bits(b), equal_nan=False) and not np.array_equal(a, b, equal_nan=True):
        failures.append(f"float64 {name}: not XLA's own lowering")
if failures:
    sys.exit("\n".join(failures))
print("ok")

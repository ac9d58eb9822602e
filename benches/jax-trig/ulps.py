"""How far rwg's float32 sin and cos on a CPU (rwg-jax/src/jax_trig.py) and
XLA's own (the C library's sinf and cosf) are from the exact values, over
every normal float32 x with |x| <= 65,536 (about 2.2 billion values; some
minutes; XLA flushes subnormal values to 0 on a CPU).

    python3 benches/jax-trig/ulps.py

Needs jax and numpy. The exact value is numpy's float64 sin or cos; an error
is in units in the last place (ulp) of the float32 nearest it.
"""

import importlib.util
import os
import sys
import time

os.environ.setdefault("XLA_FLAGS", "--xla_cpu_use_fusion_emitters=false")
import numpy as np  # noqa: E402
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

here = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location(
    "jax_trig", os.path.join(here, "..", "..", "rwg-jax", "src", "jax_trig.py"))
trig = importlib.util.module_from_spec(spec)
spec.loader.exec_module(trig)

CHUNK = 1 << 24
both = jax.jit(lambda v: (jnp.sin(v), jnp.cos(v)))
shape = jax.ShapeDtypeStruct((2 * CHUNK,), jnp.float32)
xla = both.lower(shape).compile()  # compiled before the lowering is replaced
if not trig.install(jax):
    sys.exit("this JAX lacks what rwg's sin and cos need")
rwg = jax.jit(lambda v: (jnp.sin(v), jnp.cos(v))).lower(shape).compile()


def ulps(a, exact):
    return np.abs(a.astype(np.float64) - exact) / np.spacing(
        np.abs(exact).astype(np.float32)).astype(np.float64)


low = int(np.float32(np.finfo(np.float32).tiny).view(np.uint32))
top = int(np.float32(trig.FAST_LIMIT).view(np.uint32))
worst = {}
t0 = time.time()
n = 0
for start in range(low, top + 1, CHUNK):
    # every chunk of CHUNK patterns (the last one padded with the first)
    b = np.arange(start, start + CHUNK, dtype=np.uint64)
    b = np.where(b <= top, b, low).astype(np.uint32).view(np.float32)
    x = np.concatenate([b, -b])
    n += 2 * int(min(CHUNK, top + 1 - start))
    for name, f, ours, theirs in zip(("sin", "cos"), (np.sin, np.cos), rwg(x), xla(x)):
        exact = f(x.astype(np.float64))
        for who, got in (("rwg", ours), ("xla", theirs)):
            u = ulps(np.asarray(got), exact)
            i = int(np.argmax(u))
            if u[i] > worst.get((name, who), (-1.0,))[0]:
                worst[(name, who)] = (float(u[i]), float(x[i]))
print(f"{n} values, {np.finfo(np.float32).tiny:g} <= |x| <= {trig.FAST_LIMIT:g}, {time.time() - t0:.0f} s; "
      f"jax {jax.__version__}, XLA_FLAGS={os.environ['XLA_FLAGS']}")
for (name, who), (u, x) in sorted(worst.items()):
    print(f"{name} {who}: at most {u:.3f} ulp (at x = {x!r})")

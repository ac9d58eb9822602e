"""float32 sin and cos on a CPU as array operations XLA vectorises.

XLA lowers a float32 sin or cos on a CPU to a call of the C library's sinf or
cosf for every element; envs such as Acrobot (38 a step) and Pendulum spend
most of a step there. `install` lowers them instead through `sincos_fast`: a
Cody-Waite reduction to [-pi/4, pi/4] and the minimax polynomials of Cephes'
sinf and cosf (Stephen L. Moshier, Cephes Math Library 2.2), in float32
arithmetic, eight elements an instruction. An element beyond `FAST_LIMIT`, an
infinity or a NaN still gets the C library's value: an array that holds one
computes both and takes, element by element, the C library's for those. So
an element's value never depends on the others in its array (the lanes, the
networks of a call). The values are within 1.6 units in the last place of the
exact ones, the C library's within 0.6 (docs/jax.md): close, but other bits
than XLA's own lowering, and part of rwg's CPU program.

Other dtypes, and every platform but the CPU, keep XLA's own lowering.
"""

# the reduction to the nearest multiple k of pi/2, in float64: pi/2 in two
# parts, the first of 31 significant bits, so that k * PIO2[0] is exact for
# |k| < 2^22
PIO2 = (float.fromhex("0x1.921fb544p0"), float.fromhex("0x1.0b4611a626331p-34"))
TWO_OVER_PI = 0.63661977236758134308
# the fast path's bound (|k| < 2^16)
FAST_LIMIT = 65536.0
# Cephes' sinf and cosf polynomials on [-pi/4, pi/4]
SIN = (-1.6666654611e-1, 8.3321608736e-3, -1.9515295891e-4)
COS = (4.166664568298827e-2, -1.388731625493765e-3, 2.443315711809948e-5)


def sincos_fast(jax, x, cos):
    """sin(x) (cos(x) where `cos`) of a float32 array with every |x| <=
    FAST_LIMIT, elementwise."""
    jnp = jax.numpy
    f32 = jnp.float32
    # float64 arrays inside a float32 program: the reduction only
    with jax.enable_x64(True):
        f64 = jnp.float64
        x64 = x.astype(f64)
        k = jnp.round(x64 * f64(TWO_OVER_PI))
        r = ((x64 - k * f64(PIO2[0])) - k * f64(PIO2[1])).astype(f32)
        k = k.astype(jnp.int32)
    z = r * r
    s = r + r * z * (f32(SIN[0]) + z * (f32(SIN[1]) + z * f32(SIN[2])))
    c = f32(1.0) - f32(0.5) * z + z * z * (f32(COS[0]) + z * (f32(COS[1]) + z * f32(COS[2])))
    # the quadrant: sin x = sin r, cos r, -sin r, -cos r; cos x one quadrant on
    q = (k + (1 if cos else 0)) & 3
    v = jnp.where((q & 1) == 0, s, c)
    return jnp.where(q >= 2, -v, v)


def install(jax):
    """Lowers float32 sin and cos on a CPU through `sincos_fast`, and the
    elements out of its range through XLA's own lowering (the C library).
    False, with XLA's own lowering kept, where this JAX lacks what it needs."""
    from functools import partial

    try:
        from jax.extend.core import Primitive
        from jax.interpreters import mlir

        rules = [(prim, cos, getattr(mlir._lowerings[prim], "rule", mlir._lowerings[prim]))  # noqa: SLF001
                 for prim, cos in ((jax.lax.sin_p, False), (jax.lax.cos_p, True))]
        jax.enable_x64  # noqa: B018 -- the context sincos_fast needs
    except (ImportError, AttributeError, KeyError):
        return False
    jnp, lax = jax.numpy, jax.lax
    for prim, is_cos, xla in rules:
        # the C library's, through XLA's own rule, for the elements out of range
        libm = Primitive(f"rwg_libm_{prim.name}")
        libm.def_abstract_eval(lambda x, **params: x)
        mlir.register_lowering(libm, xla)

        def impl(x, _cos=is_cos, _libm=libm, **params):
            fast = partial(sincos_fast, jax, cos=_cos)
            out = ~(jnp.abs(x) <= jnp.float32(FAST_LIMIT))  # NaN too

            def mixed(x):
                return jnp.where(out, _libm.bind(x, **params), fast(x))

            return lax.cond(jnp.any(out), mixed, fast, x)

        def lower(ctx, x, _impl=impl, _xla=xla, **params):
            if str(ctx.avals_in[0].dtype) == "float32":
                own = mlir.lower_fun(partial(_impl, **params), multiple_results=False)
                return own(ctx, x)
            return _xla(ctx, x, **params)

        mlir.register_lowering(prim, lower, platform="cpu")
    return True

#!/usr/bin/env python3
"""Prints the constants of rwg-core/src/tanh.rs (needs mpmath; run: python3 tanh_constants.py).

- EXP2_HI[j]: 2^(j/64) rounded to the nearest double (as bits); EXP2_TAIL[j]: its relative
  rounding error (2^(j/64) - hi) / hi, rounded to a double.
- L_HI + L_LO = ln(2)/64, L_HI with 40 significant bits (so k * L_HI is exact for k < 2^13);
  INV_L = 64/ln(2).
- EXPM1_C: near-minimax (Chebyshev) coefficients c2..c5 of (e^r - 1 - r)/r^2 on
  |r| <= 1.02 * ln(2)/128; absolute error of r + r^2 * poly(r) about 5e-18 (0.022 ulp of 1).
- TANH_P: near-minimax coefficients p0..p10 of (tanh(x) - x)/x^3 as a polynomial in s = x^2 on
  [0, 0.56^2]; error about 1e-17, i.e. 0.035 ulp of tanh(x) at x = 0.56.
"""
import struct
import mpmath as mp

mp.mp.dps = 60
N = 64


def bits(x):
    return struct.unpack("<Q", struct.pack("<d", x))[0]


def from_bits(b):
    return struct.unpack("<d", struct.pack("<Q", b))[0]


def check_fit(f, lo, hi, coeffs, weight, n=4001):
    worst = mp.mpf(0)
    for i in range(n):
        x = lo + (hi - lo) * mp.mpf(i) / (n - 1)
        approx = sum(mp.mpf(c) * x**k for k, c in enumerate(coeffs))
        worst = max(worst, abs(approx - f(x)) * weight(x))
    return worst


hi, tail = [], []
for j in range(N):
    v = mp.power(2, mp.mpf(j) / N)
    h = float(v)  # mpf -> float rounds to nearest
    hi.append(bits(h))
    tail.append(float((v - mp.mpf(h)) / mp.mpf(h)))

L = mp.log(2) / N
l_hi = from_bits(bits(float(L)) & ~((1 << 13) - 1))
l_lo = float(L - mp.mpf(l_hi))
inv_l = float(N / mp.log(2))

R = mp.log(2) / (2 * N) * mp.mpf("1.02")


def em1(r):
    return (mp.exp(r) - 1 - r) / (r * r) if r != 0 else mp.mpf(1) / 2


c = [float(x) for x in mp.chebyfit(em1, [-R, R], 4)[::-1]]
err_c = check_fit(em1, -R, R, c, lambda r: r * r)

S = mp.mpf("0.56") ** 2


def g(s):
    if s == 0:
        return mp.mpf(-1) / 3
    x = mp.sqrt(s)
    return (mp.tanh(x) - x) / x**3


p = [float(x) for x in mp.chebyfit(g, [0, S], 11)[::-1]]
err_p = check_fit(g, mp.mpf(0), S, p, lambda s: s * mp.sqrt(s) / mp.tanh(mp.sqrt(s)) if s else 0)

print(f"// EXPM1_C max abs error {mp.nstr(err_c, 3)}; TANH_P max rel error {mp.nstr(err_p, 3)}")
print(f"const INV_L: f64 = {inv_l!r};")
print(f"const L_HI: f64 = {l_hi!r};")
print(f"const L_LO: f64 = {l_lo!r};")
print("const EXPM1_C: [f64; 4] = [" + ", ".join(repr(x) for x in c) + "];")
print("const TANH_P: [f64; 11] = [\n" + "".join(f"    {x!r},\n" for x in p) + "];")
print("const EXP2_HI: [u64; 64] = [\n" + "".join(f"    0x{x:016x},\n" for x in hi) + "];")
print("const EXP2_TAIL: [f64; 64] = [\n" + "".join(f"    {x!r},\n" for x in tail) + "];")

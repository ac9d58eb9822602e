"""rwg's policy network in plain Python, bit for bit.

rwg's networks use rwg's own float64 tanh (rwg-core/src/tanh.rs: within 2 ulp
of libm's, no fused multiply-add) and sum each row in order, 0.0 + w0*x0 + ...
(+ the bias weight last). This module does the same operations in the same
order with Python floats, so a network exported by `rwg replay
--export-weights` acts exactly as it did inside rwg, and the env's scores can
be compared bit for bit. (numpy's tanh and matrix products may differ in the
last bit, which is enough to change a continuous-control episode.)
"""

import math
import struct

SMALL = 0.55
CLAMP = 20.0
SHIFT = 6755399441055744.0
INV_L = 92.33248261689366
L_HI = 0.010830424696237628
L_LO = 1.1517191508074686e-14
EXPM1_C = [0.4999999999998384, 0.1666666666666436, 0.041666709040625166, 0.008333339386755335]
TANH_P = [-0.3333333333333333, 0.13333333333332467, -0.05396825396714515, 0.021869488480722565, -0.008863234104802229, 0.003592106586471979, -0.001455632070932804, 0.000588792024475583, -0.0002342148186711548, 8.443719567103072e-05, -2.0141494563083882e-05]
EXP2_HI = [0x3ff0000000000000, 0x3ff02c9a3e778061, 0x3ff059b0d3158574, 0x3ff0874518759bc8, 0x3ff0b5586cf9890f, 0x3ff0e3ec32d3d1a2, 0x3ff11301d0125b51, 0x3ff1429aaea92de0, 0x3ff172b83c7d517b, 0x3ff1a35beb6fcb75, 0x3ff1d4873168b9aa, 0x3ff2063b88628cd6, 0x3ff2387a6e756238, 0x3ff26b4565e27cdd, 0x3ff29e9df51fdee1, 0x3ff2d285a6e4030b, 0x3ff306fe0a31b715, 0x3ff33c08b26416ff, 0x3ff371a7373aa9cb, 0x3ff3a7db34e59ff7, 0x3ff3dea64c123422, 0x3ff4160a21f72e2a, 0x3ff44e086061892d, 0x3ff486a2b5c13cd0, 0x3ff4bfdad5362a27, 0x3ff4f9b2769d2ca7, 0x3ff5342b569d4f82, 0x3ff56f4736b527da, 0x3ff5ab07dd485429, 0x3ff5e76f15ad2148, 0x3ff6247eb03a5585, 0x3ff6623882552225, 0x3ff6a09e667f3bcd, 0x3ff6dfb23c651a2f, 0x3ff71f75e8ec5f74, 0x3ff75feb564267c9, 0x3ff7a11473eb0187, 0x3ff7e2f336cf4e62, 0x3ff82589994cce13, 0x3ff868d99b4492ed, 0x3ff8ace5422aa0db, 0x3ff8f1ae99157736, 0x3ff93737b0cdc5e5, 0x3ff97d829fde4e50, 0x3ff9c49182a3f090, 0x3ffa0c667b5de565, 0x3ffa5503b23e255d, 0x3ffa9e6b5579fdbf, 0x3ffae89f995ad3ad, 0x3ffb33a2b84f15fb, 0x3ffb7f76f2fb5e47, 0x3ffbcc1e904bc1d2, 0x3ffc199bdd85529c, 0x3ffc67f12e57d14b, 0x3ffcb720dcef9069, 0x3ffd072d4a07897c, 0x3ffd5818dcfba487, 0x3ffda9e603db3285, 0x3ffdfc97337b9b5f, 0x3ffe502ee78b3ff6, 0x3ffea4afa2a490da, 0x3ffefa1bee615a27, 0x3fff50765b6e4540, 0x3fffa7c1819e90d8]
EXP2_TAIL = [0.0, -1.507066976926039e-17, 4.9997448722726326e-17, 7.357846871247418e-18, 8.189317638195515e-17, 1.6665881442326747e-18, -7.402825309426177e-17, -6.170654745608695e-17, -2.7939114859515733e-17, 4.776959425256223e-17, 9.341710609905046e-17, 4.585670326662351e-17, 7.826573258636076e-17, 2.823784425951061e-17, 3.2904726646008416e-17, 4.721368121170128e-17, 3.3484623336251524e-17, 5.527550048505249e-17, -6.346552106729483e-17, -1.5456342819397733e-17, 3.750854201303127e-17, -5.346099009198751e-18, 2.1023049675215714e-18, 1.3357510088834541e-17, 1.9572585293112036e-17, -5.478069123926778e-17, -2.1571477251208752e-17, 6.663804589232195e-17, 5.68648095791174e-17, 7.007875046906994e-17, -4.8923067513522756e-17, -6.872303720902018e-17, -6.835808657661922e-17, -8.416011634717156e-18, -2.092304381843353e-17, -3.833464968654295e-17, -2.3591094770850053e-17, 9.50689710108796e-18, -6.735219232374683e-17, -7.226635472101257e-17, 5.1548301170786783e-17, 2.4253985766689806e-17, -6.432131775424189e-18, -6.336161863401293e-17, 1.5341410053603723e-17, -4.123367330661149e-17, -6.152602891550265e-17, 3.540948262646183e-17, 4.875160526227062e-17, -4.719539664590972e-18, -1.0772487078934056e-17, 1.821405440362259e-17, 1.685487290628973e-17, 3.621615935336894e-17, 1.01562190116415e-17, -5.495118966122005e-17, 1.790126907604513e-17, 5.265370768556274e-17, -3.266924100901318e-17, 1.7963932659833022e-17, -5.545065618639427e-17, 5.336805878514151e-17, 4.5784915277060095e-17, 2.0414278897578303e-17]
_MASK = (1 << 64) - 1
_SHIFT_BITS = struct.unpack("<Q", struct.pack("<d", SHIFT))[0]


_FLOATS = {"nan": float("nan"), "inf": float("inf"), "-inf": float("-inf")}


def _decode(v):
    if isinstance(v, dict):
        if len(v) == 1 and "$rwg" in v:
            x = v["$rwg"]
            if isinstance(x, str) and x in _FLOATS:
                return _FLOATS[x]
            return {k: _decode(y) for k, y in x.items()}
        return {k: _decode(y) for k, y in v.items()}
    if isinstance(v, list):
        return [_decode(y) for y in v]
    return v


def gym_kwargs(w):
    """gym.make's keyword arguments of an exported network (its `gym_kwargs`),
    as the run gave them: JSON has no nan or infinities, so the export writes
    such a float as {"$rwg": "nan"} ("inf", "-inf"), and an object whose only
    key is "$rwg" as {"$rwg": {...}}."""
    return {k: _decode(v) for k, v in (w.get("gym_kwargs") or {}).items()}


def _bits(x):
    return struct.unpack("<Q", struct.pack("<d", x))[0]


def _from_bits(b):
    return struct.unpack("<d", struct.pack("<Q", b & _MASK))[0]


def _exp_small(y):
    kd = y * INV_L + SHIFT
    k = (_bits(kd) - _SHIFT_BITS) & _MASK
    kd = kd - SHIFT
    r = (y - kd * L_HI) - kd * L_LO
    j = k & 63
    scale = _from_bits(EXP2_HI[j] + ((k >> 6) << 52))
    r2 = r * r
    c2, c3, c4, c5 = EXPM1_C
    tmp = EXP2_TAIL[j] + r + r2 * (c2 + r * c3) + r2 * r2 * (c4 + r * c5)
    return scale + scale * tmp


def tanh(x):
    """rwg_core::tanh::tanh, bit for bit."""
    a = abs(x)
    if a != a:
        return x
    if a < SMALL:
        s = a * a
        s2 = s * s
        s4 = s2 * s2
        p = TANH_P
        q0 = (p[0] + p[1] * s) + (p[2] + p[3] * s) * s2
        q1 = (p[4] + p[5] * s) + (p[6] + p[7] * s) * s2
        q2 = (p[8] + p[9] * s) + p[10] * s2
        t = a + a * (s * (q0 + (q1 + q2 * s4) * s4))
    else:
        ac = CLAMP if a > CLAMP else a
        t = 1.0 - 2.0 / (_exp_small(2.0 * ac) + 1.0)
    return math.copysign(t, x)


def outputs(layers, bias, obs):
    """The output layer's pre-activations for observation `obs` (floats)."""
    x = [float(v) for v in obs]
    for li, rows in enumerate(layers):
        last = li + 1 == len(layers)
        nx = len(rows[0]) - (1 if bias else 0)
        y = []
        for row in rows:
            s = 0.0
            for w, v in zip(row[:nx], x):
                s += w * v
            if bias:
                s += row[nx]
            y.append(s if last else tanh(s))
        x = y
    return x


def act(export, obs):
    """The action rwg's network takes: an int (Discrete) or a list of floats (Box)."""
    y = outputs([layer["weights"] for layer in export["layers"]], export["bias"], obs)
    space = export["action_space"]
    if space["type"] == "Discrete":
        t = [tanh(v) for v in y]
        return t.index(max(t))
    low, high = space["low"], space["high"]
    if all(lo == -hi for lo, hi in zip(low, high)):
        return [h * tanh(v) for h, v in zip(high, y)]
    return [lo + (tanh(v) + 1.0) / 2.0 * (h - lo) for lo, h, v in zip(low, high, y)]

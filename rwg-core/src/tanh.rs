//! A fast, accurate float64 `tanh` for the policy networks.
//!
//! glibc's `tanh` (fdlibm's, through `expm1`) costs about 15-40 ns a call and
//! dominates the forward pass of networks with hidden layers. [`tanh`] here
//! is branch-free, calls nothing and allocates nothing:
//!
//! - `|x| < 0.55`: `x + x^3 P(x^2)`, `P` a degree-10 near-minimax polynomial
//!   (evaluated by Estrin's scheme), relative approximation error 6.8e-18;
//! - otherwise `1 - 2 / (e^(2|x|) + 1)`, where the result is at least 0.5, so
//!   the subtraction loses nothing; `e^y` is computed as in glibc's `exp`
//!   (`y = (k + r/ln2) ln2/64`, a 64-entry table of `2^(j/64)` with its
//!   rounding error, a degree-5 polynomial for `e^r`), with `|x|` clamped to
//!   20 (where `tanh` is 1 to double precision);
//! - both results are computed and one selected, then the sign of `x`
//!   restored (odd symmetry; `tanh(-0) = -0`, `tanh(NaN) = NaN`,
//!   `tanh(±inf) = ±1`).
//!
//! Accuracy: at most 2 ulp from glibc's `f64::tanh` (itself within about
//! 1 ulp of the exact value). Over 5·10^7 values (|x| < 1.2, < 4, < 25 and
//! 2^-60..1) 80.8 % are bit-identical, 18.6 % differ by 1 ulp and 0.57 %
//! by 2 ulp; the unit tests check the bound on a few million values.
//!
//! It is *not* guaranteed to be monotonic (neither is any libm's), so the
//! policy's argmax does not rely on that ([`crate::policy::argmax_tanh`]).
//! It uses no fused multiply-add, so it gives the same bits on every
//! IEEE-754 platform. It is used only by the policy, never in environment
//! dynamics (which must match Python's libm calls bit for bit).
//!
//! The constants come from `rwg-core/tools/tanh_constants.py` (mpmath).

/// Below this `|x|` the polynomial is used (tanh(0.55) = 0.5005 >= 0.5).
const SMALL: f64 = 0.55;
/// `|x|` is clamped to this before the exponential: tanh(x) rounds to 1 for
/// `|x| > 19.06`.
const CLAMP: f64 = 20.0;
/// `1.5 * 2^52`: adding it rounds a double of magnitude < 2^51 to an integer
/// held in the low mantissa bits.
const SHIFT: f64 = 6755399441055744.0;

/// `64 / ln 2`.
const INV_L: f64 = 92.33248261689366;
/// `ln(2)/64 = L_HI + L_LO`; `L_HI` has 40 significant bits, so `k * L_HI` is exact.
const L_HI: f64 = 0.010830424696237628;
/// See [`L_HI`].
const L_LO: f64 = 1.1517191508074686e-14;
/// `e^r = 1 + r + r^2 (c2 + c3 r + c4 r^2 + c5 r^3)` on `|r| <= ln(2)/128` (abs. error 4.9e-18).
const EXPM1_C: [f64; 4] = [
    0.4999999999998384,
    0.1666666666666436,
    0.041666709040625166,
    0.008333339386755335,
];
/// `tanh(x) = x + x^3 P(x^2)` on `|x| <= 0.56`, `P` of degree 10 (rel. error 6.8e-18).
const TANH_P: [f64; 11] = [
    -0.3333333333333333,
    0.13333333333332467,
    -0.05396825396714515,
    0.021869488480722565,
    -0.008863234104802229,
    0.003592106586471979,
    -0.001455632070932804,
    0.000588792024475583,
    -0.0002342148186711548,
    8.443719567103072e-05,
    -2.0141494563083882e-05,
];
/// `2^(j/64)` rounded to the nearest double, as bits.
const EXP2_HI: [u64; 64] = [
    0x3ff0000000000000,
    0x3ff02c9a3e778061,
    0x3ff059b0d3158574,
    0x3ff0874518759bc8,
    0x3ff0b5586cf9890f,
    0x3ff0e3ec32d3d1a2,
    0x3ff11301d0125b51,
    0x3ff1429aaea92de0,
    0x3ff172b83c7d517b,
    0x3ff1a35beb6fcb75,
    0x3ff1d4873168b9aa,
    0x3ff2063b88628cd6,
    0x3ff2387a6e756238,
    0x3ff26b4565e27cdd,
    0x3ff29e9df51fdee1,
    0x3ff2d285a6e4030b,
    0x3ff306fe0a31b715,
    0x3ff33c08b26416ff,
    0x3ff371a7373aa9cb,
    0x3ff3a7db34e59ff7,
    0x3ff3dea64c123422,
    0x3ff4160a21f72e2a,
    0x3ff44e086061892d,
    0x3ff486a2b5c13cd0,
    0x3ff4bfdad5362a27,
    0x3ff4f9b2769d2ca7,
    0x3ff5342b569d4f82,
    0x3ff56f4736b527da,
    0x3ff5ab07dd485429,
    0x3ff5e76f15ad2148,
    0x3ff6247eb03a5585,
    0x3ff6623882552225,
    0x3ff6a09e667f3bcd,
    0x3ff6dfb23c651a2f,
    0x3ff71f75e8ec5f74,
    0x3ff75feb564267c9,
    0x3ff7a11473eb0187,
    0x3ff7e2f336cf4e62,
    0x3ff82589994cce13,
    0x3ff868d99b4492ed,
    0x3ff8ace5422aa0db,
    0x3ff8f1ae99157736,
    0x3ff93737b0cdc5e5,
    0x3ff97d829fde4e50,
    0x3ff9c49182a3f090,
    0x3ffa0c667b5de565,
    0x3ffa5503b23e255d,
    0x3ffa9e6b5579fdbf,
    0x3ffae89f995ad3ad,
    0x3ffb33a2b84f15fb,
    0x3ffb7f76f2fb5e47,
    0x3ffbcc1e904bc1d2,
    0x3ffc199bdd85529c,
    0x3ffc67f12e57d14b,
    0x3ffcb720dcef9069,
    0x3ffd072d4a07897c,
    0x3ffd5818dcfba487,
    0x3ffda9e603db3285,
    0x3ffdfc97337b9b5f,
    0x3ffe502ee78b3ff6,
    0x3ffea4afa2a490da,
    0x3ffefa1bee615a27,
    0x3fff50765b6e4540,
    0x3fffa7c1819e90d8,
];
/// The relative rounding error of [`EXP2_HI`]: `(2^(j/64) - hi) / hi`.
const EXP2_TAIL: [f64; 64] = [
    0.0,
    -1.507066976926039e-17,
    4.9997448722726326e-17,
    7.357846871247418e-18,
    8.189317638195515e-17,
    1.6665881442326747e-18,
    -7.402825309426177e-17,
    -6.170654745608695e-17,
    -2.7939114859515733e-17,
    4.776959425256223e-17,
    9.341710609905046e-17,
    4.585670326662351e-17,
    7.826573258636076e-17,
    2.823784425951061e-17,
    3.2904726646008416e-17,
    4.721368121170128e-17,
    3.3484623336251524e-17,
    5.527550048505249e-17,
    -6.346552106729483e-17,
    -1.5456342819397733e-17,
    3.750854201303127e-17,
    -5.346099009198751e-18,
    2.1023049675215714e-18,
    1.3357510088834541e-17,
    1.9572585293112036e-17,
    -5.478069123926778e-17,
    -2.1571477251208752e-17,
    6.663804589232195e-17,
    5.68648095791174e-17,
    7.007875046906994e-17,
    -4.8923067513522756e-17,
    -6.872303720902018e-17,
    -6.835808657661922e-17,
    -8.416011634717156e-18,
    -2.092304381843353e-17,
    -3.833464968654295e-17,
    -2.3591094770850053e-17,
    9.50689710108796e-18,
    -6.735219232374683e-17,
    -7.226635472101257e-17,
    5.1548301170786783e-17,
    2.4253985766689806e-17,
    -6.432131775424189e-18,
    -6.336161863401293e-17,
    1.5341410053603723e-17,
    -4.123367330661149e-17,
    -6.152602891550265e-17,
    3.540948262646183e-17,
    4.875160526227062e-17,
    -4.719539664590972e-18,
    -1.0772487078934056e-17,
    1.821405440362259e-17,
    1.685487290628973e-17,
    3.621615935336894e-17,
    1.01562190116415e-17,
    -5.495118966122005e-17,
    1.790126907604513e-17,
    5.265370768556274e-17,
    -3.266924100901318e-17,
    1.7963932659833022e-17,
    -5.545065618639427e-17,
    5.336805878514151e-17,
    4.5784915277060095e-17,
    2.0414278897578303e-17,
];

/// `e^y` for `0 <= y <= 40` (or NaN), within about 0.51 ulp.
#[inline(always)]
fn exp_small(y: f64) -> f64 {
    let kd = y * INV_L + SHIFT;
    let k = kd.to_bits().wrapping_sub(SHIFT.to_bits());
    let kd = kd - SHIFT;
    // y = kd * ln2/64 + r, |r| <= ln2/128
    let r = (y - kd * L_HI) - kd * L_LO;
    let j = (k & 63) as usize;
    // 2^(k/64) = 2^(k >> 6) * 2^(j/64); k <= 3694, so the exponent stays small.
    let scale = f64::from_bits(EXP2_HI[j].wrapping_add((k >> 6) << 52));
    let r2 = r * r;
    let [c2, c3, c4, c5] = EXPM1_C;
    let tmp = EXP2_TAIL[j] + r + r2 * (c2 + r * c3) + r2 * r2 * (c4 + r * c5);
    scale + scale * tmp
}

/// The hyperbolic tangent, within 2 ulp of `f64::tanh` (see the module docs).
#[inline]
pub fn tanh(x: f64) -> f64 {
    let a = x.abs();
    // |x| < SMALL: a + a^3 P(a^2), P by Estrin's scheme.
    let s = a * a;
    let s2 = s * s;
    let s4 = s2 * s2;
    let p = &TANH_P;
    let q0 = (p[0] + p[1] * s) + (p[2] + p[3] * s) * s2;
    let q1 = (p[4] + p[5] * s) + (p[6] + p[7] * s) * s2;
    let q2 = (p[8] + p[9] * s) + p[10] * s2;
    let small = a + a * (s * (q0 + (q1 + q2 * s4) * s4));
    // |x| >= SMALL: 1 - 2/(e^2a + 1). NaN passes the clamp (the comparison is false).
    let ac = if a > CLAMP { CLAMP } else { a };
    let big = 1.0 - 2.0 / (exp_small(2.0 * ac) + 1.0);
    let t = if a < SMALL { small } else { big };
    t.copysign(x)
}

/// [`tanh`] of every element of `x`, bit for bit, written element-wise op by
/// op so that the compiler turns each step into SIMD instructions (the table
/// lookups stay scalar). Used by the policy's side-by-side lanes
/// ([`crate::policy::PolicyLanes`]).
#[inline(always)]
pub fn tanh_lanes<const K: usize>(x: [f64; K]) -> [f64; K] {
    let a = x.map(f64::abs);
    let mut small = [0.0; K];
    let p = &TANH_P;
    for l in 0..K {
        let s = a[l] * a[l];
        let s2 = s * s;
        let s4 = s2 * s2;
        let q0 = (p[0] + p[1] * s) + (p[2] + p[3] * s) * s2;
        let q1 = (p[4] + p[5] * s) + (p[6] + p[7] * s) * s2;
        let q2 = (p[8] + p[9] * s) + p[10] * s2;
        small[l] = a[l] + a[l] * (s * (q0 + (q1 + q2 * s4) * s4));
    }
    // exp_small(2 * clamp(a)), one step at a time.
    let mut y = [0.0; K];
    for l in 0..K {
        y[l] = 2.0 * (if a[l] > CLAMP { CLAMP } else { a[l] });
    }
    let mut kd = [0.0; K];
    let mut k = [0u64; K];
    for l in 0..K {
        kd[l] = y[l] * INV_L + SHIFT;
        k[l] = kd[l].to_bits().wrapping_sub(SHIFT.to_bits());
        kd[l] -= SHIFT;
    }
    let mut r = [0.0; K];
    for l in 0..K {
        r[l] = (y[l] - kd[l] * L_HI) - kd[l] * L_LO;
    }
    let mut scale = [0.0; K];
    let mut tail = [0.0; K];
    for l in 0..K {
        let j = (k[l] & 63) as usize;
        scale[l] = f64::from_bits(EXP2_HI[j].wrapping_add((k[l] >> 6) << 52));
        tail[l] = EXP2_TAIL[j];
    }
    let [c2, c3, c4, c5] = EXPM1_C;
    let mut out = [0.0; K];
    for l in 0..K {
        let r2 = r[l] * r[l];
        let tmp = tail[l] + r[l] + r2 * (c2 + r[l] * c3) + r2 * r2 * (c4 + r[l] * c5);
        let big = 1.0 - 2.0 / ((scale[l] + scale[l] * tmp) + 1.0);
        let t = if a[l] < SMALL { small[l] } else { big };
        out[l] = t.copysign(x[l]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in ulps between two finite doubles (0 for two NaNs).
    fn ulps(a: f64, b: f64) -> u64 {
        if a.is_nan() && b.is_nan() {
            return 0;
        }
        let key = |x: f64| {
            let i = x.to_bits() as i64;
            if i < 0 {
                i64::MIN - i
            } else {
                i
            }
        };
        (key(a) - key(b)).unsigned_abs()
    }

    /// Max ulp distance to `f64::tanh` over `n` pseudo-random values of
    /// magnitude up to `scale` (uniform) or log-uniform below 1.
    fn max_ulps(n: usize, seed: u64, value: impl Fn(f64, u64) -> f64) -> (u64, f64) {
        let mut s = seed;
        let mut worst = (0, 0.0);
        for _ in 0..n {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (s >> 11) as f64 / (1u64 << 53) as f64;
            let x = value(u * 2.0 - 1.0, s);
            let d = ulps(tanh(x), x.tanh());
            if d > worst.0 {
                worst = (d, x);
            }
        }
        worst
    }

    #[test]
    fn within_2_ulp_of_libm() {
        let ranges: [(&str, f64); 5] = [
            ("|x| < 0.6", 0.6),
            ("|x| < 1.2", 1.2),
            ("|x| < 4", 4.0),
            ("|x| < 25", 25.0),
            ("|x| < 700", 700.0),
        ];
        for (k, (name, scale)) in ranges.into_iter().enumerate() {
            let (d, x) = max_ulps(400_000, k as u64 + 1, |v, _| v * scale);
            assert!(d <= 2, "{name}: {d} ulp at x = {x:?}");
        }
        // Log-uniform magnitudes from 2^-80 to 1.
        let (d, x) = max_ulps(400_000, 99, |v, s| v * 2f64.powi(-(((s >> 3) % 80) as i32)));
        assert!(d <= 2, "small |x|: {d} ulp at x = {x:?}");
        // Around the switch between the two formulas.
        let (d, x) = max_ulps(200_000, 7, |v, _| SMALL + v * 1e-3);
        assert!(d <= 2, "near {SMALL}: {d} ulp at x = {x:?}");
    }

    #[test]
    fn special_values() {
        assert_eq!(tanh(0.0).to_bits(), 0.0f64.to_bits());
        assert_eq!(tanh(-0.0).to_bits(), (-0.0f64).to_bits());
        assert!(tanh(f64::NAN).is_nan());
        assert_eq!(tanh(f64::INFINITY), 1.0);
        assert_eq!(tanh(f64::NEG_INFINITY), -1.0);
        assert_eq!(tanh(f64::MAX), 1.0);
        assert_eq!(tanh(-19.1), -1.0);
        assert_eq!(tanh(19.0), 19.0f64.tanh());
        for x in [1e-310, -5e-324, 1e-300, 2.0f64.powi(-30)] {
            assert_eq!(tanh(x), x, "{x:?}");
        }
    }

    #[test]
    fn lanes_equal_scalar() {
        let mut s: u64 = 11;
        for _ in 0..20_000 {
            let x: [f64; 8] = std::array::from_fn(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let u = (s >> 11) as f64 / (1u64 << 53) as f64;
                (u * 2.0 - 1.0) * [0.7, 3.0, 30.0][(s % 3) as usize]
            });
            let t = tanh_lanes(x);
            for l in 0..8 {
                assert_eq!(t[l].to_bits(), tanh(x[l]).to_bits(), "{:?}", x[l]);
            }
        }
        let special = [
            0.0,
            -0.0,
            f64::NAN,
            f64::INFINITY,
            -1e-310,
            SMALL,
            -CLAMP,
            1e300,
        ];
        let t = tanh_lanes(special);
        for l in 0..8 {
            assert_eq!(
                t[l].to_bits(),
                tanh(special[l]).to_bits(),
                "{:?}",
                special[l]
            );
        }
    }

    #[test]
    fn odd_symmetry() {
        for x in [0.1, 0.55, 0.549999, 1.0, 3.3, 18.0] {
            assert_eq!(tanh(-x), -tanh(x));
        }
    }
}

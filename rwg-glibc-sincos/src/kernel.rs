//! Derived from glibc's `sysdeps/ieee754/dbl-64/s_sin.c` (IBM Accurate
//! Mathematical Library, written by International Business Machines Corp.;
//! Copyright (C) 2001-2022 Free Software Foundation, Inc.), under the GNU
//! Lesser General Public License 2.1 or (at your option) any later version:
//! see the crate's `COPYING`.
//!
//! The operations of glibc 2.36's x86-64 `__sin_fma` and `__cos_fma` (the
//! variants its `sin`/`cos` ifuncs pick on CPUs with AVX2 and FMA), for
//! |x| < 105414350, written once over the vector operations of the trait
//! [`Lanes`]: `fma.rs` implements it for four AVX2+FMA lanes (`__m256d`),
//! `avx512.rs` for eight AVX-512 lanes (`__m512d`). Every method is one IEEE
//! operation per lane (or an exact bit operation), so both run the same
//! roundings in the same order and give the same bits; they differ only in
//! masks, table reads and loads.
//!
//! glibc compiles `sysdeps/ieee754/dbl-64/s_sin.c` for that variant with
//! `-mfma -mavx2`, so GCC fused some products into the following additions.
//! Which ones was read off the machine code of `__sin_fma`/`__cos_fma` in
//! Debian 12's libm (2.36-9): every `fmadd`/`fnmadd`/`fmsub` below stands
//! where that code has a fused instruction, every `mul` + `add` where it has
//! two; the constants are the bits that code loads. Rust never fuses by
//! itself, so these are exactly the roundings glibc performs.
//!
//! Paths (k = |x|, as glibc tests the high word; sin / cos):
//! - k < 2^-26 / 2^-27: `x` / `1.0`;
//! - k < 0.855469: `do_sin(x, 0)` / `do_cos(x, 0)`; `do_sin` is a Taylor
//!   polynomial when |a| < 0.126, else a table lookup at the nearest k/128;
//! - k < 2.426265: sin = `copysign(do_cos(pi/2 - |x|, hp1), x)`, cos =
//!   `do_sin(a, da)` with `a + da` = pi/2 - |x| split in two;
//! - k < 105414350: the three-constant reduction by pi/2 to `(a, da, n)`,
//!   then `do_sin` or `do_cos` by quadrant, negated in quadrants 2 and 3.
//!
//! Lanes beyond (huge, ±inf, NaN) are flagged for the caller, which computes
//! them with libm. Lanes on different paths are all computed and blended; a
//! kernel no lane needs is skipped.
//!
//! The functions here are `#[inline(always)]` generics without target
//! features of their own: they are compiled inside the entry points of
//! `fma.rs` / `avx512.rs` (`entry_points!`), which carry the instruction
//! set, so the trait's methods inline into them.

pub(crate) const SIGN: f64 = -0.0;
const BIG: f64 = f64::from_bits(0x42c8_0000_0000_0000); // 1.5 * 2^45
const TOINT: f64 = f64::from_bits(0x4338_0000_0000_0000); // 1.5 * 2^52
const HPINV: f64 = f64::from_bits(0x3fe4_5f30_6dc9_c883); // 2/pi
const HP0: f64 = f64::from_bits(0x3ff9_21fb_5444_2d18); // pi/2, high
const HP1: f64 = f64::from_bits(0x3c91_a626_3314_5c07); // pi/2, low
const MP1: f64 = f64::from_bits(0x3ff9_21fb_5800_0000);
const MP2: f64 = f64::from_bits(0xbe4d_de97_3c00_0000);
const PP3: f64 = f64::from_bits(0xbc8c_b3b3_9800_0000);
const PP4: f64 = f64::from_bits(0xbacd_747f_23e3_2ed7);
// Taylor polynomial of sin (|a| < 0.126).
const S1: f64 = f64::from_bits(0xbfc5_5555_5555_5555);
const S2: f64 = f64::from_bits(0x3f81_1111_1111_0ece);
const S3: f64 = f64::from_bits(0xbf2a_01a0_19db_08b8);
const S4: f64 = f64::from_bits(0x3ec7_1de2_7b9a_7ed9);
const S5: f64 = f64::from_bits(0xbe5a_ddff_c2fc_df59);
// sin and cos of the small remainder beside a table point.
const SN3: f64 = f64::from_bits(0xbfc5_5555_5555_5515);
const SN5: f64 = f64::from_bits(0x3f81_1110_e829_872f);
const CS2: f64 = 0.5;
const CS4: f64 = f64::from_bits(0xbfa5_5555_5555_5535);
const CS6: f64 = f64::from_bits(0x3f56_c16b_edd9_e239);
const TAYLOR_MAX: f64 = f64::from_bits(0x3fc0_20c4_9ba5_e354); // 0.126

// Path limits on |x|: glibc compares the high word, i.e. |x| < these.
const SIN_TINY: f64 = f64::from_bits(0x3e50_0000_0000_0000); // 2^-26
const COS_TINY: f64 = f64::from_bits(0x3e40_0000_0000_0000); // 2^-27
const SMALL: f64 = f64::from_bits(0x3feb_6000_0000_0000); // 0.85546875
const MID: f64 = f64::from_bits(0x4003_68fd_0000_0000); // 2.426265...
/// Above this (and for ±inf, NaN) glibc uses `__branred`: libm's job here.
const REDUCE: f64 = f64::from_bits(0x4199_21fb_0000_0000); // 105414350.0...

/// The largest table index a valid lane reads (k/128 for |a| < 0.855469).
pub(crate) const TABLE_MAX_K: i64 = 109;

/// The vector operations the port is written in: `Self` holds one `f64`
/// per lane, [`Lanes::I`] one 64-bit integer per lane, [`Lanes::M`] one
/// truth value per lane. Every floating-point method is one IEEE operation
/// (rounded to nearest) per lane, so an implementation changes no bits.
/// The methods are `unsafe` only because they are compiled for their
/// instruction set.
pub(crate) trait Lanes: Copy {
    /// Lanes per vector.
    const N: usize;
    /// Per-lane truth values (a comparison's result).
    type M: Copy;
    /// 64-bit integers, one per lane.
    type I: Copy;

    /// `v` in every lane.
    unsafe fn splat(v: f64) -> Self;
    /// `self + b`.
    unsafe fn add(self, b: Self) -> Self;
    /// `self - b`.
    unsafe fn sub(self, b: Self) -> Self;
    /// `self * b`.
    unsafe fn mul(self, b: Self) -> Self;
    /// `self * b + c`, rounded once.
    unsafe fn fmadd(self, b: Self, c: Self) -> Self;
    /// `self * b - c`, rounded once.
    unsafe fn fmsub(self, b: Self, c: Self) -> Self;
    /// `c - self * b`, rounded once.
    unsafe fn fnmadd(self, b: Self, c: Self) -> Self;
    /// `|self|` (the sign bit cleared).
    unsafe fn abs(self) -> Self;
    /// `-self` (the sign bit flipped).
    unsafe fn neg(self) -> Self;
    /// `copysign(self, sign)`.
    unsafe fn copysign(self, sign: Self) -> Self;
    /// `self < b` (false for NaN).
    unsafe fn lt(self, b: Self) -> Self::M;
    /// `self <= b` (false for NaN).
    unsafe fn le(self, b: Self) -> Self::M;
    /// `self == b` (false for NaN).
    unsafe fn eq(self, b: Self) -> Self::M;
    /// `m ? b : self` per lane.
    unsafe fn pick(self, b: Self, m: Self::M) -> Self;
    /// No lane.
    unsafe fn none() -> Self::M;
    /// `a && b`.
    unsafe fn and_m(a: Self::M, b: Self::M) -> Self::M;
    /// `a || b`.
    unsafe fn or_m(a: Self::M, b: Self::M) -> Self::M;
    /// `!a && b`.
    unsafe fn andnot_m(a: Self::M, b: Self::M) -> Self::M;
    /// Bit `i` set for lane `i` of `m`.
    unsafe fn bits(m: Self::M) -> u32;
    /// The bits of each lane.
    unsafe fn to_bits(self) -> Self::I;
    /// Lanes where `n & bit != 0` (`bit` a single bit).
    unsafe fn bit_set(n: Self::I, bit: i64) -> Self::M;
    /// `n + v`, wrapping.
    unsafe fn add_i(n: Self::I, v: i64) -> Self::I;
    /// The table entries `[sn, ssn, cs, ccs]` at `k = low 32 bits of u`,
    /// `u = BIG + |a|`, with `k` clamped into `0..=TABLE_MAX_K` (lanes that
    /// are not on a table path may hold anything).
    unsafe fn lookup(u: Self) -> [Self; 4];
    /// `x` (at most `N` elements) in the first lanes, zeros in the rest.
    unsafe fn load(x: &[f64]) -> Self;
    /// The first `out.len()` (at most `N`) lanes into `out`.
    unsafe fn store(self, out: &mut [f64]);
}

/// `TAYLOR_SIN(a * a, a, da)`.
#[inline(always)]
unsafe fn taylor_sin<V: Lanes>(a: V, da: V) -> V {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point's) guarantees.
    unsafe {
        let xx = a.mul(a);
        let mut p = xx.fmadd(V::splat(S5), V::splat(S4));
        p = xx.fmadd(p, V::splat(S3));
        p = xx.fmadd(p, V::splat(S2));
        p = xx.fmadd(p, V::splat(S1));
        let q = p.fmsub(a, da.mul(V::splat(0.5)));
        a.add(xx.fmadd(q, da))
    }
}

/// `BIG + |a|`: its low bits index the table.
#[inline(always)]
unsafe fn table_key<V: Lanes>(a: V) -> V {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point's) guarantees.
    unsafe { a.abs().add(V::splat(BIG)) }
}

/// `do_sin(a, da)` for |a| >= 0.126 (the table path); `u = table_key(a)`,
/// `rows = lookup(u)`.
#[inline(always)]
unsafe fn sin_table<V: Lanes>(a: V, da: V, u: V, rows: [V; 4]) -> V {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point's) guarantees.
    unsafe {
        let le0 = a.le(V::splat(0.0));
        let dx = da.pick(da.neg(), le0);
        let x = a.abs().sub(u.sub(V::splat(BIG)));
        let xx = x.mul(x);
        let p = xx.fmadd(V::splat(SN5), V::splat(SN3));
        let s = x.add(x.mul(xx).fmadd(p, dx));
        let q = xx.fmadd(xx.fmadd(V::splat(CS6), V::splat(CS4)), V::splat(CS2));
        let c = x.fmadd(dx, xx.mul(q));
        let [sn, ssn, cs, ccs] = rows;
        let cor = s.fmadd(cs, c.fnmadd(sn, s.fmadd(ccs, ssn)));
        sn.add(cor).copysign(a)
    }
}

/// `do_sin(a, da)`: Taylor below 0.126, the table above (both computed:
/// a branch on the lanes' mix would be mispredicted often).
#[inline(always)]
unsafe fn do_sin<V: Lanes>(a: V, da: V, u: V, rows: [V; 4]) -> V {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point's) guarantees.
    unsafe {
        let taylor = a.abs().lt(V::splat(TAYLOR_MAX));
        sin_table(a, da, u, rows).pick(taylor_sin(a, da), taylor)
    }
}

/// `do_cos(a, da)`; `u = table_key(a)`, `rows = lookup(u)`.
#[inline(always)]
unsafe fn do_cos<V: Lanes>(a: V, da: V, u: V, rows: [V; 4]) -> V {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point's) guarantees.
    unsafe {
        let lt0 = a.lt(V::splat(0.0));
        let dx = da.pick(da.neg(), lt0);
        let x = a.abs().sub(u.sub(V::splat(BIG))).add(dx);
        let xx = x.mul(x);
        let p = xx.fmadd(V::splat(SN5), V::splat(SN3));
        let s = x.mul(xx).fmadd(p, x);
        let q = xx.fmadd(xx.fmadd(V::splat(CS6), V::splat(CS4)), V::splat(CS2));
        let c = xx.mul(q);
        let [sn, ssn, cs, ccs] = rows;
        let cor = s.fnmadd(sn, c.fnmadd(cs, s.fnmadd(ssn, ccs)));
        cs.add(cor)
    }
}

/// `reduce_sincos(x)`: `(a, da, n)` with `a + da` = x - n pi/2 (n mod 4 as
/// the low bits of the returned integer lanes).
#[inline(always)]
unsafe fn reduce<V: Lanes>(x: V) -> (V, V, V::I) {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point's) guarantees.
    unsafe {
        let t = x.fmadd(V::splat(HPINV), V::splat(TOINT));
        let xn = t.sub(V::splat(TOINT));
        let y = xn.fnmadd(V::splat(MP1), x);
        let y = xn.fnmadd(V::splat(MP2), y);
        let t2 = xn.fnmadd(V::splat(PP3), y);
        let db = xn.fnmadd(V::splat(PP3), y.sub(t2));
        let b = xn.fnmadd(V::splat(PP4), t2);
        let db = db.add(xn.fnmadd(V::splat(PP4), t2.sub(b)));
        (b, db, t.to_bits())
    }
}

/// sin and/or cos of `V::N` lanes, and the mask (bit `i` for lane `i`) of
/// lanes left to libm (|x| >= 105414350, inf, NaN), whose results here are
/// meaningless.
#[inline(always)]
unsafe fn eval<V: Lanes, const SIN: bool, const COS: bool>(x: V) -> (V, V, u32) {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point's) guarantees.
    unsafe {
        let all = (1u32 << V::N) - 1;
        let zero = V::splat(0.0);
        let ax = x.abs();
        let ok = ax.lt(V::splat(REDUCE));
        let small = ax.lt(V::splat(SMALL));
        let below_mid = ax.lt(V::splat(MID));
        let mid = V::andnot_m(small, below_mid);
        let red = V::andnot_m(below_mid, ok);

        // Arguments of do_sin (sa, sda) and do_cos (ca, cda) per lane.
        let (mut sa, mut sda, mut ca, mut cda) = (x, zero, x, zero);
        let (mut sin_c, mut cos_c) = (mid, small);
        let (mut sin_neg, mut cos_neg) = (V::none(), V::none());
        // Middle path (computed whatever the lanes: cheaper than a branch).
        // sin: do_cos(hp0 - |x|, hp1); cos: do_sin of that, split in two.
        let t = V::splat(HP0).sub(ax);
        ca = ca.pick(t, mid);
        cda = cda.pick(V::splat(HP1), mid);
        if COS {
            let a = t.add(V::splat(HP1));
            let da = t.sub(a).add(V::splat(HP1));
            sa = sa.pick(a, mid);
            sda = sda.pick(da, mid);
        }
        if V::bits(red) != 0 {
            let (a, da, n) = reduce(x);
            sa = sa.pick(a, red);
            sda = sda.pick(da, red);
            ca = ca.pick(a, red);
            cda = cda.pick(da, red);
            let odd = V::and_m(V::bit_set(n, 1), red);
            sin_c = V::or_m(sin_c, odd);
            cos_c = V::or_m(cos_c, V::andnot_m(odd, red));
            sin_neg = V::and_m(V::bit_set(n, 2), red);
            cos_neg = V::and_m(V::bit_set(V::add_i(n, 1), 2), red);
        }

        // Which kernels some wanted lane needs.
        let mut need_s = V::none();
        let mut need_c = V::none();
        if SIN {
            need_s = V::or_m(need_s, V::andnot_m(sin_c, ok));
            need_c = V::or_m(need_c, V::and_m(sin_c, ok));
        }
        if COS {
            need_s = V::or_m(need_s, V::andnot_m(cos_c, ok));
            need_c = V::or_m(need_c, V::and_m(cos_c, ok));
        }
        // One table lookup when both kernels read the same rows (the usual case
        // when both run: the same argument, or pi/2 - |x| and its split).
        let (us, uc) = (table_key(sa), table_key(ca));
        let (run_s, run_c) = (V::bits(need_s) != 0, V::bits(need_c) != 0);
        let (ks, kc) = match (run_s, run_c) {
            (true, false) => (do_sin(sa, sda, us, V::lookup(us)), zero),
            (false, true) => (zero, do_cos(ca, cda, uc, V::lookup(uc))),
            (false, false) => (zero, zero),
            (true, true) => {
                let rs = V::lookup(us);
                let rc = if V::bits(us.eq(uc)) == all {
                    rs
                } else {
                    V::lookup(uc)
                };
                (do_sin(sa, sda, us, rs), do_cos(ca, cda, uc, rc))
            }
        };

        let mut s = zero;
        if SIN {
            s = ks.pick(kc, sin_c);
            s = s.pick(s.copysign(x), mid);
            s = s.pick(s.neg(), sin_neg);
            s = s.pick(x, ax.lt(V::splat(SIN_TINY)));
        }
        let mut c = zero;
        if COS {
            c = ks.pick(kc, cos_c);
            c = c.pick(c.neg(), cos_neg);
            c = c.pick(V::splat(1.0), ax.lt(V::splat(COS_TINY)));
        }
        (s, c, !V::bits(ok) & all)
    }
}

/// sin (if `SIN`) and cos (if `COS`) of every element of `x` into `sin` /
/// `cos` (the one not asked for may be empty), `V::N` lanes at a time, the
/// tail zero-padded; lanes beyond the vector range through `libm_sin` /
/// `libm_cos`.
#[inline(always)]
pub(crate) unsafe fn run<V: Lanes, const SIN: bool, const COS: bool>(
    x: &[f64],
    sin: &mut [f64],
    cos: &mut [f64],
    libm_sin: fn(f64) -> f64,
    libm_cos: fn(f64) -> f64,
) {
    assert!((!SIN || sin.len() == x.len()) && (!COS || cos.len() == x.len()));
    let mut i = 0;
    while i < x.len() {
        let n = (x.len() - i).min(V::N);
        // SAFETY: `n <= V::N` elements, on a CPU with `V`'s instruction set
        // (the caller's guarantee).
        let (s, c, bad) = unsafe { eval::<V, SIN, COS>(V::load(&x[i..i + n])) };
        if SIN {
            // SAFETY: as above.
            unsafe { s.store(&mut sin[i..i + n]) };
        }
        if COS {
            // SAFETY: as above.
            unsafe { c.store(&mut cos[i..i + n]) };
        }
        if bad != 0 {
            for l in (0..n).filter(|l| bad >> l & 1 == 1) {
                if SIN {
                    sin[i + l] = libm_sin(x[i + l]);
                }
                if COS {
                    cos[i + l] = libm_cos(x[i + l]);
                }
            }
        }
        i += n;
    }
}

/// The three public entry points over the lane type `$v`, compiled for the
/// target features `$features`, whose documentation names `$cpu`.
macro_rules! entry_points {
    ($v:ty, $features:literal, $cpu:literal) => {
        /// `out[i] = sin(x[i])`, lanes beyond the vector range through
        /// `libm_sin`.
        ///
        /// # Safety
        #[doc = concat!("The CPU must support ", $cpu, ".")]
        #[inline]
        #[target_feature(enable = $features)]
        pub unsafe fn sin_lanes(x: &[f64], out: &mut [f64], libm_sin: fn(f64) -> f64) {
            // SAFETY: this function's target features are `$v`'s.
            unsafe { $crate::kernel::run::<$v, true, false>(x, out, &mut [], libm_sin, libm_sin) };
        }

        /// `out[i] = cos(x[i])`, lanes beyond the vector range through
        /// `libm_cos`.
        ///
        /// # Safety
        #[doc = concat!("The CPU must support ", $cpu, ".")]
        #[inline]
        #[target_feature(enable = $features)]
        pub unsafe fn cos_lanes(x: &[f64], out: &mut [f64], libm_cos: fn(f64) -> f64) {
            // SAFETY: this function's target features are `$v`'s.
            unsafe { $crate::kernel::run::<$v, false, true>(x, &mut [], out, libm_cos, libm_cos) };
        }

        /// `sin[i], cos[i] = sin(x[i]), cos(x[i])` (the bits of the two
        /// functions, not of glibc's `sincos`), lanes beyond the vector
        /// range through libm.
        ///
        /// # Safety
        #[doc = concat!("The CPU must support ", $cpu, ".")]
        #[inline]
        #[target_feature(enable = $features)]
        pub unsafe fn sincos_lanes(
            x: &[f64],
            sin: &mut [f64],
            cos: &mut [f64],
            libm_sin: fn(f64) -> f64,
            libm_cos: fn(f64) -> f64,
        ) {
            // SAFETY: this function's target features are `$v`'s.
            unsafe { $crate::kernel::run::<$v, true, true>(x, sin, cos, libm_sin, libm_cos) };
        }
    };
}
pub(crate) use entry_points;

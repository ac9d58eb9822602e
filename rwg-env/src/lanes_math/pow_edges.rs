//! The self-check's arguments for `pow(x, 2)` ([`super::pow2_edge_arguments`]).

/// `x` within `ulps` ulps either side, `x` included.
fn near(v: &mut Vec<f64>, x: f64, ulps: i64) {
    for d in -ulps..=ulps {
        v.push(f64::from_bits((x.to_bits() as i64 + d) as u64));
    }
}

/// xorshift64 over [0, 1) (also the tests' generator).
pub(super) struct Unit(pub(super) u64);

impl Unit {
    /// The next number in [0, 1).
    pub(super) fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Log-uniform over [2^-60, 2^32].
    pub(super) fn log_uniform(&mut self) -> f64 {
        (self.next() * 92.0 - 60.0).exp2()
    }
}

/// See [`super::pow2_edge_arguments`].
pub(super) fn arguments() -> Vec<f64> {
    let mut v: Vec<f64> = vec![
        0.0,
        f64::from_bits(1),
        f64::MIN_POSITIVE,
        1e-300,
        1e-160,
        1e160,
        1e300,
        f64::MAX,
        f64::INFINITY,
        f64::NAN,
    ];
    // 1 (left to the fast path), the port's ends, powers of two.
    near(&mut v, 1.0, 4);
    near(&mut v, 2f64.powi(-60), 4);
    near(&mut v, 2f64.powi(32), 4);
    for e in -62..=34 {
        near(&mut v, 2f64.powi(e), 1);
    }
    // The log's subinterval edges (x = 2^k z, z's top bits select the row),
    // at a few exponents.
    const OFF: u64 = 0x3fe6_9555_0000_0000;
    for k in [-60i64, -21, -1, 0, 1, 5, 31] {
        for j in 0..128u64 {
            let bits = OFF.wrapping_add(j << 45).wrapping_add((k as u64) << 52);
            near(&mut v, f64::from_bits(bits), 1);
        }
    }
    // exp's table points: 2 log x = (m + 1/2) ln2 / 128, where k rounds.
    let mut m = -60 * 256;
    while m < 32 * 256 {
        near(&mut v, ((m as f64 + 0.5) / 256.0).exp2(), 1);
        m += 13;
    }
    // The squares the port computes in practice, and anything in its range.
    let mut u = Unit(0x2545_f491_4f6c_dd1d);
    let mut band = 0;
    while band < 1500 {
        let x = u.log_uniform();
        if crate::float::hard_square(x) {
            v.push(x);
            band += 1;
        }
    }
    for _ in 0..1500 {
        v.push(u.log_uniform());
    }
    let neg: Vec<f64> = v.iter().map(|x| -x).collect();
    v.extend(neg);
    v
}

//! Whole-buffer passes of [`super::PluginBatch`]'s common case: the
//! sentinels written before a batched call and the test of what the plugin
//! wrote after it, each one pass over a buffer without a branch per value.
//! The tests are sufficient, not exact (they include the lanes not stepped,
//! and a sum of finite values may overflow): when one fails, the batch
//! checks the lanes one by one, which find the error or nothing.

/// Fills the output slots of the lanes of `mask` with values a plugin
/// cannot leave there by accident unnoticed (NaN, flags 0xff), so a slot it
/// does not write fails the checks; whole buffers when `every` lane steps.
#[inline]
pub(super) fn fill_sentinels(
    mask: &[u8],
    every: bool,
    d: usize,
    obs: &mut [f64],
    rewards: &mut [f64],
    terminated: &mut [u8],
    truncated: &mut [u8],
) {
    if every {
        fill_nan(obs);
        fill_nan(rewards);
        fill_bytes(terminated, 0xff);
        fill_bytes(truncated, 0xff);
        return;
    }
    if d == 0 {
        return;
    }
    let lanes = obs
        .chunks_exact_mut(d)
        .zip(rewards.iter_mut().zip(terminated.iter_mut().zip(truncated)));
    for ((o, (r, (te, tr))), &m) in lanes.zip(mask) {
        if m == 1 {
            o.fill(f64::NAN);
            *r = f64::NAN;
            *te = 0xff;
            *tr = 0xff;
        }
    }
}

/// `values.fill(f64::NAN)`, eight values per loop iteration.
#[inline]
fn fill_nan(values: &mut [f64]) {
    let mut chunks = values.chunks_exact_mut(8);
    for c in &mut chunks {
        c.copy_from_slice(&[f64::NAN; 8]);
    }
    chunks.into_remainder().fill(f64::NAN);
}

/// `bytes.fill(b)` eight bytes at a time (no call to `memset` for a buffer
/// of a few words).
#[inline]
fn fill_bytes(bytes: &mut [u8], b: u8) {
    let mut chunks = bytes.chunks_exact_mut(8);
    for c in &mut chunks {
        c.copy_from_slice(&[b; 8]);
    }
    chunks.into_remainder().fill(b);
}

/// Whether every flag is 0 or 1 and every reward and observation finite,
/// lanes not stepped included (a sufficient test: if it fails, the lanes
/// are checked one by one).
#[inline]
pub(super) fn outputs_ok(
    obs: &[f64],
    rewards: &[f64],
    terminated: &[u8],
    truncated: &[u8],
) -> bool {
    let flags = or_bytes(terminated) | or_bytes(truncated);
    (flags <= 1) & sum_is_finite(obs) & sum_is_finite(rewards)
}

/// The bytes of `bytes` OR-ed together, eight at a time.
#[inline]
pub(super) fn or_bytes(bytes: &[u8]) -> u8 {
    let mut chunks = bytes.chunks_exact(8);
    let mut acc = 0u64;
    for c in &mut chunks {
        acc |= u64::from_ne_bytes(c.try_into().expect("8 bytes"));
    }
    let acc = acc | (acc >> 32);
    let acc = acc | (acc >> 16);
    let acc = (acc | (acc >> 8)) as u8;
    chunks.remainder().iter().fold(acc, |a, &b| a | b)
}

/// Whether every byte is 1 (a mask of every lane).
#[inline]
pub(super) fn all_ones(mask: &[u8]) -> bool {
    let mut chunks = mask.chunks_exact(8);
    let ones = u64::from_ne_bytes([1; 8]);
    chunks.all(|c| u64::from_ne_bytes(c.try_into().expect("8 bytes")) == ones)
        && chunks.remainder().iter().all(|&m| m == 1)
}

/// Whether every value is finite, exactly, in one pass without a branch
/// per value: `x - x` is 0 for a finite `x` and NaN for an infinite or NaN
/// one, and a NaN stays in a sum.
#[inline]
#[expect(clippy::eq_op, reason = "`x - x` is the test, not a mistake")]
pub(super) fn all_finite(values: &[f64]) -> bool {
    let mut chunks = values.chunks_exact(4);
    let mut acc = [0.0f64; 4];
    for c in &mut chunks {
        for k in 0..4 {
            acc[k] += c[k] - c[k];
        }
    }
    let tail = chunks.remainder().iter().fold(0.0, |a, &x| a + (x - x));
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail == 0.0
}

/// Whether the sum of `values` is finite: it is if every value is finite,
/// and a NaN or infinite value makes it NaN or infinite (no finite value
/// cancels one). A sufficient test for "every value is finite" at one
/// vector add per two values; finite values whose sum overflows fail it
/// too (the caller then checks them one by one).
#[inline]
#[expect(clippy::eq_op, reason = "`s - s` is the test, not a mistake")]
pub(super) fn sum_is_finite(values: &[f64]) -> bool {
    let s = sum(values);
    s - s == 0.0
}

/// The sum of `values` in some order (four running sums of pairs).
#[cfg(target_arch = "x86_64")]
#[inline]
fn sum(values: &[f64]) -> f64 {
    use std::arch::x86_64::*;
    let mut chunks = values.chunks_exact(8);
    // SAFETY: SSE2 is part of x86-64; every load reads 2 of the 8 values
    // of a chunk.
    unsafe {
        let (mut a, mut b) = (_mm_setzero_pd(), _mm_setzero_pd());
        let (mut c, mut d) = (_mm_setzero_pd(), _mm_setzero_pd());
        for ch in &mut chunks {
            let p = ch.as_ptr();
            a = _mm_add_pd(a, _mm_loadu_pd(p));
            b = _mm_add_pd(b, _mm_loadu_pd(p.add(2)));
            c = _mm_add_pd(c, _mm_loadu_pd(p.add(4)));
            d = _mm_add_pd(d, _mm_loadu_pd(p.add(6)));
        }
        let s = _mm_add_pd(_mm_add_pd(a, b), _mm_add_pd(c, d));
        let pair = _mm_add_sd(s, _mm_unpackhi_pd(s, s));
        chunks
            .remainder()
            .iter()
            .fold(_mm_cvtsd_f64(pair), |t, &x| t + x)
    }
}

/// The sum of `values` in some order (eight running sums).
#[cfg(not(target_arch = "x86_64"))]
#[inline]
fn sum(values: &[f64]) -> f64 {
    let mut chunks = values.chunks_exact(8);
    let mut acc = [0.0f64; 8];
    for c in &mut chunks {
        for k in 0..8 {
            acc[k] += c[k];
        }
    }
    let s = acc.iter().sum::<f64>();
    chunks.remainder().iter().fold(s, |t, &x| t + x)
}

#[cfg(test)]
mod tests {
    use super::*;

    const BAD: [f64; 4] = [f64::NAN, -f64::NAN, f64::INFINITY, f64::NEG_INFINITY];

    #[test]
    fn the_finite_tests_find_any_non_finite_value_at_any_position() {
        for n in 0..40 {
            let ok: Vec<f64> = (0..n).map(|i| (i as f64 - 7.5) * 1e300).collect();
            assert!(all_finite(&ok), "{n}");
            // Eight values of 1e300 cannot overflow: the sum test passes.
            let small: Vec<f64> = ok.iter().map(|x| x / 40.0).collect();
            assert!(sum_is_finite(&small), "{n}");
            for i in 0..n {
                for bad in BAD {
                    let mut v = small.clone();
                    v[i] = bad;
                    assert!(!all_finite(&v), "{n} {i} {bad}");
                    assert!(!sum_is_finite(&v), "{n} {i} {bad}");
                }
            }
            // +inf and -inf in one buffer: NaN, not a cancellation.
            if n >= 2 {
                let mut v = small.clone();
                v[0] = f64::INFINITY;
                v[n - 1] = f64::NEG_INFINITY;
                assert!(!sum_is_finite(&v), "{n}");
            }
        }
        assert!(all_finite(&[
            f64::MAX,
            f64::MIN,
            -0.0,
            f64::MIN_POSITIVE / 2.0
        ]));
    }

    #[test]
    fn a_sum_that_overflows_fails_the_sum_test_only() {
        // Finite values: all_finite says so, the sum test is only sufficient.
        let v = [f64::MAX, f64::MAX, 1.0];
        assert!(all_finite(&v));
        assert!(!sum_is_finite(&v));
    }

    #[test]
    fn flags_and_masks_are_checked_at_every_position() {
        for n in 0..40 {
            let zeros = vec![0u8; n];
            let ones = vec![1u8; n];
            assert!(or_bytes(&zeros) == 0 && or_bytes(&ones) == u8::from(n > 0));
            assert!(all_ones(&ones));
            assert_eq!(all_ones(&zeros), n == 0);
            for i in 0..n {
                for bad in [2u8, 3, 0x80, 0xff] {
                    let mut v = ones.clone();
                    v[i] = bad;
                    assert!(or_bytes(&v) > 1 && !all_ones(&v), "{n} {i} {bad}");
                    let mut z = zeros.clone();
                    z[i] = bad;
                    assert_eq!(or_bytes(&z), bad, "{n} {i} {bad}");
                }
                let mut v = ones.clone();
                v[i] = 0;
                assert!(or_bytes(&v) <= 1 && !all_ones(&v));
            }
        }
    }

    #[test]
    fn sentinels_fill_the_masked_lanes_or_every_slot() {
        for n in 0..20 {
            for d in 1..4 {
                let mask: Vec<u8> = (0..n).map(|i| u8::from(i % 3 != 1)).collect();
                for every in [false, true] {
                    let (mut obs, mut r) = (vec![0.0; n * d], vec![0.0; n]);
                    let (mut te, mut tr) = (vec![0u8; n], vec![1u8; n]);
                    fill_sentinels(&mask, every, d, &mut obs, &mut r, &mut te, &mut tr);
                    for i in 0..n {
                        let filled = every || mask[i] == 1;
                        assert_eq!(r[i].is_nan(), filled);
                        assert!(obs[i * d..(i + 1) * d].iter().all(|x| x.is_nan() == filled));
                        assert_eq!((te[i], tr[i]), if filled { (0xff, 0xff) } else { (0, 1) });
                    }
                    assert!(n == 0 || !outputs_ok(&obs, &r, &te, &tr));
                }
            }
        }
    }
}

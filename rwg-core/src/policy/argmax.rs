//! `numpy.argmax(tanh(z))` without evaluating tanh in the common case: the
//! discrete action of a network's outputs.

use crate::tanh::tanh;

/// `numpy.argmax(tanh(z))` with rwg's [`tanh`]: the first index whose tanh
/// is the largest.
///
/// Computed without evaluating tanh in the common case. Let `b` be the first
/// maximum of `z`. An index `j` can have `tanh(z[j]) >= tanh(z[b])` only if
/// it is "close" to `b`: `z[b] - z[j] < 1e-6`, or `z[b] > 5`, or
/// `z[j] < -5`. Otherwise both lie in [-5, 5], where the exact tanh' is at
/// least 1.8e-4, so the exact values differ by more than 1.8e-10, far more
/// than the 2 ulp (< 4.5e-16) each computed value may be off: `tanh(z[j]) <
/// tanh(z[b])` whatever the rounding. The close indices (before or after
/// `b`: the computed tanh need not be monotonic) are settled by computing
/// tanh, first index winning ties.
#[inline]
pub fn argmax_tanh(z: &[f64]) -> usize {
    let mut best = 0;
    for i in 1..z.len() {
        if z[i] > z[best] {
            best = i;
        }
    }
    let zb = z[best];
    let close = |zj: f64| zb - zj < 1e-6 || zb > 5.0 || zj < -5.0;
    if !z.iter().enumerate().any(|(j, &zj)| j != best && close(zj)) {
        return best;
    }
    // numpy's argmax over `best` and the close indices (the others lose).
    let mut arg = best;
    let mut max = tanh(zb);
    for (j, &zj) in z.iter().enumerate() {
        if j != best && close(zj) {
            let t = tanh(zj);
            if t > max || (t == max && j < arg) {
                arg = j;
                max = t;
            }
        }
    }
    arg
}

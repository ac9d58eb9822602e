//! The expected values were computed once with SciPy 1.17.1
//! (`ks_2samp(a, b, method="exact")`, `binomtest(b, b + c, 0.5).pvalue`,
//! `fisher_exact(table).pvalue`, `spearmanr(x, y).statistic`) on the inputs
//! written here, and copied in; Holm's decisions are worked by hand.

use super::*;

/// `|got − want| ≤ 1e-9 · max(1, |want|)`.
fn close(got: f64, want: f64) {
    assert!(
        (got - want).abs() <= 1e-9 * want.abs().max(1.0),
        "got {got}, want {want}"
    );
}

const SMALL_A: [f64; 10] = [1., 2., 2., 3., 5., 8., 9., 9., 10., 12.];
const SMALL_B: [f64; 10] = [0., 2., 3., 3., 4., 6., 7., 11., 13., 14.];

/// Two deterministic samples of 300, with ties: `((37 i) mod 101) / 10` and
/// `((53 i + 7) mod 113) / 10 + 0.5`.
fn modular_samples() -> (Vec<f64>, Vec<f64>) {
    let a = (0..300).map(|i| ((i * 37) % 101) as f64 / 10.0).collect();
    let b = (0..300)
        .map(|i| ((i * 53 + 7) % 113) as f64 / 10.0 + 0.5)
        .collect();
    (a, b)
}

#[test]
fn ks_matches_scipy_exact() {
    let r = ks_two_sample(&SMALL_A, &SMALL_B);
    close(r.statistic, 0.2);
    close(r.p_value, 0.9944575548290717);

    let (a, b) = modular_samples();
    let r = ks_two_sample(&a, &b);
    close(r.statistic, 0.15333333333333332);
    close(r.p_value, 0.0017015674192205016);

    // a shift of 0.05 in 2000 values of a grid of 0.001
    let a: Vec<f64> = (0..2000)
        .map(|i| ((i * 7919) % 1000) as f64 / 1000.0)
        .collect();
    let b: Vec<f64> = a.iter().map(|x| x + 0.05).collect();
    let r = ks_two_sample(&a, &b);
    close(r.statistic, 0.051);
    close(r.p_value, 0.011000567452742057);
}

#[test]
fn ks_of_one_sample_twice_is_d0_p1_whatever_the_order() {
    let r = ks_two_sample(&[2.0, 1.0, 1.0], &[1.0, 2.0, 1.0]);
    assert_eq!((r.statistic, r.p_value), (0.0, 1.0));
    // disjoint samples: D = 1, p = 2 / C(2n, n)
    let r = ks_two_sample(&[1.0, 2.0, 3.0], &[4.0, 5.0, 6.0]);
    close(r.statistic, 1.0);
    close(r.p_value, 2.0 / 20.0);
}

#[test]
fn mcnemar_matches_scipy_binomtest() {
    for (b, c, want) in [
        (3, 10, 0.09228515625),
        (0, 5, 0.0625),
        (7, 7, 1.0),
        (150, 180, 0.1102607870684355),
        (8, 10, 0.8145294189453125),
        (1000, 1100, 0.03072070786424249),
        (0, 0, 1.0),
        (0, 1, 1.0),
    ] {
        let r = mcnemar_exact(b, c);
        close(r.p_value, want);
        assert_eq!(r.statistic, b.min(c) as f64);
        // symmetric in its two counts
        assert_eq!(mcnemar_exact(c, b).p_value, r.p_value);
    }
}

#[test]
fn fisher_matches_scipy() {
    for (t, want) in [
        ([[6, 2], [1, 4]], 0.10256410256410256),
        ([[158, 9842], [160, 9840]], 0.9549323023603546),
        ([[3, 7], [9, 1]], 0.019766611097880443),
        ([[0, 10], [5, 5]], 0.032507739938080496),
        ([[12, 244], [30, 226]], 0.005615555533465244),
        ([[5, 5], [5, 5]], 1.0),
        ([[0, 10], [0, 10]], 1.0),
    ] {
        close(fisher_exact(t).p_value, want);
    }
}

#[test]
fn spearman_matches_scipy() {
    close(spearman(&SMALL_A, &SMALL_B).unwrap(), 0.9877722029314423);
    let (a, b) = modular_samples();
    close(spearman(&a, &b).unwrap(), 0.01763829330966389);
    let x = [3., 1., 4., 1., 5., 9., 2., 6.];
    let y = [2., 7., 1., 8., 2., 8., 1., 8.];
    close(spearman(&x, &y).unwrap(), 0.19885368120992467);
    assert_eq!(spearman(&[1.0, 1.0], &[1.0, 2.0]), None);
    assert_eq!(spearman(&[1.0], &[1.0]), None);
}

#[test]
fn average_ranks_share_ties() {
    assert_eq!(average_ranks(&[10., 20., 10., 30.]), [1.5, 3.0, 1.5, 4.0]);
}

#[test]
fn holm_steps_down() {
    // sorted: 0.005 ≤ 0.05/4, 0.01 ≤ 0.05/3, 0.03 > 0.05/2: stop there
    assert_eq!(
        holm(&[0.01, 0.04, 0.03, 0.005], 0.05),
        [true, false, false, true]
    );
    // 0.04 alone: 0.04 ≤ 0.05
    assert_eq!(holm(&[0.04], 0.05), [true]);
    assert_eq!(holm(&[0.04, 0.5], 0.05), [false, false]);
    assert_eq!(holm(&[f64::NAN, 0.001], 0.05), [false, true]);
    assert!(holm(&[], 0.05).is_empty());
}

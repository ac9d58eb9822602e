//! Unit tests of the statistics: hand-computed cases, and a fixture whose
//! expected values were computed with numpy 2.4 (`fixture.py` below) and are
//! compared bit for bit.

use super::*;

fn meta(solved: Option<f64>) -> CellMeta {
    CellMeta {
        non_finite_episodes: None,
        id: CellId::new("Fixture-v0", "0HL", &[], false),
        n_weights: 8,
        obs_dim: 4,
        max_episode_steps: 200,
        solved,
        solved_source: solved.map(|_| "manifest".into()),
        samples: 16,
        episodes: 10,
        wall_s: 1.0,
        env_steps: 1000,
        steps_per_s: 1000.0,
    }
}

// ---------------------------------------------------------------- by hand

#[test]
fn mean_and_population_variance_by_hand() {
    let x = [1.0, 2.0, 3.0, 4.0];
    assert_eq!(mean(&x), 2.5);
    // squared deviations 2.25 + 0.25 + 0.25 + 2.25 = 5, divided by N = 4
    // (not by N + 1 = 5 as the paper's text prints, nor by N − 1 = 3)
    assert_eq!(variance(&x), 1.25);
    let s = sample_stats(&x);
    assert_eq!((s.min, s.max, s.std), (1.0, 4.0, 1.25f64.sqrt()));
    assert_eq!(variance(&[7.0]), 0.0);
    assert!(mean(&[]).is_nan());
}

#[test]
fn min_max_propagate_nan() {
    assert!(min(&[1.0, f64::NAN, 0.0]).is_nan());
    assert!(max(&[1.0, f64::NAN]).is_nan());
    assert_eq!(max(&[-3.0, -1.0]), -1.0);
}

#[test]
fn ranks_are_stable_and_best_is_last() {
    // argsort(stable) of [3, 1, 3, 2] = [1, 3, 0, 2]
    assert_eq!(argsort(&[3.0, 1.0, 3.0, 2.0]), vec![1, 3, 0, 2]);
    assert_eq!(ranks(&[3.0, 1.0, 3.0, 2.0]), vec![2, 0, 3, 1]);
    // NaN sorts last; -0.0 and 0.0 tie
    assert_eq!(ranks(&[f64::NAN, 0.0, -0.0]), vec![2, 0, 1]);
}

#[test]
fn percentiles_by_hand() {
    let x = [4.0, 1.0, 3.0, 2.0];
    assert_eq!(percentile(&x, 0.0), 1.0);
    assert_eq!(percentile(&x, 50.0), 2.5);
    // virtual index 0.75: 2 − (2 − 1)·0.25
    assert_eq!(percentile(&x, 25.0), 1.75);
    assert_eq!(percentile(&x, 100.0), 4.0);
    // virtual index 0.999 between 0 and 10: 10 − 10·(1 − 0.999), where
    // 1 − 0.999 rounds up; numpy gives the same 9.990000000000002
    assert_eq!(percentile(&[0.0, 10.0], 99.9), 9.990000000000002);
    assert_eq!(percentile(&[5.0], 99.9), 5.0);
    assert!(percentile(&[1.0, f64::NAN], 10.0).is_nan());
    assert!(percentile(&[], 10.0).is_nan());
}

#[test]
fn wilson_by_hand() {
    // k = 0: [0, z²/(n + z²)]
    let (lo, hi) = wilson_interval(0, 100, Z_95);
    assert_eq!(lo, 0.0);
    assert!((hi - Z_95 * Z_95 / (100.0 + Z_95 * Z_95)).abs() < 1e-16);
    assert!((hi - 0.036_994_4).abs() < 1e-6);
    // k = n: [n/(n + z²), 1]
    let (lo, hi) = wilson_interval(100, 100, Z_95);
    assert_eq!(hi, 1.0);
    assert!((lo - 100.0 / (100.0 + Z_95 * Z_95)).abs() < 1e-15);
    // textbook case: 5 of 10 -> [0.2366, 0.7634]
    let (lo, hi) = wilson_interval(5, 10, Z_95);
    assert!((lo - 0.236_593).abs() < 1e-6 && (hi - 0.763_407).abs() < 1e-6);
    assert_eq!(wilson_interval(0, 0, Z_95), (0.0, 1.0));
}

#[test]
fn expected_guesses_and_success_odds_by_hand() {
    let prop = solved_fraction(&[1.0, 2.0, 3.0, 4.0], 4.0);
    assert_eq!((prop.successes, prop.trials, prop.p), (1, 4, 0.25));
    match expected_guesses(&prop) {
        ExpectedGuesses::Estimate {
            value,
            lo_bound,
            hi_bound,
        } => {
            assert_eq!(value, 4.0);
            assert_eq!(lo_bound, 1.0 / prop.hi);
            assert_eq!(hi_bound, Some(1.0 / prop.lo));
        }
        other => panic!("{other:?}"),
    }
    let none = solved_fraction(&[1.0, 2.0], 4.0);
    assert_eq!(
        expected_guesses(&none),
        ExpectedGuesses::NoneSeen {
            at_least: 1.0 / none.hi
        }
    );
    assert_eq!(p_any_success(0.5, 1), 0.5);
    assert_eq!(p_any_success(0.5, 2), 0.75);
    assert_eq!(p_any_success(0.0, 1000), 0.0);
    assert_eq!(p_any_success(1.0, 10), 1.0);
    // tiny p keeps its precision: 1 − (1 − 1e-12)^10 ≈ 1e-11
    assert!((p_any_success(1e-12, 10) / 1e-11 - 1.0).abs() < 1e-9);
}

#[test]
fn normalised_score() {
    let mut s = summarize_cell(
        &meta(Some(10.0)),
        1,
        &[0.0, 2.0, 4.0],
        &[1, 1, 1],
        &per_sample(&[0.0, 2.0, 4.0], 1),
    );
    assert_eq!(s.median_mean, 2.0);
    assert_eq!(s.normalise(2.0), Some(0.0));
    assert_eq!(s.normalise(10.0), Some(1.0));
    assert_eq!(s.normalise(6.0), Some(0.5));
    s.solved = None;
    assert_eq!(s.normalise(6.0), None);
}

// ---------------------------------------------------------------- numpy fixture

// Generated with numpy 2.4.6:
//
// ```python
// rng = np.random.default_rng(20200509)
// N, E = 16, 10
// S = np.round(rng.normal(size=(N, E)) * 40 + 100, 6)
// S[7] = S[3]                                    # tied means
// S[11] = rng.normal(size=E) * 1e-3 + 200        # the best sample
// S[5, :] = 150.0                                # mean exactly at `solved`
// steps = rng.integers(10, 201, size=(N, E))
// M, V = S.mean(axis=1), S.var(axis=1)
// rank = np.empty(N, int); rank[np.argsort(M, kind="stable")] = np.arange(N)
// np.percentile(M, q) for q in [1, 5, 10, 25, 50, 75, 90, 99, 99.9]
// np.mean(M), np.mean(V), np.percentile(S, 99.9), np.mean(steps)
// ```
// Wilson interval of k = 2 of 16 with z = 1.959963984540054, in float64.

const SCORES: [[f64; 10]; 16] = [
    [
        105.903745, 90.775712, 87.527421, 81.7656, 67.52907, 81.974075, 131.836247, 182.195405,
        56.74239, 68.48549,
    ],
    [
        160.627708, 149.438981, 111.491032, 151.856409, 86.319987, 201.630503, 69.332683,
        30.955171, 93.232162, 96.408237,
    ],
    [
        98.84691, 97.701486, 104.451431, -51.875195, 81.410471, 68.900484, 86.04325, 46.912977,
        46.898488, 137.109518,
    ],
    [
        138.882652, 102.220902, 65.716561, 106.107312, 73.502803, 116.571665, 74.68958, 27.640772,
        96.519615, 52.429947,
    ],
    [
        -12.753455, 74.71721, 129.204156, 76.445931, 161.132788, 39.017151, 138.298681, 104.359909,
        41.90154, 84.607025,
    ],
    [
        150.0, 150.0, 150.0, 150.0, 150.0, 150.0, 150.0, 150.0, 150.0, 150.0,
    ],
    [
        112.498258, 47.363898, 51.637901, 134.474722, 115.540188, -3.189664, 71.549466, 135.059318,
        124.494232, 147.62991,
    ],
    [
        138.882652, 102.220902, 65.716561, 106.107312, 73.502803, 116.571665, 74.68958, 27.640772,
        96.519615, 52.429947,
    ],
    [
        56.39429, 150.457293, 94.229153, 40.837376, 73.133561, 78.232106, 84.04571, 52.176073,
        128.36077, 75.156234,
    ],
    [
        61.91739, 89.905082, 105.437452, 145.575076, 71.527192, 125.590055, 104.13693, 126.106104,
        82.03609, 74.148712,
    ],
    [
        123.725462, 1.129063, 95.501323, 89.037943, 74.772083, 58.192943, 107.654138, 97.020739,
        10.976465, 77.0005,
    ],
    [
        200.00288873296319,
        200.00029066430946,
        200.00206723604586,
        200.00011460053335,
        199.9992452692065,
        199.99829620310413,
        199.99909973032447,
        199.9994290996659,
        200.0015420704364,
        200.00012170263597,
    ],
    [
        148.533315, 55.736449, 88.748464, 49.056097, 72.977849, 156.865077, 128.844459, 130.288382,
        146.323153, 5.506144,
    ],
    [
        78.229909, 53.565051, 158.663823, 161.640094, 56.202267, 54.20926, 145.099333, 77.719847,
        80.354518, 118.379744,
    ],
    [
        103.850078, 46.98412, 133.137619, 107.359868, 115.174955, 98.588856, 104.792778, 99.450705,
        107.760173, 175.451587,
    ],
    [
        106.32668, 134.938117, 47.013776, 151.729799, 151.563719, 105.878121, 77.855827,
        134.104183, 102.463076, 44.531242,
    ],
];
const STEPS: [[u32; 10]; 16] = [
    [55, 105, 171, 131, 94, 59, 14, 116, 196, 49],
    [181, 128, 174, 29, 97, 19, 79, 65, 83, 161],
    [187, 129, 130, 49, 179, 80, 199, 98, 183, 179],
    [104, 166, 131, 114, 106, 61, 56, 50, 54, 101],
    [62, 17, 164, 35, 100, 196, 34, 136, 113, 101],
    [59, 114, 195, 71, 102, 91, 98, 82, 178, 59],
    [116, 145, 130, 36, 55, 169, 37, 108, 38, 25],
    [40, 158, 34, 198, 92, 116, 115, 73, 130, 110],
    [56, 144, 162, 102, 197, 179, 153, 79, 54, 45],
    [193, 154, 44, 85, 38, 70, 176, 142, 83, 52],
    [59, 112, 55, 116, 10, 148, 107, 102, 48, 13],
    [79, 141, 83, 38, 140, 180, 41, 130, 53, 21],
    [21, 46, 59, 125, 56, 26, 38, 128, 11, 106],
    [196, 14, 42, 166, 22, 94, 89, 85, 167, 106],
    [115, 37, 24, 141, 89, 163, 30, 192, 40, 194],
    [49, 151, 34, 141, 127, 95, 126, 43, 162, 20],
];
const MEANS: [f64; 16] = [
    95.4735155,
    115.12928730000002,
    71.639982,
    85.4281809,
    83.6930936,
    150.0,
    93.7058229,
    85.4281809,
    83.3022566,
    98.63800830000001,
    73.50106589999999,
    200.00030953092255,
    98.2879389,
    98.4063846,
    109.2550739,
    105.640454,
];
const VARS: [f64; 16] = [
    1241.6421301897567,
    2293.4388480365837,
    2357.2256936108433,
    973.4287152179979,
    2465.5384162726627,
    0.0,
    2185.476670068685,
    973.4287152179979,
    1035.162886952934,
    679.5481496526864,
    1436.2735854367093,
    1.875951598051279e-06,
    2379.5457246823676,
    1711.4838860606924,
    912.9917452206024,
    1385.5742701422867,
];
const STDS: [f64; 16] = [
    35.23694269072952,
    47.88986164144332,
    48.55126871267983,
    31.199819153610456,
    49.65418830544572,
    0.0,
    46.74908202380754,
    31.199819153610456,
    32.17394733247591,
    26.068144346168687,
    37.89820029284648,
    0.0013696538241655368,
    48.78058758033125,
    41.3700844338115,
    30.215753262505345,
    37.223302783905226,
];
const MINS: [f64; 16] = [
    56.74239,
    30.955171,
    -51.875195,
    27.640772,
    -12.753455,
    150.0,
    -3.189664,
    27.640772,
    40.837376,
    61.91739,
    1.129063,
    199.99829620310413,
    5.506144,
    53.565051,
    46.98412,
    44.531242,
];
const MAXS: [f64; 16] = [
    182.195405,
    201.630503,
    137.109518,
    138.882652,
    161.132788,
    150.0,
    147.62991,
    138.882652,
    150.457293,
    145.575076,
    123.725462,
    200.00288873296319,
    156.865077,
    161.640094,
    175.451587,
    151.729799,
];
const RANKS: [usize; 16] = [7, 13, 0, 4, 3, 14, 6, 5, 2, 10, 1, 15, 8, 9, 12, 11];
const MEAN_PCTS: [f64; 9] = [
    71.919144585,
    73.03579492499999,
    78.40166124999999,
    84.994409075,
    96.8807272,
    106.544108975,
    132.56464365,
    192.50026310128416,
    199.25030488795878,
];
const MEAN_OF_MEANS: f64 = 102.97059717693267;
const MEAN_VARIANCE: f64 = 1376.9224649149223;
const TOP_THRESHOLD: f64 = 201.37171233154118;
const TOP_COUNT: u64 = 1;
const MEAN_LENGTH: f64 = 98.425;
const MAX_LENGTH: u32 = 199;
const WILSON: (f64, f64) = (0.03497748774324047, 0.36022827265758695);

fn fixture_scores() -> Vec<f64> {
    SCORES.iter().flatten().copied().collect()
}

fn fixture_steps() -> Vec<u32> {
    STEPS.iter().flatten().copied().collect()
}

#[test]
fn fixture_per_sample_matches_numpy_bit_for_bit() {
    let stats = per_sample(&fixture_scores(), 10);
    assert_eq!(stats.len(), 16);
    for (i, s) in stats.iter().enumerate() {
        assert_eq!(s.mean, MEANS[i], "mean of sample {i}");
        assert_eq!(s.variance, VARS[i], "variance of sample {i}");
        assert_eq!(s.std, STDS[i], "std of sample {i}");
        assert_eq!(s.min, MINS[i], "min of sample {i}");
        assert_eq!(s.max, MAXS[i], "max of sample {i}");
    }
    let means: Vec<f64> = stats.iter().map(|s| s.mean).collect();
    assert_eq!(ranks(&means), RANKS);
}

#[test]
fn fixture_summary_matches_numpy() {
    let scores = fixture_scores();
    let stats = per_sample(&scores, 10);
    let s = summarize_cell(&meta(Some(150.0)), 10, &scores, &fixture_steps(), &stats);
    assert_eq!(s.best_sample, 11);
    assert_eq!(s.best_mean, MEANS[11]);
    assert_eq!(s.best_variance, VARS[11]);
    assert_eq!(
        s.worst_mean,
        MEANS[RANKS.iter().position(|&r| r == 0).unwrap()]
    );
    let got: Vec<f64> = s.mean_percentiles.iter().map(|p| p.value).collect();
    assert_eq!(got, MEAN_PCTS);
    assert_eq!(s.median_mean, MEAN_PCTS[4]);
    assert_eq!(s.p99_9_mean, MEAN_PCTS[8]);
    assert_eq!(s.mean_percentile(99.9), Some(MEAN_PCTS[8]));
    assert_eq!(s.mean_of_means, MEAN_OF_MEANS);
    assert_eq!(s.mean_variance, MEAN_VARIANCE);
    assert_eq!(s.top_episode_threshold, TOP_THRESHOLD);
    assert_eq!(s.top_episodes, TOP_COUNT);
    assert_eq!(s.mean_episode_length, MEAN_LENGTH);
    assert_eq!(s.max_episode_length, MAX_LENGTH);
    // samples 5 (mean exactly 150) and 11 are solved
    let prop = s.solved_fraction.unwrap();
    assert_eq!((prop.successes, prop.trials, prop.p), (2, 16, 0.125));
    assert!((prop.lo - WILSON.0).abs() < 1e-15 && (prop.hi - WILSON.1).abs() < 1e-15);
    assert!(matches!(
        s.expected_guesses,
        Some(ExpectedGuesses::Estimate { value, .. }) if value == 8.0
    ));
    let odds: Vec<(u64, f64)> = s.success_odds.iter().map(|o| (o.guesses, o.p)).collect();
    assert_eq!(odds[0].0, 10);
    assert!((odds[0].1 - 0.736_924_423_836_171_6).abs() < 1e-15);
    assert!((odds[1].1 - 0.999_998_412_165_250_3).abs() < 1e-15);
    assert_eq!(odds[2], (1000, 1.0));
}

#[test]
fn fixture_without_solved_score() {
    let scores = fixture_scores();
    let stats = per_sample(&scores, 10);
    let s = summarize_cell(&meta(None), 10, &scores, &fixture_steps(), &stats);
    assert!(s.solved_fraction.is_none() && s.expected_guesses.is_none());
    assert!(s.success_odds.is_empty());
}

/// `(n, numpy.sum(x[:n]), numpy.var(x[:n]), numpy.percentile(x[:n], 99.9))`
/// for `x[i] = (i*7919 % 1000)/7.0 - 50 + i*1e-3`: exercises every branch of
/// the pairwise summation (n < 8, ≤ 128, recursive).
const PAIRWISE: [(usize, f64, f64, f64); 11] = [
    (1, -50.0, 0.0, -50.0),
    (7, 264.1638571428571, 1617.6708644748019, 81.21729171428572),
    (8, 276.028, 1488.682076678571, 81.20572128571429),
    (9, 276.3217142857143, 1438.8590744419246, 81.19415085714286),
    (
        100,
        2012.0928571428574,
        1737.3045985561218,
        90.19576557142858,
    ),
    (
        128,
        2698.4137142857144,
        1738.9400183112245,
        90.18272957142858,
    ),
    (129, 2738.8274285714288, 1728.3346136975185, 90.182264),
    (256, 5541.211428571429, 1693.721124515306, 91.98542214285716),
    (
        257,
        5529.181714285714,
        1691.5260926835408,
        91.98495657142858,
    ),
    (
        1000,
        21856.642857142855,
        1700.7522618214286,
        93.21360671428573,
    ),
    (
        1001,
        21807.642857142855,
        1704.0638461640604,
        93.2134285714286,
    ),
];

#[test]
fn pairwise_sum_variance_percentile_match_numpy() {
    let x: Vec<f64> = (0..1001)
        .map(|i| ((i * 7919) % 1000) as f64 / 7.0 - 50.0 + i as f64 * 1e-3)
        .collect();
    for (n, sum, var, p999) in PAIRWISE {
        assert_eq!(pairwise_sum(&x[..n]), sum, "sum of {n}");
        assert_eq!(variance(&x[..n]), var, "variance of {n}");
        assert_eq!(percentile(&x[..n], 99.9), p999, "99.9th percentile of {n}");
    }
    // a naive left-to-right sum differs from numpy's at n = 1000
    let naive: f64 = x[..1000].iter().sum();
    assert_ne!(naive, PAIRWISE[9].1);
}

// ------------------------------------------------- spread at a study size

#[test]
fn spread_over_disjoint_blocks_by_hand() {
    // 7 networks, N = 3: blocks [1, 2, 3] and [4, 5, 6]; network 6 (7.0) is
    // left out
    let means = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
    let s = spread_at_n(&means, 3).unwrap();
    assert_eq!((s.n, s.blocks, s.unused), (3, 2, 1));
    assert_eq!(s.coverage, 1.0 / 3.0);
    assert_eq!(s.best_mean.blocks, [3.0, 6.0]);
    assert_eq!(
        (s.best_mean.min, s.best_mean.median, s.best_mean.max),
        (3.0, 4.5, 6.0)
    );
    // np.percentile([1, 2, 3], 99.9) = 2.998, and 5.998 for [4, 5, 6]
    let p = &s.p99_9_mean;
    assert_eq!(
        p.blocks,
        [
            percentile(&[1.0, 2.0, 3.0], 99.9),
            percentile(&[4.0, 5.0, 6.0], 99.9)
        ]
    );
    assert!((p.blocks[0] - 2.998).abs() < 1e-12 && (p.blocks[1] - 5.998).abs() < 1e-12);
    assert_eq!((p.min, p.max), (p.blocks[0], p.blocks[1]));
    assert_eq!(p.median, percentile(&p.blocks, 50.0));
    assert_eq!(s.best_mean.blocks_at_or_above(6.0), 1);
    assert_eq!(s.best_mean.blocks_at_or_above(2.0), 2);
    assert_eq!(s.best_mean.blocks_at_or_above(6.5), 0);
}

#[test]
fn spread_blocks_follow_sample_order_and_median_is_numpys() {
    // N = 2, 5 blocks: the best of each pair, in order; odd K: the middle one
    let means = [0.0, 9.0, 5.0, 1.0, -3.0, -2.0, 4.0, 4.0, 7.0, 8.0];
    let s = spread_at_n(&means, 2).unwrap();
    assert_eq!(s.best_mean.blocks, [9.0, 5.0, -2.0, 4.0, 8.0]);
    assert_eq!(
        (s.best_mean.min, s.best_mean.median, s.best_mean.max),
        (-2.0, 5.0, 9.0)
    );
    assert_eq!((s.unused, s.coverage), (0, 4.0 / 6.0));
    // N = 1: every network is its own block; best = p99.9 = the mean itself
    let s = spread_at_n(&means, 1).unwrap();
    assert_eq!(s.best_mean.blocks, means);
    assert_eq!(s.p99_9_mean.blocks, means);
    assert_eq!(s.best_mean.median, 4.0);
}

#[test]
fn spread_refuses_zero_and_too_few_networks() {
    let means = [1.0; 7];
    assert_eq!(spread_at_n(&means, 0), Err(SpreadError::Zero));
    let e = spread_at_n(&means, 4).unwrap_err();
    assert_eq!(
        e,
        SpreadError::TooFewSamples {
            n: 4,
            samples: 7,
            needed: 8,
            largest: 3
        }
    );
    assert_eq!(
        e.to_string(),
        "7 networks hold fewer than 2 disjoint blocks of 4 (2 × 4 = 8 are needed); \
         choose N ≤ 3 or run more networks (rwg run MANIFEST --samples 8 --out NEW_DIR)"
    );
    // exactly one block, and more than the cell: refused too
    assert!(spread_at_n(&means, 7).is_err() && spread_at_n(&means, 100).is_err());
    let e = spread_at_n(&[1.0], 1).unwrap_err();
    assert!(
        e.to_string().ends_with(
            "are needed); run more networks (rwg run MANIFEST --samples 2 --out NEW_DIR)"
        ),
        "{e}"
    );
    assert!(spread_at_n(&means, 3).is_ok());
}

#[test]
fn spread_is_deterministic_and_absent_unless_asked() {
    // a pseudo-random cell (an LCG, so the test needs no RNG crate)
    let mut x: u64 = 12345;
    let means: Vec<f64> = (0..5000)
        .map(|_| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64 * 100.0 - 50.0
        })
        .collect();
    let a = spread_at_n(&means, 1000).unwrap();
    let b = spread_at_n(&means, 1000).unwrap();
    assert_eq!(
        serde_json::to_string(&a).unwrap(),
        serde_json::to_string(&b).unwrap()
    );
    // every block's statistics as computed directly on its slice
    for (k, block) in means.chunks_exact(1000).enumerate() {
        assert_eq!(a.best_mean.blocks[k], max(block));
        assert_eq!(a.p99_9_mean.blocks[k], percentile(block, 99.9));
    }
    assert!(a.best_mean.min <= a.best_mean.median && a.best_mean.median <= a.best_mean.max);
    assert!(a.p99_9_mean.max <= a.best_mean.max);
    // the whole cell's best is the best block's best
    assert_eq!(a.best_mean.max, max(&means));

    // a summary carries no spread unless one is set, and its JSON has no key
    let scores: Vec<f64> = means.iter().flat_map(|&m| [m, m]).collect();
    let steps = vec![1u32; scores.len()];
    let mut m = meta(None);
    m.samples = 5000;
    m.episodes = 2;
    let mut s = summarize_cell(&m, 2, &scores, &steps, &per_sample(&scores, 2));
    assert!(s.at_n.is_none());
    let plain = serde_json::to_string(&s).unwrap();
    assert!(!plain.contains("at_n"), "{plain}");
    s.at_n = Some(a);
    let with = serde_json::to_string(&s).unwrap();
    assert!(with.starts_with(&plain[..plain.len() - 1]) && with.contains("\"at_n\":{\"n\":1000,"));
    let back: CellSummary = serde_json::from_str(&plain).unwrap();
    assert!(back.at_n.is_none());
}

/// Returns at rwg's bound (`MAX_RETURN`, the largest it takes) keep every
/// statistic finite: a sample's alternating extremes (the largest variance),
/// and a cell of them; and the bound holds for the largest study.
#[test]
fn returns_at_the_bound_keep_every_statistic_finite() {
    use rwg_core::sampler::MAX_RETURN;
    let (samples, episodes) = (crate::limits::MAX_SAMPLES, crate::limits::MAX_EPISODES);
    // the variance's sum of squared deviations (each at most (2 bound)^2)
    assert!(4.0 * samples as f64 * f64::from(episodes) * MAX_RETURN * MAX_RETURN < f64::MAX);
    let scores: Vec<f64> = (0..64)
        .map(|i| if i % 3 == 0 { -MAX_RETURN } else { MAX_RETURN })
        .collect();
    let stats = per_sample(&scores, 8);
    for s in &stats {
        let all = [s.mean, s.variance, s.std, s.min, s.max];
        assert!(all.iter().all(|v| v.is_finite()), "{s:?}");
    }
    let s = summarize_cell(&meta(Some(1.0)), 8, &scores, &[1; 64], &stats);
    let mut all = vec![s.best_mean, s.best_variance, s.worst_mean, s.mean_of_means];
    all.extend([s.mean_variance, s.median_mean, s.p99_9_mean]);
    all.extend(s.mean_percentiles.iter().map(|p| p.value));
    assert!(all.iter().all(|v| v.is_finite()), "{all:?}");
}

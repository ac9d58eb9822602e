use super::*;
use crate::tanh::tanh;
use rwg_env::space::BoxSpace;

fn n_weights(obs: usize, hidden: &[usize], out: usize, bias: bool) -> usize {
    NetShape::new(
        obs,
        &Architecture {
            hidden: hidden.to_vec(),
            bias,
        },
        out,
    )
    .n_weights()
}

/// The paper's appendix tables of weight counts.
#[test]
fn weight_counts_match_the_paper() {
    // CartPole: 4 inputs, 2 outputs; Acrobot: 6 inputs, 3 outputs;
    // MountainCar: 2 in, 3 out; MountainCarContinuous: 2 in, 1 out;
    // Pendulum: 3 in, 1 out.
    let cases: [(usize, usize, [usize; 3], [usize; 3]); 5] = [
        (4, 2, [8, 24, 40], [10, 30, 50]),
        (6, 3, [18, 36, 52], [21, 43, 63]),
        (2, 3, [6, 20, 36], [9, 27, 47]),
        (2, 1, [2, 12, 28], [3, 17, 37]),
        (3, 1, [3, 16, 32], [4, 21, 41]),
    ];
    let archs: [&[usize]; 3] = [&[], &[4], &[4, 4]];
    for (obs, out, no_bias, bias) in cases {
        for (k, h) in archs.iter().enumerate() {
            assert_eq!(
                n_weights(obs, h, out, false),
                no_bias[k],
                "obs {obs} hidden {h:?}"
            );
            assert_eq!(
                n_weights(obs, h, out, true),
                bias[k],
                "obs {obs} hidden {h:?} bias"
            );
        }
    }
}

#[test]
fn forward_pass_by_hand() {
    // 2 inputs, hidden [2], 1 output in [-2, 2], with bias.
    let arch = Architecture {
        hidden: vec![2],
        bias: true,
    };
    let space = Space::Box(BoxSpace::symmetric(&[2.0]));
    let mut p = Policy::new(NetShape::new(2, &arch, 1), &space);
    // layer 1: rows [w00 w01 b0], [w10 w11 b1]; layer 2: [v0 v1 c]
    p.weights_mut()
        .copy_from_slice(&[0.5, -1.0, 0.25, 2.0, 0.0, -0.5, 1.5, -0.75, 0.1]);
    let x = [0.3, 0.7];
    let h0 = tanh(0.5 * 0.3 - 0.7 + 0.25f64);
    let h1 = tanh(2.0 * 0.3 + 0.0 * 0.7 + -0.5f64);
    let y = tanh(1.5 * h0 - 0.75 * h1 + 0.1f64);
    match p.act(&x) {
        Action::Continuous(a) => assert_eq!(a, &[2.0 * y]),
        _ => panic!("expected a continuous action"),
    }
}

#[test]
fn asymmetric_bounds_map_affinely() {
    let arch = Architecture {
        hidden: vec![],
        bias: false,
    };
    let space = Space::Box(BoxSpace::new(vec![0.0], vec![1.0]));
    let mut p = Policy::new(NetShape::new(1, &arch, 1), &space);
    p.weights_mut()[0] = 1.0;
    let Action::Continuous(a) = p.act(&[0.5]) else {
        panic!()
    };
    assert_eq!(a[0], 0.0 + (tanh(0.5) + 1.0) / 2.0 * 1.0);
}

/// numpy's argmax of the computed tanh values: the first maximum.
fn numpy_argmax_of_tanh(z: &[f64]) -> usize {
    let t: Vec<f64> = z.iter().map(|v| tanh(*v)).collect();
    let mut expect = 0;
    for i in 1..t.len() {
        if t[i] > t[expect] {
            expect = i;
        }
    }
    expect
}

#[test]
fn argmax_is_numpy_argmax_of_tanh() {
    let cases: [&[f64]; 9] = [
        &[0.1, 0.2],
        &[0.3, -0.3, 0.3],
        &[25.0, 30.0],       // both saturate to 1.0: first wins
        &[-30.0, -25.0],     // both -1.0: first wins
        &[1.0, 1.0 + 1e-17], // equal after rounding
        &[4.0, 4.0 + 1e-12], // distinct tanh values? decided by tanh
        &[-1.0, 0.0, 19.5, 22.0],
        &[19.5, 22.0, 19.0], // a later, smaller z ties after saturation
        &[0.7, 0.7 + 2e-16, 0.7 + 1e-16],
    ];
    for z in cases {
        assert_eq!(argmax_tanh(z), numpy_argmax_of_tanh(z), "{z:?}");
    }
}

#[test]
fn argmax_matches_numpy_on_near_ties() {
    // Random vectors whose entries are often within a few ulps of each
    // other or saturated, where the shortcut must hand over to tanh.
    let mut s: u64 = 3;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        s
    };
    for _ in 0..200_000 {
        let r = next();
        let base = ((r >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 50.0;
        let z: Vec<f64> = (0..3)
            .map(|_| {
                let k = (next() % 7) as i64 - 3;
                f64::from_bits((base.to_bits() as i64 + k) as u64)
            })
            .collect();
        assert_eq!(argmax_tanh(&z), numpy_argmax_of_tanh(&z), "{z:?}");
    }
}

/// `actions_into` with the lanes of `mask_bits` gives `action`'s values
/// for those lanes and leaves the others' slots as they were.
fn check_actions_into<const K: usize>(lanes: &mut PolicyLanes<K>, mask_bits: u64, what: &str) {
    let len = match lanes.map {
        ActionMap::Argmax => 1,
        _ => lanes.z.len(),
    };
    let mask: [u8; K] = std::array::from_fn(|l| ((mask_bits >> l) & 1) as u8);
    let untouched = -12345.5;
    let mut out = vec![untouched; K * len];
    lanes.actions_into(&mask, &mut out);
    for (l, &m) in mask.iter().enumerate() {
        let got = &out[l * len..(l + 1) * len];
        if m == 0 {
            assert!(
                got.iter().all(|&v| v == untouched),
                "{what}: lane {l} is not in the mask but was written"
            );
            continue;
        }
        let same = match lanes.action(l) {
            Action::Discrete(a) => got == [a as f64],
            Action::Continuous(v) => v.iter().zip(got).all(|(x, y)| x.to_bits() == y.to_bits()),
        };
        assert!(same, "{what}: lane {l}: actions_into gave {got:?}");
    }
}

/// Every lane of `PolicyLanes` (with every instruction set this CPU has)
/// acts exactly as `Policy::act` with the same weights, through `action`
/// and through `actions_into`.
#[test]
fn lanes_act_as_single_policies() {
    let spaces = [
        Space::Discrete { n: 3 },
        Space::Box(BoxSpace::symmetric(&[2.0])),
        Space::Box(BoxSpace::symmetric(&[2.0, 0.5])),
        Space::Box(BoxSpace::new(vec![-1.0, 0.0], vec![3.0, 1.0])),
    ];
    let mut s: u64 = 17;
    let mut rand = move |scale: f64| {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * scale
    };
    const K: usize = 5;
    for simd in Simd::available_levels() {
        for space in &spaces {
            for hidden in [vec![], vec![4], vec![3, 4], vec![7, 2, 5]] {
                for bias in [false, true] {
                    let arch = Architecture {
                        hidden: hidden.clone(),
                        bias,
                    };
                    let shape = NetShape::new(4, &arch, NetShape::outputs_for(space));
                    let mut lanes = PolicyLanes::<K>::new(shape.clone(), space);
                    lanes.simd = simd;
                    let mut singles: Vec<Policy> = (0..K)
                        .map(|l| {
                            let mut p = Policy::new(shape.clone(), space);
                            p.weights_mut().iter_mut().for_each(|w| *w = rand(3.0));
                            lanes.set_weights(l, p.weights());
                            p
                        })
                        .collect();
                    for t in 0..50u64 {
                        let obs: Vec<f64> = (0..K * 4).map(|_| rand(4.0)).collect();
                        lanes.forward(&obs);
                        let mask_bits = if t % 5 == 0 {
                            u64::MAX
                        } else {
                            (rand(1.0).to_bits() >> 7) ^ t
                        };
                        let what = format!("{simd:?} {space:?} {hidden:?} {bias}");
                        check_actions_into(&mut lanes, mask_bits, &what);
                        for (l, p) in singles.iter_mut().enumerate() {
                            let want = p.act(&obs[l * 4..(l + 1) * 4]);
                            let got = lanes.action(l);
                            let same = match (want, got) {
                                (Action::Discrete(a), Action::Discrete(b)) => a == b,
                                (Action::Continuous(a), Action::Continuous(b)) => {
                                    a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
                                }
                                _ => false,
                            };
                            assert!(same, "{simd:?} {space:?} {hidden:?} {bias}: lane {l}");
                        }
                    }
                }
            }
        }
    }
}

/// The all-lanes argmax pass in `forward` picks what `Policy::act`
/// picks on edge outputs: ties, outputs within 1e-6, at and beyond +-5,
/// saturated, NaN and infinite (identity weights, so the outputs are the
/// observations).
#[test]
fn lanes_argmax_matches_policy_on_edges() {
    let arch = Architecture {
        hidden: vec![],
        bias: false,
    };
    let edges = [
        0.0,
        -0.0,
        0.3,
        0.3 + 1e-7,
        0.3 + 2e-6,
        5.0,
        5.0 + 1e-15,
        4.9999999,
        -5.0,
        -5.0 - 1e-15,
        19.5,
        22.0,
        -30.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    const K: usize = 16;
    for n in [2usize, 3] {
        let space = Space::Discrete { n };
        let shape = NetShape::new(n, &arch, n);
        for simd in Simd::available_levels() {
            let mut lanes = PolicyLanes::<K>::new(shape.clone(), &space);
            lanes.simd = simd;
            let mut single = Policy::new(shape.clone(), &space);
            for (i, w) in single.weights_mut().iter_mut().enumerate() {
                *w = if i % (n + 1) == 0 { 1.0 } else { 0.0 };
            }
            for l in 0..K {
                lanes.set_weights(l, single.weights());
            }
            // Every combination of edge values over the outputs, K lanes at a time.
            let combos: Vec<Vec<f64>> = (0..edges.len().pow(n as u32))
                .map(|mut c| {
                    (0..n)
                        .map(|_| {
                            let v = edges[c % edges.len()];
                            c /= edges.len();
                            v
                        })
                        .collect()
                })
                .collect();
            for chunk in combos.chunks(K) {
                let mut obs = vec![0.1; K * n];
                for (l, z) in chunk.iter().enumerate() {
                    obs[l * n..(l + 1) * n].copy_from_slice(z);
                }
                lanes.forward(&obs);
                check_actions_into(&mut lanes, u64::MAX, &format!("{simd:?} n={n}"));
                check_actions_into(&mut lanes, 0x5a5a, &format!("{simd:?} n={n}, some lanes"));
                for l in 0..chunk.len() {
                    let want = single.act(&obs[l * n..(l + 1) * n]);
                    let got = lanes.action(l);
                    let same =
                        matches!((want, got), (Action::Discrete(a), Action::Discrete(b)) if a == b);
                    assert!(same, "{simd:?} n={n}: {:?}", &obs[l * n..(l + 1) * n]);
                }
            }
        }
    }
}

#[test]
fn discrete_policy_acts_in_range() {
    let arch = Architecture {
        hidden: vec![4, 4],
        bias: true,
    };
    let space = Space::Discrete { n: 3 };
    let mut p = Policy::new(NetShape::new(6, &arch, 3), &space);
    for (i, w) in p.weights_mut().iter_mut().enumerate() {
        *w = ((i * 7919) % 13) as f64 / 6.0 - 1.0;
    }
    let Action::Discrete(a) = p.act(&[0.1, -0.2, 0.3, 0.4, -1.0, 2.0]) else {
        panic!()
    };
    assert!((0..3).contains(&a));
}

/// `non_finite_outputs` names the lanes whose outputs overflow (an infinite
/// product) or are NaN (through a hidden layer: tanh keeps a NaN), at every
/// SIMD level, and `non_finite_output` gives the value.
#[test]
fn non_finite_outputs_name_their_lanes() {
    const K: usize = 4;
    let space = Space::Discrete { n: 2 };
    for hidden in [vec![], vec![3]] {
        let arch = Architecture {
            hidden: hidden.clone(),
            bias: false,
        };
        let shape = NetShape::new(2, &arch, 2);
        for simd in Simd::available_levels() {
            let mut lanes = PolicyLanes::<K>::new(shape.clone(), &space);
            lanes.simd = simd;
            for l in 0..K {
                lanes.set_weights(l, &vec![1e300; shape.n_weights()]);
            }
            // lane 1: 1e300 * 1e10 overflows; lane 2: inf - inf is NaN
            let obs = [1.0, 2.0, 1e10, 0.0, 1e10, -1e10, 0.5, -0.5];
            lanes.forward(&obs);
            let mask = lanes.non_finite_outputs();
            if hidden.is_empty() {
                assert_eq!(mask, 0b0110, "{simd:?}");
                assert_eq!(lanes.non_finite_output(1), Some(f64::INFINITY));
                assert!(lanes.non_finite_output(2).unwrap().is_nan());
            } else {
                // tanh saturates lane 1's infinity; lane 2's NaN goes through
                assert_eq!(mask, 0b0100, "{simd:?} {hidden:?}");
            }
            assert_eq!(lanes.non_finite_output(0), None);
        }
    }
}

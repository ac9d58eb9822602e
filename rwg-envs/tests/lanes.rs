//! The sampler's side-by-side episodes (`LaneWorker`, used by `run_blocks`)
//! give exactly the results of running each network's episodes one after the
//! other (`Worker::run_sample`), for every built-in env and several
//! architectures, block sizes and episode counts.

use rwg_core::policy::Architecture;
use rwg_core::sampler::{
    run_blocks, BlockResult, CellPlan, EpisodeResult, LaneWorker, SampleError, WeightDist, Worker,
};
use rwg_envs::{make, EnvOptions, REGISTRY};

fn plan(env: &str, hidden: &[usize], bias: bool, episodes: u32) -> CellPlan {
    CellPlan {
        seed: 5,
        env_id: env.to_string(),
        arch: Architecture {
            hidden: hidden.to_vec(),
            bias,
        },
        episodes,
        dist: WeightDist::Normal { std: 1.0 },
        policy: rwg_core::policy::PolicyKind::Network,
        non_finite: Default::default(),
    }
}

/// Results that no episode produces (so a slot left unwritten shows).
fn unwritten(n: usize) -> Vec<EpisodeResult> {
    vec![
        EpisodeResult {
            score: f64::NAN,
            steps: u32::MAX,
            non_finite: false,
        };
        n
    ]
}

/// Sample by sample, episode by episode.
fn sequential(plan: &CellPlan, samples: std::ops::Range<u64>) -> Vec<EpisodeResult> {
    let opts = EnvOptions::default();
    let mut w = Worker::new(make(&plan.env_id, &opts).unwrap(), plan);
    let e = plan.episodes as usize;
    let mut out = vec![
        EpisodeResult {
            score: 0.0,
            steps: 0,
            non_finite: false,
        };
        (samples.end - samples.start) as usize * e
    ];
    for (k, s) in samples.enumerate() {
        w.run_sample(plan, s, &mut out[k * e..(k + 1) * e]).unwrap();
    }
    out
}

fn assert_same(a: &[EpisodeResult], b: &[EpisodeResult], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            x.steps == y.steps && x.score.to_bits() == y.score.to_bits(),
            "{what}: episode {i}: {x:?} vs {y:?}"
        );
    }
}

#[test]
fn lanes_match_sequential_episodes_bit_for_bit() {
    let opts = EnvOptions::default();
    let archs: [&[usize]; 3] = [&[], &[4], &[4, 4]];
    for r in REGISTRY {
        for hidden in archs {
            for bias in [false, true] {
                // 5 samples x 3 episodes: 15 episodes over 4 lanes, weights
                // changing within lanes.
                let p = plan(r.id, hidden, bias, 3);
                let want = sequential(&p, 10..15);
                let mut lw = LaneWorker::<_, 4>::new(|| make(r.id, &opts).unwrap(), &p);
                let mut got = unwritten(want.len());
                lw.run_block(&p, 10..15, &mut got).unwrap();
                let what = format!("{} {hidden:?} bias {bias}", r.id);
                assert_same(&got, &want, &what);
                // Reusing the worker for another block.
                let want2 = sequential(&p, 15..16);
                let mut got2 = unwritten(want2.len());
                lw.run_block(&p, 15..16, &mut got2).unwrap();
                assert_same(&got2, &want2, &what);
            }
        }
    }
}

#[test]
fn run_blocks_matches_sequential_for_odd_blocks() {
    let p = plan("Pendulum-v1", &[4], false, 2);
    let want = sequential(&p, 0..7);
    let blocks = [0..1, 1..4, 4..7];
    let mut got = vec![];
    run_blocks(
        &p,
        &blocks,
        2,
        || make("Pendulum-v1", &EnvOptions::default()).unwrap(),
        |b: BlockResult| -> Result<(), SampleError> {
            got.extend(b.episodes);
            Ok(())
        },
    )
    .unwrap();
    assert_same(&got, &want, "Pendulum-v1 blocks");
}

#[test]
fn fewer_episodes_than_lanes() {
    let opts = EnvOptions::default();
    let p = plan("CartPole-v0", &[4, 4], true, 1);
    let want = sequential(&p, 3..5);
    let mut lw = LaneWorker::<_, 8>::new(|| make("CartPole-v0", &opts).unwrap(), &p);
    let mut got = unwritten(want.len());
    lw.run_block(&p, 3..5, &mut got).unwrap();
    assert_same(&got, &want, "2 episodes on 8 lanes");
}

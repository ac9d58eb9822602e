use super::*;
use crate::block::draw_block_weights;
use crate::plan::{reset_seed, WeightDist};
use crate::policy::{Architecture, NetShape};
use rwg_env::Space;

fn plan(episodes: u32) -> CellPlan {
    CellPlan {
        seed: 3,
        env_id: "Toy-v0".into(),
        arch: Architecture {
            hidden: vec![],
            bias: false,
        },
        episodes,
        dist: WeightDist::Normal { std: 1.0 },
        policy: crate::policy::PolicyKind::Network,
        non_finite: Default::default(),
    }
}

/// A 2-lane policy over 1 observation, 1 discrete-argmax output pair.
fn policy() -> PolicyLanes<2> {
    let space = Space::Discrete { n: 2 };
    PolicyLanes::new(NetShape::new(1, &plan(1).arch, 2), &space)
}

fn results(n: usize) -> Vec<EpisodeResult> {
    vec![EpisodeResult::EMPTY; n]
}

fn ending(episodes: u32) -> CellPlan {
    CellPlan {
        non_finite: NonFinite::End,
        ..plan(episodes)
    }
}

#[test]
fn episodes_are_dealt_in_order_with_their_networks_weights() {
    let (plan, mut policy) = (plan(2), policy());
    let out = results(4);
    let mut deal = Deal::new(&plan, 5..7, 2, Vec::new(), &out);
    let mut want = vec![];
    draw_block_weights(&plan, &(5..7), 2, &mut want);
    let mut lane = Lane::<bool>::IDLE;
    for item in 0..4 {
        let ep = deal.next(&mut policy, 1, &mut lane).expect("an episode");
        let k = item / 2;
        assert_eq!(
            (ep.item, ep.k, lane.item, lane.weights_of),
            (item, k, item, k)
        );
        assert_eq!(ep.seed, reset_seed(3, "Toy-v0", 5 + k as u64, ep.episode));
    }
    assert!(deal.next(&mut policy, 1, &mut lane).is_none());
    let mut weights = vec![];
    assert_eq!(deal.finish(&mut weights), Ok(()));
    assert_eq!(weights, want, "the drawn weights come back");
}

#[test]
fn nothing_is_dealt_after_a_failure_and_later_episodes_are_cut_off() {
    let (plan, mut policy) = (plan(3), policy());
    let out = results(3);
    let mut deal = Deal::new(&plan, 0..1, 2, Vec::new(), &out);
    let mut lanes = [Lane::<bool>::IDLE; 2];
    for (i, lane) in lanes.iter_mut().enumerate() {
        deal.next(&mut policy, i, lane).expect("an episode");
        lane.begin(true);
    }
    deal.fail(0, 4, EnvError::Other("broke".into()));
    let mut idle = Lane::<bool>::IDLE;
    assert!(deal.next(&mut policy, 0, &mut idle).is_none());
    deal.cut_off(&mut lanes);
    assert_eq!(lanes.map(|l| l.running()), [true, false]);
    let err = deal.finish(&mut Vec::new()).unwrap_err();
    assert_eq!((err.sample, err.episode, err.step), (0, 0, 4));
}

#[test]
fn a_finished_episode_is_recorded_and_an_overflowing_one_fails() {
    let plan = plan(2);
    let mut out = results(2);
    let mut deal = Deal::new(&plan, 0..1, 2, Vec::new(), &out);
    let mut lane = Lane::<bool>::IDLE;
    lane.begin(true);
    assert!(!deal.stepped(&mut lane, 1.5, false, &mut out));
    assert!(deal.stepped(&mut lane, 2.0, true, &mut out));
    assert!(!lane.running());
    assert_eq!((out[0].score, out[0].steps), (3.5, 2));
    lane.item = 1;
    lane.begin(true);
    assert!(!deal.stepped(&mut lane, 1e100, false, &mut out));
    assert_eq!(lane.failing_step(), 2);
    // the return leaves ±1e100 at step 2: the episode fails there
    assert!(!deal.stepped(&mut lane, 1e100, false, &mut out));
    assert!(!lane.running());
    let err = deal.finish(&mut Vec::new()).unwrap_err();
    assert_eq!((err.episode, err.step), (1, 2));
    assert!(
        err.to_string().contains("total reward is 2e100, beyond"),
        "{err}"
    );
}

#[test]
fn with_end_a_reward_not_finite_ends_the_episode_with_the_return_before_it() {
    let end = ending(3);
    let mut out = results(3);
    let mut deal = Deal::new(&end, 0..1, 2, Vec::new(), &out);
    let mut lane = Lane::<bool>::IDLE;
    lane.begin(true);
    assert!(!deal.stepped(&mut lane, 1.5, false, &mut out));
    assert!(deal.stepped(&mut lane, f64::NAN, false, &mut out));
    assert!(!lane.running());
    assert_eq!(out[0], EpisodeResult::cut(1.5, 2));
    // a return that leaves ±1e100 ends the episode too
    lane.item = 1;
    lane.begin(true);
    assert!(!deal.stepped(&mut lane, -1e100, false, &mut out));
    assert!(deal.stepped(&mut lane, -1e100, true, &mut out));
    assert_eq!(out[1], EpisodeResult::cut(-1e100, 2));
    // an env's NonFinite error of a step ends it; any other fails it
    lane.item = 2;
    lane.begin(true);
    lane.score = 4.0;
    let nan = EnvError::NonFinite("obs[0] = NaN".into());
    assert!(deal.env_failed(&lane, 1, nan.clone(), &mut out));
    assert_eq!(out[2], EpisodeResult::cut(4.0, 1));
    assert_eq!(deal.finish(&mut Vec::new()), Ok(()));
    // ... but not at a reset, nor with the default
    for (plan, step) in [(ending(3), 0), (plan(3), 1)] {
        let mut deal = Deal::new(&plan, 0..1, 2, Vec::new(), &out);
        assert!(!deal.env_failed(&lane, step, nan.clone(), &mut out));
        let err = deal.finish(&mut Vec::new()).unwrap_err();
        assert_eq!((err.episode, err.step), (2, step));
    }
}

#[test]
fn running_lanes_with_outputs_not_finite_fail_at_their_next_step() {
    let (plan, mut policy) = (plan(1), policy());
    let out = results(2);
    let mut deal = Deal::new(&plan, 0..2, 2, Vec::new(), &out);
    let mut lanes = [Lane::<bool>::IDLE; 2];
    for (i, lane) in lanes.iter_mut().enumerate() {
        deal.next(&mut policy, i, lane).expect("an episode");
        lane.begin(true);
        lane.steps = 6;
    }
    policy.forward(&[1.0, 1.0]);
    let mut out = results(2);
    assert_eq!(
        deal.stop_non_finite(&policy, &mut lanes, &mut out),
        (false, 0)
    );
    policy.forward(&[1.0, f64::INFINITY]);
    assert_eq!(
        deal.stop_non_finite(&policy, &mut lanes, &mut out),
        (true, 0)
    );
    assert_eq!(lanes.map(|l| l.running()), [true, false]);
    let err = deal.finish(&mut Vec::new()).unwrap_err();
    assert_eq!((err.sample, err.step), (1, 7));
    assert!(err.error.to_string().starts_with("the network's output is"));
}

#[test]
fn with_end_lanes_with_outputs_not_finite_end_before_their_next_step() {
    let (plan, mut policy) = (ending(1), policy());
    let mut out = results(2);
    let mut deal = Deal::new(&plan, 0..2, 2, Vec::new(), &out);
    let mut lanes = [Lane::<bool>::IDLE; 2];
    for (i, lane) in lanes.iter_mut().enumerate() {
        deal.next(&mut policy, i, lane).expect("an episode");
        lane.begin(true);
        lane.steps = 6;
        lane.score = 2.5;
    }
    policy.forward(&[1.0, f64::INFINITY]);
    assert_eq!(
        deal.stop_non_finite(&policy, &mut lanes, &mut out),
        (true, 0b10)
    );
    assert_eq!(lanes.map(|l| l.running()), [true, false]);
    assert_eq!(out[1], EpisodeResult::cut(2.5, 6));
    assert_eq!(deal.finish(&mut Vec::new()), Ok(()));
}

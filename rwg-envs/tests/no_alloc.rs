//! The step loop allocates nothing: `Environment::step` of every built-in
//! env, `Policy::act`, `PolicyLanes::forward` / `action` / `actions_into`
//! (of networks and of random actions), and `reset`
//! (counted with a global allocator that counts the calls of this thread),
//! and the lockstep envs' `reset_many` / `step_many`.

use rwg_core::policy::{Architecture, NetShape, Policy, PolicyLanes};
use rwg_env::seeding::Pcg64;
use rwg_env::{Action, ActionDtype, Environment, Space};
use rwg_envs::{
    visit, visit_lockstep, EnvOptions, EnvVisitor, LockstepEnv, LockstepVisitor, REGISTRY,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCS.try_with(|a| a.set(a.get() + 1));
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCS.try_with(|a| a.set(a.get() + 1));
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by this thread while running `f`.
fn allocations(f: impl FnOnce()) -> u64 {
    let before = ALLOCS.with(Cell::get);
    f();
    ALLOCS.with(Cell::get) - before
}

/// Runs 2000 steps of policy + env (resetting when episodes end) and counts
/// the allocations, after building everything.
struct StepLoop {
    hidden: Vec<usize>,
}

impl EnvVisitor for StepLoop {
    type Output = (u64, u64);
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, mut env: E) -> (u64, u64) {
        let spec = env.spec().clone();
        let arch = Architecture {
            hidden: self.hidden,
            bias: true,
        };
        let shape = NetShape::new(
            spec.obs_dim(),
            &arch,
            NetShape::outputs_for(&spec.action_space),
        );
        let mut policy = Policy::new(shape.clone(), &spec.action_space);
        let mut rng = Pcg64::from_seed(1);
        for w in policy.weights_mut() {
            *w = rng.uniform(-2.0, 2.0);
        }
        let mut lanes = PolicyLanes::<4>::new(shape, &spec.action_space);
        for l in 0..4 {
            lanes.set_weights(l, policy.weights());
        }
        let mut obs = vec![0.0; spec.obs_dim()];
        let mut obs4 = vec![0.0; 4 * spec.obs_dim()];
        env.reset(0, &mut obs).unwrap();
        let mut seed = 0;
        let steps = allocations(|| {
            for _ in 0..2000 {
                let s = env.step(policy.act(&obs), &mut obs).unwrap();
                if s.terminated || s.truncated {
                    seed += 1;
                    env.reset(seed, &mut obs).unwrap();
                }
            }
        });
        let lane_acts = allocations(|| {
            for i in 0..2000 {
                let k = i % obs4.len();
                obs4[k] = (i as f64).sin();
                lanes.forward(&obs4);
                for l in 0..4 {
                    match (lanes.action(l), &spec.action_space) {
                        (Action::Discrete(a), Space::Discrete { n }) => {
                            assert!((a as usize) < *n)
                        }
                        (Action::Continuous(a), Space::Box(b)) => assert_eq!(a.len(), b.dim()),
                        _ => panic!("action of the wrong kind"),
                    }
                }
            }
        });
        (steps, lane_acts)
    }
}

#[test]
fn step_loop_allocates_nothing() {
    for r in REGISTRY {
        for hidden in [vec![], vec![4, 4]] {
            let (steps, lanes) = visit(
                r.id,
                &EnvOptions::default(),
                StepLoop {
                    hidden: hidden.clone(),
                },
            )
            .unwrap();
            assert_eq!(
                steps, 0,
                "{} {hidden:?}: policy + step + reset allocated",
                r.id
            );
            assert_eq!(lanes, 0, "{} {hidden:?}: PolicyLanes allocated", r.id);
        }
    }
}

/// Random actions (a cell with `policy = "random"`) allocate nothing per
/// step: `Policy::act`, `PolicyLanes::forward` / `action` / `actions_into`
/// of random policies, in every built-in env's action space.
#[test]
fn random_actions_allocate_nothing() {
    for r in REGISTRY {
        let spec = rwg_envs::make(r.id, &EnvOptions::default())
            .unwrap()
            .spec()
            .clone();
        let space = spec.action_space.clone();
        let mut policy = Policy::random(&space);
        policy.seed_actions(Pcg64::from_seed(5));
        let mut lanes = PolicyLanes::<4>::random(&space);
        for l in 0..4 {
            lanes.seed_lane(l, Pcg64::from_seed(l as u64));
        }
        let obs = vec![0.0; 4 * spec.obs_dim()];
        let mut out = vec![0.0; 4 * space.flat_dim()];
        let n = allocations(|| {
            for t in 0..2000 {
                let _ = policy.act(&obs);
                lanes.forward(&obs);
                let _ = lanes.action(t % 4);
                lanes.actions_into(&[1, u8::from(t % 3 == 0), 1, 0], &mut out);
            }
        });
        assert_eq!(n, 0, "{}: random actions allocated", r.id);
    }
}

/// 2000 lockstep steps of 16 lanes (a `PolicyLanes` choosing the actions
/// with `actions_into`,
/// finished lanes reset, every third lane masked out now and then): the
/// allocations of `reset_many` and `step_many`.
struct LockstepLoop;

impl LockstepVisitor for LockstepLoop {
    type Output = u64;
    fn visit<M: LockstepEnv + Clone + Send + Sync + 'static>(self, mut env: M) -> u64 {
        const N: usize = 16;
        let spec = env.spec().clone();
        let d = spec.obs_dim();
        let arch = Architecture {
            hidden: vec![4],
            bias: true,
        };
        let shape = NetShape::new(d, &arch, NetShape::outputs_for(&spec.action_space));
        let mut lanes = PolicyLanes::<N>::new(shape.clone(), &spec.action_space);
        let mut rng = Pcg64::from_seed(3);
        let mut w = vec![0.0; shape.n_weights()];
        for l in 0..N {
            for x in w.iter_mut() {
                *x = rng.uniform(-2.0, 2.0);
            }
            lanes.set_weights(l, &w);
        }
        let mut obs = vec![0.0; N * d];
        let mut actions = vec![0.0; N];
        let (mut rewards, mut term, mut trunc) = ([0.0; N], [0u8; N], [0u8; N]);
        let mut reset_mask = [1u8; N];
        let mut step_mask = [1u8; N];
        let mut seeds = [0u64; N];
        let mut next_seed = 0;
        // lanes_math chooses its implementations once per process (self-checks
        // that allocate); that is not part of the step loop.
        let _ = rwg_env::lanes_math::implementation();
        let _ = rwg_env::lanes_math::pow_implementation();
        allocations(|| {
            for t in 0..2000 {
                if reset_mask.contains(&1) {
                    for (i, s) in seeds.iter_mut().enumerate() {
                        if reset_mask[i] == 1 {
                            next_seed += 1;
                            *s = next_seed;
                        }
                    }
                    env.reset_many(&reset_mask, &seeds, &mut obs, &mut |_, e| panic!("{e}"));
                    reset_mask = [0; N];
                }
                lanes.forward(&obs);
                for (i, m) in step_mask.iter_mut().enumerate() {
                    *m = u8::from(!(i % 3 == 0 && t % 5 == 0));
                }
                // As the sampler's lockstep loop (rwg_core::many) chooses them.
                lanes.actions_into(&step_mask, &mut actions);
                env.step_many(
                    &step_mask,
                    &actions,
                    &mut obs,
                    &mut rewards,
                    &mut term,
                    &mut trunc,
                    &mut |_, e| panic!("{e}"),
                );
                for i in 0..N {
                    if step_mask[i] == 1 && (term[i] == 1 || trunc[i] == 1) {
                        reset_mask[i] = 1;
                    }
                }
            }
        })
    }
}

#[test]
fn lockstep_step_loop_allocates_nothing() {
    for r in REGISTRY {
        for dtype in [ActionDtype::F64, ActionDtype::F32] {
            let opts = EnvOptions {
                action_dtype: dtype,
                max_episode_steps: None,
            };
            let n = visit_lockstep::<16, _>(r.id, &opts, LockstepLoop)
                .unwrap_or_else(|_| panic!("{} has a lockstep version", r.id));
            assert_eq!(n, 0, "{} {dtype:?}: reset_many + step_many allocated", r.id);
        }
    }
}

//! The step loop allocates nothing: `Environment::step` of every built-in
//! env, `Policy::act`, `PolicyLanes::forward` / `action`, and `reset`
//! (counted with a global allocator that counts the calls of this thread).

use rwg_core::policy::{Architecture, NetShape, Policy, PolicyLanes};
use rwg_env::seeding::Pcg64;
use rwg_env::{Action, Environment, Space};
use rwg_envs::{visit, EnvOptions, EnvVisitor, REGISTRY};
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

//! The step call (`step`, and the lane loop of `step_many`): a fast path
//! for a well-formed call on a healthy instance, and a checked path that
//! finds and reports whatever is wrong with any other call; both convert the
//! C action with [`action_of`], checked against the action space.

use std::panic::{catch_unwind, AssertUnwindSafe};

use super::builder::ActionKind;
use super::trampolines::{env_err, obs_slice, panic_message, with_instance, Instance};
use crate::env::{Action, EnvError, Environment, Step};
use crate::plugin::abi::*;

/// Converts the C action to an [`Action`], checking it against the space.
fn action_of(a: &[f64], kind: ActionKind) -> Result<Action<'_>, String> {
    match kind {
        ActionKind::Discrete(n) => {
            if a.len() != 1 {
                return Err(format!(
                    "a discrete action has length 1, got action_len {}",
                    a.len()
                ));
            }
            let v = a[0];
            // The common case first, without `fract` (a libm call on
            // baseline x86-64): in range (false for NaN) and integral.
            if v >= 0.0 && v < n as f64 {
                let i = v as u64;
                if i as f64 == v {
                    return Ok(Action::Discrete(i as i64));
                }
            }
            if !v.is_finite() || v.fract() != 0.0 {
                return Err(format!("discrete action {v:?} is not an integer"));
            }
            if v < 0.0 || v >= n as f64 {
                return Err(format!(
                    "{v} is outside the action space Discrete({n}) (valid: 0..={})",
                    n - 1
                ));
            }
            Ok(Action::Discrete(v as i64))
        }
        ActionKind::Box(dim) => {
            if a.len() != dim {
                return Err(format!(
                    "action has {} values, the action space has {dim}",
                    a.len()
                ));
            }
            if let Some(i) = a.iter().position(|x| !x.is_finite()) {
                return Err(format!("action[{i}] is {:?}, not a finite number", a[i]));
            }
            Ok(Action::Continuous(a))
        }
    }
}

pub(super) unsafe extern "C" fn step<E: Environment>(
    env: *mut RwgEnv,
    action: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    out: *mut RwgStepOut,
) -> Status {
    // SAFETY: `step_inline`'s contract is `step`'s (the ABI's).
    unsafe { step_inline::<E>(env, action, action_len, obs, obs_len, out) }
}

/// The body of [`step`].
///
/// # Safety
/// The ABI's contract for `step`: `env` is NULL or an instance of `E` made
/// by this table, `action` NULL or valid for `action_len` reads, `obs` NULL
/// or valid for `obs_len` writes, `out` NULL or writable.
#[inline(always)]
pub(super) unsafe fn step_inline<E: Environment>(
    env: *mut RwgEnv,
    action: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    out: *mut RwgStepOut,
) -> Status {
    if !out.is_null() && !obs.is_null() && !action.is_null() {
        let keys = call_keys(obs_len, action_len);
        // SAFETY: the contract above, the three pointers checked non-NULL.
        match unsafe { step_fast::<E>(env, keys, action, action_len, obs, obs_len) } {
            Ok(s) => {
                // SAFETY: `out` is non-NULL, so writable.
                unsafe {
                    *out = RwgStepOut {
                        reward: s.reward,
                        terminated: u8::from(s.terminated),
                        truncated: u8::from(s.truncated),
                        reserved: [0; 6],
                    }
                };
                return RWG_OK;
            }
            Err(Some(status)) => return status,
            Err(None) => {}
        }
    }
    // SAFETY: `step_checked`'s contract is this function's.
    unsafe { step_checked::<E>(env, action, action_len, obs, obs_len, out) }
}

/// What the fast path of a step compares an instance with: the call's
/// observation and action lengths and the kind of action, packed into one
/// word (an instance that is not healthy has [`FastKey::NONE`], which no
/// call has).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) struct FastKey(u64);

impl FastKey {
    /// The key of no call.
    pub(super) const NONE: FastKey = FastKey(u64::MAX);

    /// The key of a call with these lengths on a discrete (`discrete`) or
    /// continuous action space; `NONE` for lengths no instance has.
    #[inline(always)]
    pub(super) fn of_call(obs_len: usize, action_len: usize, discrete: bool) -> FastKey {
        if obs_len > u32::MAX as usize || action_len > (u32::MAX >> 1) as usize {
            return FastKey::NONE;
        }
        FastKey(((obs_len as u64) << 32) | ((action_len as u64) << 1) | u64::from(discrete))
    }

    /// The key of a well-formed step call on a healthy instance with these
    /// spaces (its dimensions are at most 2^20, so it is never `NONE`).
    pub(super) fn of_instance(obs_dim: usize, action: ActionKind) -> FastKey {
        match action {
            ActionKind::Discrete(_) => FastKey::of_call(obs_dim, 1, true),
            ActionKind::Box(d) => FastKey::of_call(obs_dim, d, false),
        }
    }
}

/// The keys of a step call with these lengths on a discrete and on a
/// continuous action space.
#[inline(always)]
pub(super) fn call_keys(obs_len: usize, action_len: usize) -> (FastKey, FastKey) {
    (
        FastKey::of_call(obs_len, action_len, true),
        FastKey::of_call(obs_len, action_len, false),
    )
}

/// The fast path of a step, shared by `step` and `step_many`'s lane loop:
/// a well-formed call (`action` and `obs` non-NULL, the caller checked; its
/// [`call_keys`] in `keys`) on a healthy instance steps the env. `Err(None)`
/// if the call is unusual in any way: nothing has been done to the env
/// then, and the caller goes to [`step_checked`], which finds and reports
/// the problem, so the two paths behave the same. `Err(Some(status))` if the
/// env failed or panicked (recorded in the instance, as `step_checked`
/// records it).
///
/// # Safety
/// `step_inline`'s contract, with `action` and `obs` not NULL.
#[inline(always)]
pub(super) unsafe fn step_fast<E: Environment>(
    env: *mut RwgEnv,
    keys: (FastKey, FastKey),
    action: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
) -> Result<Step, Option<Status>> {
    // SAFETY: `env` is NULL or an instance of `E` (the contract).
    let Some(inst) = (unsafe { env.cast::<Instance<E>>().as_mut() }) else {
        return Err(None);
    };
    // SAFETY: `action` is valid for `action_len` reads (the contract).
    let Some(a) = (unsafe { action_fast(inst, keys, action, action_len) }) else {
        return Err(None);
    };
    // SAFETY: `obs` is valid for `obs_len` writes (the contract).
    let o = unsafe { std::slice::from_raw_parts_mut(obs, obs_len) };
    let env = &mut inst.env;
    match catch_unwind(AssertUnwindSafe(|| env.step(a, o))) {
        Ok(Ok(s)) => Ok(s),
        Ok(Err(e)) => Err(Some(step_error(inst, e))),
        Err(p) => Err(Some(step_panic(inst, p))),
    }
}

/// The action of a fast-path call on `inst` if the instance is healthy,
/// the lengths are its own (one comparison of [`FastKey`]s) and the action
/// is valid; `None` otherwise (no message).
///
/// # Safety
/// `action` is valid for `len` reads.
#[inline(always)]
unsafe fn action_fast<'a, E>(
    inst: &Instance<E>,
    (discrete, continuous): (FastKey, FastKey),
    action: *const f64,
    len: usize,
) -> Option<Action<'a>> {
    if inst.fast == discrete {
        // SAFETY: the key says `len` is 1: one read (the contract).
        let v = unsafe { *action };
        // 0 <= v < n (false for NaN; n is at most 2^53, exact) and
        // integral: exactly the valid actions, in two comparisons and one
        // round trip through i64 (in range, so the unchecked conversion is
        // exact truncation). -0.0 is action 0, as in `action_of`.
        if v >= 0.0 && v < inst.action_n {
            // SAFETY: 0 <= v < 2^53: finite and within i64.
            let i = unsafe { v.to_int_unchecked::<i64>() };
            if i as f64 == v {
                return Some(Action::Discrete(i));
            }
        }
        None
    } else if inst.fast == continuous {
        // SAFETY: `action` is valid for `len` reads (the contract).
        let a = unsafe { std::slice::from_raw_parts(action, len) };
        a.iter()
            .all(|x| x.is_finite())
            .then_some(Action::Continuous(a))
    } else {
        None
    }
}

#[cold]
#[inline(never)]
fn step_error<E>(inst: &mut Instance<E>, e: EnvError) -> Status {
    let (status, msg) = env_err(e);
    inst.set_error(&msg);
    status
}

#[cold]
#[inline(never)]
fn step_panic<E>(inst: &mut Instance<E>, p: Box<dyn std::any::Any + Send>) -> Status {
    inst.poison(panic_message(&*p));
    RWG_ERR_PANIC
}

/// `step` with every argument checked and every problem reported.
///
/// # Safety
/// `step_inline`'s contract.
#[cold]
#[inline(never)]
unsafe fn step_checked<E: Environment>(
    env: *mut RwgEnv,
    action: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    out: *mut RwgStepOut,
) -> Status {
    let call = |e: &mut E, obs_dim: usize, kind: ActionKind| {
        let invalid = |m: String| (RWG_ERR_INVALID_ARGUMENT, m);
        if out.is_null() {
            return Err(invalid("step: out is NULL".into()));
        }
        let a: &[f64] = if action_len == 0 {
            &[]
        } else if action.is_null() {
            return Err(invalid("step: action is NULL".into()));
        } else {
            // SAFETY: non-NULL: valid for `action_len` reads (the contract).
            unsafe { std::slice::from_raw_parts(action, action_len) }
        };
        let a = action_of(a, kind).map_err(invalid)?;
        // SAFETY: `obs` is NULL or valid for `obs_len` writes (the contract).
        let obs = unsafe { obs_slice(obs, obs_len, obs_dim) }?;
        let s = e.step(a, obs).map_err(env_err)?;
        // SAFETY: `out` was checked non-NULL: writable (the contract).
        unsafe {
            *out = RwgStepOut {
                reward: s.reward,
                terminated: u8::from(s.terminated),
                truncated: u8::from(s.truncated),
                reserved: [0; 6],
            }
        };
        Ok(())
    };
    // SAFETY: the contract (`env` NULL or an instance of `E`).
    unsafe { with_instance(env, call) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discrete_actions_must_be_integral_and_in_range() {
        let k = ActionKind::Discrete(3);
        assert_eq!(action_of(&[2.0], k), Ok(Action::Discrete(2)));
        for bad in [[3.0], [-1.0], [0.5], [f64::NAN], [f64::INFINITY]] {
            assert!(action_of(&bad, k).is_err(), "{bad:?}");
        }
        assert!(action_of(&[0.0, 1.0], k).is_err());
        assert!(action_of(&[], k).is_err());
        assert_eq!(action_of(&[-0.0], k), Ok(Action::Discrete(0)));
        assert!(action_of(&[1e300], k).unwrap_err().contains("outside"));
        assert!(action_of(&[1.5], k).unwrap_err().contains("not an integer"));
    }

    #[test]
    fn continuous_actions_must_be_finite_and_sized() {
        let k = ActionKind::Box(2);
        assert!(action_of(&[5.0, -7.0], k).is_ok());
        assert!(action_of(&[0.0, f64::NAN], k)
            .unwrap_err()
            .contains("action[1]"));
        assert!(action_of(&[0.0], k).is_err());
    }
}

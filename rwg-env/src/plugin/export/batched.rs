//! ABI 1.1's batched calls, `reset_many` and `step_many`, for exported Rust
//! environments: each masked lane goes through the code of the single call
//! ([`reset`]; for `step`, its fast path [`step_fast`] and, for anything
//! unusual, its checked path), so the two paths cannot differ (same checks,
//! same panic catching, same results bit for bit); what a batch saves is
//! the host's side of a call per lane. Both are instantiated per
//! environment type `E`, so the lane loop calls `E`'s `step` directly (no
//! trait object), and the fast path tests an instance with one comparison
//! ([`FastKey`](super::step::FastKey): healthy, and the call's
//! lengths its own).

use super::step::{call_keys, step_fast, step_inline};
use super::trampolines::reset;
use crate::env::Environment;
use crate::plugin::abi::*;

/// Whether the whole call must be refused: a NULL where `n > 0` needs a
/// buffer, or a mask value other than 0 or 1.
///
/// # Safety
/// `mask` is NULL or valid for `n` reads.
#[inline]
unsafe fn refused(n: usize, pointers_ok: bool, mask: *const u8) -> bool {
    if n == 0 {
        return false;
    }
    // One pass without a branch per lane (vectorised): any value above 1
    // has a bit above bit 0.
    // SAFETY: a non-NULL `mask` is valid for `n` reads (the caller's promise).
    !pointers_ok
        || (!mask.is_null()
            && unsafe { std::slice::from_raw_parts(mask, n) }
                .iter()
                .fold(0, |a, &m| a | m)
                > 1)
}

/// `mask`, or NULL if every one of its `n` values is 1 (the lane loop then
/// tests no lane), for a mask [`refused`] accepted.
///
/// # Safety
/// `mask` is NULL or valid for `n` reads.
#[inline]
unsafe fn simplified(n: usize, mask: *const u8) -> *const u8 {
    // SAFETY: a non-NULL `mask` is valid for `n` reads (the caller's promise).
    if mask.is_null()
        || unsafe { std::slice::from_raw_parts(mask, n) }
            .iter()
            .fold(1, |a, &m| a & m)
            == 1
    {
        std::ptr::null()
    } else {
        mask
    }
}

/// Whether lane `i` is to be called: no mask, or its value is 1.
///
/// # Safety
/// `mask` is NULL or valid for reads at `i`.
#[inline(always)]
unsafe fn masked(mask: *const u8, i: usize) -> bool {
    // SAFETY: a non-NULL `mask` is readable at `i` (the caller's promise).
    mask.is_null() || unsafe { *mask.add(i) } == 1
}

/// Writes `i` to `*failed`, unless `failed` is NULL.
///
/// # Safety
/// `failed` is NULL or valid for a write.
#[inline(always)]
unsafe fn report(failed: *mut usize, i: usize) {
    if !failed.is_null() {
        // SAFETY: non-NULL, so writable (the caller's promise).
        unsafe { *failed = i };
    }
}

/// `reset_many`: `reset(envs[i], 1, seeds[i], ...)` on every masked lane.
pub(super) unsafe extern "C" fn reset_many<E: Environment>(
    envs: *const *mut RwgEnv,
    n: usize,
    mask: *const u8,
    seeds: *const u64,
    obs: *mut f64,
    obs_len: usize,
    failed: *mut usize,
) -> Status {
    // SAFETY (of every block below): the ABI's contract for `reset_many`:
    // `mask` is NULL or has `n` values, `failed` is NULL or writable, and
    // (checked non-NULL here) `envs` and `seeds` have `n` entries, `obs`
    // `n * obs_len`; `envs[i]` are instances of this table's type `E`.
    let refuse = unsafe {
        refused(
            n,
            !envs.is_null() && !seeds.is_null() && !obs.is_null(),
            mask,
        )
    };
    if refuse {
        // SAFETY: see above.
        unsafe { report(failed, n) };
        return RWG_ERR_INVALID_ARGUMENT;
    }
    for i in 0..n {
        // SAFETY: see above.
        if !unsafe { masked(mask, i) } {
            continue;
        }
        // SAFETY: see above (lane `i < n` of each array).
        let status = unsafe {
            reset::<E>(
                *envs.add(i),
                1,
                *seeds.add(i),
                obs.add(i * obs_len),
                obs_len,
            )
        };
        if status != RWG_OK {
            // SAFETY: see above.
            unsafe { report(failed, i) };
            return status;
        }
    }
    RWG_OK
}

/// `step_many`: `step(envs[i], ...)` on every masked lane, its reward and
/// flags scattered into the three arrays.
pub(super) unsafe extern "C" fn step_many<E: Environment>(
    envs: *const *mut RwgEnv,
    n: usize,
    mask: *const u8,
    actions: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    rewards: *mut f64,
    terminated: *mut u8,
    truncated: *mut u8,
    failed: *mut usize,
) -> Status {
    let pointers_ok = !envs.is_null()
        && !actions.is_null()
        && !obs.is_null()
        && !rewards.is_null()
        && !terminated.is_null()
        && !truncated.is_null();
    // SAFETY (of every block below): the ABI's contract for `step_many`:
    // `mask` is NULL or has `n` values, `failed` is NULL or writable, and
    // (checked non-NULL here) `envs`, `rewards`, `terminated` and
    // `truncated` have `n` entries, `actions` `n * action_len`, `obs`
    // `n * obs_len`; `envs[i]` are instances of this table's type `E`.
    if unsafe { refused(n, pointers_ok, mask) } {
        // SAFETY: see above.
        unsafe { report(failed, n) };
        return RWG_ERR_INVALID_ARGUMENT;
    }
    let keys = call_keys(obs_len, action_len);
    // Lane i: the single call's fast path, its results written straight
    // into the lane's slots; anything unusual goes through the single call.
    // `Err` stops the call at the lane that failed.
    let step_lane = |i: usize, action: *const f64, o: *mut f64| -> Result<(), Status> {
        // SAFETY: see above (lane `i < n`; `action` and `o` are its slots).
        let env = unsafe { *envs.add(i) };
        // SAFETY: see above.
        let fast = unsafe { step_fast::<E>(env, keys, action, action_len, o, obs_len) };
        let status = match fast {
            Ok(s) => {
                // SAFETY: see above.
                unsafe {
                    *rewards.add(i) = s.reward;
                    *terminated.add(i) = u8::from(s.terminated);
                    *truncated.add(i) = u8::from(s.truncated);
                }
                return Ok(());
            }
            Err(Some(status)) => status,
            // SAFETY: see above.
            Err(None) => unsafe {
                lane_checked::<E>(
                    env,
                    action,
                    action_len,
                    o,
                    obs_len,
                    rewards.add(i),
                    terminated.add(i),
                    truncated.add(i),
                )
            },
        };
        if status == RWG_OK {
            Ok(())
        } else {
            // SAFETY: see above.
            unsafe { report(failed, i) };
            Err(status)
        }
    };
    // Lane i's action and observation, advanced lane by lane (no multiply);
    // a loop without a mask test when every lane steps.
    let (mut action, mut o) = (actions, obs);
    // SAFETY: see above.
    let every = unsafe { simplified(n, mask) }.is_null();
    for i in 0..n {
        let lane = (action, o);
        action = action.wrapping_add(action_len);
        o = o.wrapping_add(obs_len);
        // SAFETY: see above (`mask` is not NULL unless `every`).
        if every || unsafe { *mask.add(i) } == 1 {
            if let Err(status) = step_lane(i, lane.0, lane.1) {
                return status;
            }
        }
    }
    RWG_OK
}

/// A lane the fast path refused, through the single call (which finds
/// and reports what is wrong, or steps the env if nothing is).
///
/// # Safety
/// `step_inline`'s contract, and `reward`, `terminated`, `truncated`
/// writable.
#[cold]
#[inline(never)]
#[expect(
    clippy::too_many_arguments,
    reason = "one lane's slots of `step_many`'s buffers"
)]
unsafe fn lane_checked<E: Environment>(
    env: *mut RwgEnv,
    action: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    reward: *mut f64,
    terminated: *mut u8,
    truncated: *mut u8,
) -> Status {
    let mut out = RwgStepOut {
        reward: 0.0,
        terminated: 0,
        truncated: 0,
        reserved: [0; 6],
    };
    // SAFETY: this function's contract is `step_inline`'s.
    let status = unsafe { step_inline::<E>(env, action, action_len, obs, obs_len, &mut out) };
    if status == RWG_OK {
        // SAFETY: the three are writable (this function's contract).
        unsafe {
            *reward = out.reward;
            *terminated = out.terminated;
            *truncated = out.truncated;
        }
    }
    status
}

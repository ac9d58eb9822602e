//! ABI 1.2's vector env for exported Rust environments: `vec_create`,
//! `vec_destroy`, `vec_reset`, `vec_step` and `vec_last_error` over a
//! [`ManyEnv`] (e.g. one of `rwg-envs`' lockstep envs), instantiated per
//! `ManyEnv` type so its `step_many` is a direct call.
//!
//! A `ManyEnv` has a fixed number of lanes (its width); a vector env of
//! `n` lanes is `ceil(n / width)` of them side by side, the host's buffers
//! handed to each in place. Only a last, partial one goes through scratch
//! buffers of its width, its extra lanes never masked.
//!
//! The `ManyEnv` checks actions itself (a lane with an invalid action fails
//! through `on_fail`, as the lockstep envs do with the scalar envs'
//! checks); this layer checks the call as a whole (pointers, mask values,
//! lengths), catches panics (one poisons the whole vector env) and turns
//! each failing lane's [`EnvError`] into its status and message.

use std::ffi::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};

use super::builder::{ActionKind, PluginStatic};
use super::trampolines::{creation, panic_message, same_shape, status_of};
use crate::env::EnvError;
use crate::many::ManyEnv;
use crate::plugin::abi::*;

/// A vector env as the C side sees it (`rwg_vec_env_t *`).
pub(super) struct VecInstance<M> {
    chunks: Vec<M>,
    /// Lanes of each chunk.
    width: usize,
    /// Lanes of the vector env.
    n: usize,
    obs_dim: usize,
    action_len: usize,
    /// The message of the panic that poisoned the vector env.
    poisoned: Option<String>,
    /// Each lane's message and, at `n`, the call's; NUL-terminated.
    errors: Vec<Vec<u8>>,
    /// Some message is not empty (they are cleared at the next call).
    dirty: bool,
    /// The lanes' statuses in the call in progress (a failure only).
    status: Vec<Status>,
    /// Every lane's mask for a call with a NULL mask.
    ones: Vec<u8>,
    /// The last chunk's buffers when `n` is not a multiple of `width`.
    tail: Tail,
}

/// Scratch buffers of one chunk's width.
#[derive(Default)]
struct Tail {
    mask: Vec<u8>,
    seeds: Vec<u64>,
    actions: Vec<f64>,
    obs: Vec<f64>,
    rewards: Vec<f64>,
    terminated: Vec<u8>,
    truncated: Vec<u8>,
}

/// Builds a vector env of `lanes` lanes from the user's config: the
/// chunks `make` builds, checked against the descriptor's shapes.
pub(super) fn instantiate_vec<M: ManyEnv>(
    make: &dyn Fn(&str) -> Result<M, String>,
    config: &str,
    lanes: usize,
    obs_dim: usize,
    action: ActionKind,
) -> Result<*mut RwgVecEnv, (Status, String)> {
    if lanes == 0 {
        return Err((
            RWG_ERR_INVALID_ARGUMENT,
            "vec_create: a vector env needs at least one lane".into(),
        ));
    }
    let first = make(config).map_err(|e| (RWG_ERR_INVALID_ARGUMENT, e))?;
    let width = first.lanes();
    if width == 0 || !same_shape(first.spec(), obs_dim, action) {
        return Err((
            RWG_ERR_INTERNAL,
            format!(
                "vec_create: the constructor built a vector env of {width} lanes with spaces {} / {}, \
                 which does not match the descriptor",
                first.spec().observation_space.describe(),
                first.spec().action_space.describe()
            ),
        ));
    }
    let count = lanes.div_ceil(width);
    let mut chunks = Vec::with_capacity(count);
    chunks.push(first);
    while chunks.len() < count {
        chunks.push(make(config).map_err(|e| (RWG_ERR_INVALID_ARGUMENT, e))?);
    }
    let action_len = match action {
        ActionKind::Discrete(_) => 1,
        ActionKind::Box(d) => d,
    };
    let tail = if lanes.is_multiple_of(width) {
        Tail::default()
    } else {
        Tail {
            mask: vec![0; width],
            seeds: vec![0; width],
            actions: vec![0.0; width * action_len],
            obs: vec![0.0; width * obs_dim],
            rewards: vec![0.0; width],
            terminated: vec![0; width],
            truncated: vec![0; width],
        }
    };
    let inst = Box::new(VecInstance {
        chunks,
        width,
        n: lanes,
        obs_dim,
        action_len,
        poisoned: None,
        errors: vec![vec![0]; lanes + 1],
        dirty: false,
        status: vec![RWG_OK; lanes],
        ones: vec![1; lanes],
        tail,
    });
    Ok(Box::into_raw(inst).cast())
}

impl<M> VecInstance<M> {
    fn set_error(&mut self, lane: usize, msg: &str) {
        let e = &mut self.errors[lane.min(self.n)];
        e.clear();
        e.extend(msg.bytes().map(|b| if b == 0 { b' ' } else { b }));
        e.push(0);
        self.dirty = true;
    }

    /// Empties every message and status (the previous call's).
    fn clear(&mut self) {
        if self.dirty {
            for e in &mut self.errors {
                e.clear();
                e.push(0);
            }
            self.status.fill(RWG_OK);
            self.dirty = false;
        }
    }

    /// Fails every lane of `mask` with `status` and `msg` (a call refused
    /// as a whole, or a poisoned vector env).
    fn fail_all(&mut self, mask: &[u8], status: Status, msg: &str) {
        self.set_error(self.n, msg);
        for (i, &m) in mask.iter().enumerate().take(self.n) {
            if m == 1 {
                self.status[i] = status;
                self.set_error(i, msg);
            }
        }
    }

    /// The call's status (the lowest failing lane's), the lanes' statuses
    /// copied to the host's `out` on a failure.
    ///
    /// # Safety
    /// `out` is NULL or valid for `self.n` writes.
    unsafe fn finish(&self, out: *mut Status) -> Status {
        if !self.dirty {
            return RWG_OK;
        }
        let first = self.status.iter().copied().find(|&s| s != RWG_OK);
        if !out.is_null() {
            // SAFETY: non-NULL: valid for `n` writes (the contract).
            unsafe { std::slice::from_raw_parts_mut(out, self.n) }.copy_from_slice(&self.status);
        }
        first.unwrap_or(RWG_OK)
    }
}

/// The mask of a call (the host's, or every lane for NULL), or `None` if a
/// value is neither 0 nor 1.
///
/// # Safety
/// `mask` is NULL or valid for `n` reads.
unsafe fn mask_of(mask: *const u8, ones: &[u8]) -> Option<&[u8]> {
    if mask.is_null() {
        return Some(ones);
    }
    // SAFETY: non-NULL: valid for `n` reads (the contract).
    let m = unsafe { std::slice::from_raw_parts(mask, ones.len()) };
    (m.iter().fold(0, |a, &v| a | v) <= 1).then_some(m)
}

/// The checks and panic catching every vector call shares: `call` runs on
/// the vector env with the mask when the call is acceptable (`refusal`
/// gives the status and message of one that is not).
///
/// # Safety
/// `vec` is NULL or a vector env of `M` made by this table's `vec_create`,
/// not in use elsewhere; `mask` NULL or valid for its `n` reads;
/// `status_out` NULL or valid for `n` writes.
unsafe fn vec_call<M>(
    vec: *mut RwgVecEnv,
    mask: *const u8,
    status_out: *mut Status,
    refusal: impl FnOnce(&VecInstance<M>) -> Option<(Status, String)>,
    call: impl FnOnce(&mut VecInstance<M>, &[u8], &mut dyn FnMut(usize, EnvError)),
) -> Status {
    // SAFETY: the contract above.
    let Some(v) = (unsafe { vec.cast::<VecInstance<M>>().as_mut() }) else {
        return RWG_ERR_INVALID_ARGUMENT;
    };
    v.clear();
    let ones = std::mem::take(&mut v.ones);
    // SAFETY: the contract above (`ones` has `n` values).
    let status = unsafe { vec_call_masked(v, &ones, mask, status_out, refusal, call) };
    v.ones = ones;
    status
}

/// [`vec_call`] on the instance `v`, whose every lane `ones` holds.
///
/// # Safety
/// `mask` is NULL or valid for `v.n` reads, `status_out` NULL or valid for
/// `v.n` writes.
unsafe fn vec_call_masked<M>(
    v: &mut VecInstance<M>,
    ones: &[u8],
    mask: *const u8,
    status_out: *mut Status,
    refusal: impl FnOnce(&VecInstance<M>) -> Option<(Status, String)>,
    call: impl FnOnce(&mut VecInstance<M>, &[u8], &mut dyn FnMut(usize, EnvError)),
) -> Status {
    // A call refused as a whole fails every lane with its status.
    // SAFETY: `mask` as the contract says.
    let Some(mask) = (unsafe { mask_of(mask, ones) }) else {
        v.fail_all(
            ones,
            RWG_ERR_INVALID_ARGUMENT,
            "a mask value is neither 0 nor 1",
        );
        // SAFETY: `status_out` as the contract says (also below).
        return unsafe { v.finish(status_out) };
    };
    if let Some((status, msg)) = refusal(v) {
        v.fail_all(ones, status, &msg);
        // SAFETY: see above.
        return unsafe { v.finish(status_out) };
    }
    if let Some(p) = &v.poisoned {
        let msg = format!("the vector env is poisoned by an earlier panic: {p}");
        v.fail_all(mask, RWG_ERR_PANIC, &msg);
        // SAFETY: see above.
        return unsafe { v.finish(status_out) };
    }
    let mut failures: Vec<(usize, EnvError)> = Vec::new();
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        call(v, mask, &mut |lane, e| failures.push((lane, e)))
    }));
    match outcome {
        Ok(()) => {
            for (lane, e) in failures {
                if lane < v.n && mask[lane] == 1 {
                    v.status[lane] = status_of(&e);
                    v.set_error(lane, &e.to_string());
                }
            }
        }
        Err(p) => {
            let msg = panic_message(&*p);
            v.fail_all(mask, RWG_ERR_PANIC, &format!("panic: {msg}"));
            v.poisoned = Some(msg);
        }
    }
    // SAFETY: see above.
    unsafe { v.finish(status_out) }
}

/// Calls `f(chunk, lanes)` for each chunk with the range of its lanes.
fn for_chunks<M>(
    chunks: &mut [M],
    width: usize,
    n: usize,
    mut f: impl FnMut(&mut M, std::ops::Range<usize>),
) {
    for (c, m) in chunks.iter_mut().enumerate() {
        let start = c * width;
        f(m, start..(start + width).min(n));
    }
}

pub(super) unsafe extern "C" fn vec_create<P: PluginStatic>(
    env_index: u32,
    config: *const c_char,
    lanes: usize,
    out_vec: *mut *mut RwgVecEnv,
    err_buf: *mut c_char,
    err_len: usize,
) -> Status {
    // SAFETY: `creation`'s contract is `vec_create`'s (the ABI's).
    unsafe {
        creation::<P, RwgVecEnv>(
            "vec_create",
            env_index,
            config,
            out_vec,
            err_buf,
            err_len,
            |e, c| {
                let Some(make) = &e.make_vec else {
                    return Err((
                        RWG_ERR_UNSUPPORTED,
                        "vec_create: this environment has no vector env".into(),
                    ));
                };
                make(c, lanes, e.obs_dim, e.action)
            },
        )
    }
}

pub(super) unsafe extern "C" fn vec_destroy<M>(vec: *mut RwgVecEnv) {
    if vec.is_null() {
        return;
    }
    // SAFETY: a non-NULL `vec` is a vector env of `M` this table's
    // `vec_create` made with `Box::into_raw`, destroyed once (the ABI).
    let inst = unsafe { Box::from_raw(vec.cast::<VecInstance<M>>()) };
    // A panicking Drop must not unwind into C; whatever it left is leaked.
    let _ = catch_unwind(AssertUnwindSafe(move || drop(inst)));
}

pub(super) unsafe extern "C" fn vec_last_error<M>(
    vec: *const RwgVecEnv,
    lane: usize,
) -> *const c_char {
    // SAFETY: `vec` is NULL or a vector env of `M` (the ABI's contract).
    match unsafe { vec.cast::<VecInstance<M>>().as_ref() } {
        Some(v) => v.errors[lane.min(v.n)].as_ptr().cast(),
        None => c"".as_ptr(),
    }
}

/// The refusal of a call with a NULL buffer or the wrong `obs_len`.
fn refuse_buffers(pointers_ok: bool, obs_len: usize, obs_dim: usize) -> Option<(Status, String)> {
    if !pointers_ok {
        Some((RWG_ERR_INVALID_ARGUMENT, "a buffer is NULL".into()))
    } else if obs_len != obs_dim {
        Some((
            RWG_ERR_BUFFER_SIZE,
            format!("obs_len is {obs_len}, the observation space has {obs_dim}"),
        ))
    } else {
        None
    }
}

pub(super) unsafe extern "C" fn vec_reset<M: ManyEnv>(
    vec: *mut RwgVecEnv,
    mask: *const u8,
    seeds: *const u64,
    obs: *mut f64,
    obs_len: usize,
    status: *mut Status,
) -> Status {
    let pointers_ok = !seeds.is_null() && !obs.is_null();
    let call = |v: &mut VecInstance<M>, mask: &[u8], on_fail: &mut dyn FnMut(usize, EnvError)| {
        let (n, w, d) = (v.n, v.width, v.obs_dim);
        // SAFETY: `vec_call` calls this only after `refuse_buffers` passed:
        // `seeds` and `obs` are non-NULL, so hold `n` and `n * obs_len` values
        // (the ABI), and `obs_len == d`.
        let seeds = unsafe { std::slice::from_raw_parts(seeds, n) };
        // SAFETY: as above.
        let obs = unsafe { std::slice::from_raw_parts_mut(obs, n * d) };
        let tail = &mut v.tail;
        for_chunks(&mut v.chunks, w, n, |m, r| {
            let start = r.start;
            let mut fail = |i: usize, e: EnvError| on_fail(start + i, e);
            if r.len() == w {
                m.reset_many(
                    &mask[r.clone()],
                    &seeds[r.clone()],
                    &mut obs[r.start * d..r.end * d],
                    &mut fail,
                );
                return;
            }
            let k = r.len();
            tail.mask[..k].copy_from_slice(&mask[r.clone()]);
            tail.seeds[..k].copy_from_slice(&seeds[r.clone()]);
            m.reset_many(&tail.mask, &tail.seeds, &mut tail.obs, &mut fail);
            copy_masked(
                &mask[r.clone()],
                d,
                &tail.obs,
                &mut obs[r.start * d..r.end * d],
            );
        });
    };
    // SAFETY: the ABI's contract for `vec_reset`: `vec` is NULL or a vector
    // env of this table's, `mask` NULL or `n` values, `status` NULL or `n`
    // writable; `seeds` and `obs` (called only when non-NULL) `n` and
    // `n * obs_len` values, and `obs_len` is checked to be `d`.
    unsafe {
        vec_call::<M>(
            vec,
            mask,
            status,
            |v| refuse_buffers(pointers_ok, obs_len, v.obs_dim),
            call,
        )
    }
}

/// Copies the masked lanes' slots of `from` (lanes of `d` values) to `to`.
fn copy_masked<T: Copy>(mask: &[u8], d: usize, from: &[T], to: &mut [T]) {
    for (i, &m) in mask.iter().enumerate() {
        if m == 1 {
            to[i * d..(i + 1) * d].copy_from_slice(&from[i * d..(i + 1) * d]);
        }
    }
}

pub(super) unsafe extern "C" fn vec_step<M: ManyEnv>(
    vec: *mut RwgVecEnv,
    mask: *const u8,
    actions: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    rewards: *mut f64,
    terminated: *mut u8,
    truncated: *mut u8,
    status: *mut Status,
) -> Status {
    let pointers_ok = !actions.is_null()
        && !obs.is_null()
        && !rewards.is_null()
        && !terminated.is_null()
        && !truncated.is_null();
    let call = |v: &mut VecInstance<M>, mask: &[u8], on_fail: &mut dyn FnMut(usize, EnvError)| {
        let (n, w, d, a) = (v.n, v.width, v.obs_dim, v.action_len);
        // SAFETY (all five): `vec_call` calls this only after the refusal
        // passed: the buffers are non-NULL, so hold `n * action_len`,
        // `n * obs_len` and `n` values (the ABI), and the lengths are `a`, `d`.
        let actions = unsafe { std::slice::from_raw_parts(actions, n * a) };
        let obs = unsafe { std::slice::from_raw_parts_mut(obs, n * d) };
        let rewards = unsafe { std::slice::from_raw_parts_mut(rewards, n) };
        let terminated = unsafe { std::slice::from_raw_parts_mut(terminated, n) };
        let truncated = unsafe { std::slice::from_raw_parts_mut(truncated, n) };
        let tail = &mut v.tail;
        for_chunks(&mut v.chunks, w, n, |m, r| {
            let start = r.start;
            let mut fail = |i: usize, e: EnvError| on_fail(start + i, e);
            if r.len() == w {
                m.step_many(
                    &mask[r.clone()],
                    &actions[r.start * a..r.end * a],
                    &mut obs[r.start * d..r.end * d],
                    &mut rewards[r.clone()],
                    &mut terminated[r.clone()],
                    &mut truncated[r.clone()],
                    &mut fail,
                );
                return;
            }
            let k = r.len();
            let lane_mask = &mask[r.clone()];
            tail.mask[..k].copy_from_slice(lane_mask);
            tail.actions[..k * a].copy_from_slice(&actions[r.start * a..r.end * a]);
            m.step_many(
                &tail.mask,
                &tail.actions,
                &mut tail.obs,
                &mut tail.rewards,
                &mut tail.terminated,
                &mut tail.truncated,
                &mut fail,
            );
            copy_masked(lane_mask, d, &tail.obs, &mut obs[r.start * d..r.end * d]);
            copy_masked(lane_mask, 1, &tail.rewards, &mut rewards[r.clone()]);
            copy_masked(lane_mask, 1, &tail.terminated, &mut terminated[r.clone()]);
            copy_masked(lane_mask, 1, &tail.truncated, &mut truncated[r.clone()]);
        });
    };
    // SAFETY: the ABI's contract for `vec_step`: `vec` is NULL or a vector
    // env of this table's, `mask` NULL or `n` values, `status` NULL or `n`
    // writable; the buffers (used only when non-NULL) `n * action_len`,
    // `n * obs_len` and `n` values, and the lengths are checked to be the
    // env's.
    unsafe {
        vec_call::<M>(
            vec,
            mask,
            status,
            |v| {
                refuse_buffers(pointers_ok, obs_len, v.obs_dim).or_else(|| {
                    (action_len != v.action_len).then(|| {
                        (
                            RWG_ERR_INVALID_ARGUMENT,
                            format!(
                                "action_len is {action_len}, an action of this env has {}",
                                v.action_len
                            ),
                        )
                    })
                })
            },
            call,
        )
    }
}

//! [`PluginVecEnv`]: ABI 1.2's vector env, many lanes of one plugin
//! environment in one plugin object, reset and stepped by one call each
//! over caller-owned structure-of-arrays buffers.
//!
//! It gives what [`PluginBatch`](super::PluginBatch) gives, call for call:
//! the same checks of what the plugin returns (each failing lane's status,
//! then flags, reward and observation), the host's time limit,
//! reset-before-step, and poisoning after `RWG_ERR_PANIC` (of the whole
//! vector env, as the header says), with the texts of the single calls
//! (a [`LaneFailure`] names the lane).

use rwg_env::env::{EnvError, EnvSpec};
use rwg_env::plugin::abi::*;
use std::ffi::{CStr, CString};

use super::batch::LaneFailure;
use super::batch_scan::{all_finite, all_ones, fill_sentinels, outputs_ok};
use super::clock::LaneClock;
use super::handshake::plugin_text;
use super::instance::{call_error, check_obs, lane_output_error};
use super::{PluginEnvType, VecVTable, ERR_BUF_LEN};

/// A status the plugin cannot return: a lane's slot the plugin did not
/// write after a failed call.
const UNWRITTEN: Status = i32::MIN;

/// A plugin's vector env: `len()` lanes of one environment with one config.
///
/// One thread at a time uses it (every call takes `&mut self`); it may move
/// between threads between calls.
pub struct PluginVecEnv {
    handle: *mut RwgVecEnv,
    vt: VecVTable,
    prefix: String,
    spec: EnvSpec,
    n: usize,
    obs_dim: usize,
    action_len: usize,
    clock: LaneClock,
    has_reset: Vec<bool>,
    /// A panic in the plugin poisoned the whole vector env.
    poisoned: bool,
    /// Every lane was reset and the vector env is not poisoned.
    all_ready: bool,
    /// The lanes of the call in progress still to be done.
    todo: Vec<u8>,
    /// The lanes' statuses after a failed call.
    status: Vec<Status>,
}

// SAFETY: the ABI allows a vector env to move between threads between
// calls; every call goes through `&mut self`.
unsafe impl Send for PluginVecEnv {}

impl std::fmt::Debug for PluginVecEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PluginVecEnv")
            .field("env", &self.spec.id)
            .field("lanes", &self.n)
            .field("poisoned", &self.poisoned)
            .finish()
    }
}

impl Drop for PluginVecEnv {
    fn drop(&mut self) {
        // SAFETY: a live vector env of this table, used by no other call.
        unsafe { (self.vt.destroy)(self.handle) }
    }
}

impl PluginEnvType {
    /// Whether the plugin provides ABI 1.2's vector env for this env.
    pub fn has_vec_env(&self) -> bool {
        self.vt.vec.is_some()
    }

    /// A vector env of `lanes` lanes with `config`, with the descriptor's
    /// time limit (or `max_episode_steps` if given) applied by the host.
    /// [`EnvError::Unsupported`] if the plugin has none (before ABI 1.2).
    pub fn make_vec(
        &self,
        config: &str,
        lanes: usize,
        max_episode_steps: Option<u32>,
    ) -> Result<PluginVecEnv, EnvError> {
        let Some(vt) = self.vt.vec else {
            return Err(EnvError::Unsupported(format!(
                "{}: the plugin has no vector env (ABI 1.2's vec_create)",
                self.prefix()
            )));
        };
        let c = CString::new(config).map_err(|_| {
            EnvError::Other(format!("{}: the config contains a NUL byte", self.prefix()))
        })?;
        let mut buf = [0 as std::ffi::c_char; ERR_BUF_LEN];
        let mut out: *mut RwgVecEnv = std::ptr::null_mut();
        // SAFETY: the arguments follow the header's contract for vec_create.
        let status = unsafe {
            (vt.create)(
                self.index,
                c.as_ptr(),
                lanes,
                &mut out,
                buf.as_mut_ptr(),
                buf.len(),
            )
        };
        super::std_fds::refill();
        if status != RWG_OK || out.is_null() {
            // SAFETY: the plugin NUL-terminates within the buffer; the last
            // byte is never written by anyone else.
            let msg = plugin_text(unsafe { CStr::from_ptr(buf.as_ptr()) });
            return Err(EnvError::Other(format!(
                "{}: vec_create of {lanes} lanes failed with {} ({status}): {}",
                self.prefix(),
                status_name(status),
                if status == RWG_OK {
                    "RWG_OK but no vector env".into()
                } else {
                    msg
                }
            )));
        }
        let mut spec = self.spec.clone();
        if max_episode_steps.is_some() {
            spec.max_episode_steps = max_episode_steps;
        }
        let action_len = spec.action_space.flat_dim();
        Ok(PluginVecEnv {
            handle: out,
            vt,
            prefix: self.prefix(),
            obs_dim: spec.obs_dim(),
            action_len,
            clock: LaneClock::new(lanes, spec.max_episode_steps.unwrap_or(u32::MAX)),
            spec,
            n: lanes,
            has_reset: vec![false; lanes],
            poisoned: false,
            all_ready: false,
            todo: vec![0; lanes],
            status: vec![UNWRITTEN; lanes],
        })
    }
}

impl PluginVecEnv {
    /// Number of lanes.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether it has no lanes (never: `vec_create` needs one).
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The environment's spec, with the host's time limit.
    pub fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    /// Whether a panic in the plugin poisoned the vector env.
    pub fn is_poisoned(&self) -> bool {
        self.poisoned
    }

    /// Copies `mask` into `todo`, failing (and clearing) the lanes that must
    /// not be called: all of them once poisoned, and with `need_reset`
    /// those never reset.
    fn start(&mut self, mask: &[u8], need_reset: bool, on_fail: &mut impl FnMut(LaneFailure)) {
        assert_eq!(mask.len(), self.n, "a mask of {} lanes", self.n);
        self.todo.copy_from_slice(mask);
        for i in 0..self.n {
            if self.todo[i] == 1 && (self.poisoned || (need_reset && !self.has_reset[i])) {
                self.todo[i] = 0;
                let error = if self.poisoned {
                    EnvError::Other(format!(
                        "{}: the vector env is poisoned by an earlier panic in the plugin",
                        self.prefix
                    ))
                } else {
                    EnvError::ResetNeeded
                };
                on_fail(LaneFailure { lane: i, error });
            }
        }
    }

    /// Lane `i`'s error after a call (`what`) that returned `call_status`:
    /// its status (the plugin's message with it), `None` if it succeeded.
    /// A panic poisons the vector env.
    fn lane_error(&mut self, what: &str, call_status: Status, i: usize) -> Option<EnvError> {
        if call_status == RWG_OK {
            return None;
        }
        let status = self.status[i];
        if status == RWG_OK {
            return None;
        }
        if status == UNWRITTEN {
            return Some(EnvError::Other(format!(
                "{}: vec_{what} returned {} ({call_status}) without writing this lane's status",
                self.prefix,
                status_name(call_status)
            )));
        }
        // SAFETY: a live vector env; the string is read before any other call.
        let msg = unsafe {
            let p = (self.vt.last_error)(self.handle, i);
            if p.is_null() {
                String::new()
            } else {
                plugin_text(CStr::from_ptr(p))
            }
        };
        self.poisoned |= status == RWG_ERR_PANIC;
        Some(call_error(&self.prefix, what, status, &msg))
    }

    fn update_ready(&mut self) {
        self.all_ready = !self.poisoned && self.has_reset.iter().all(|&r| r);
    }

    /// Resets every lane `i` with `mask[i] == 1` with `seeds[i]`, its first
    /// observation into `obs[i * obs_dim..]`. Failing lanes go to `on_fail`
    /// (the others are reset all the same).
    pub fn reset_many(
        &mut self,
        mask: &[u8],
        seeds: &[u64],
        obs: &mut [f64],
        mut on_fail: impl FnMut(LaneFailure),
    ) {
        let (n, d) = (self.n, self.obs_dim);
        assert!(
            seeds.len() == n && obs.len() == n * d,
            "buffers of {n} lanes"
        );
        self.start(mask, false, &mut on_fail);
        for i in (0..n).filter(|&i| self.todo[i] == 1) {
            self.clock.start(i);
            obs[i * d..(i + 1) * d].fill(f64::NAN);
        }
        self.status.fill(UNWRITTEN);
        // SAFETY: buffers of n lanes; a live vector env used by this thread.
        let status = unsafe {
            (self.vt.reset)(
                self.handle,
                self.todo.as_ptr(),
                seeds.as_ptr(),
                obs.as_mut_ptr(),
                d,
                self.status.as_mut_ptr(),
            )
        };
        if status == RWG_OK && all_finite(obs) {
            for (r, &m) in self.has_reset.iter_mut().zip(&self.todo) {
                *r |= m == 1;
            }
        } else {
            for i in 0..n {
                if self.todo[i] != 1 {
                    continue;
                }
                let error = match self.lane_error("reset", status, i) {
                    Some(e) => Err(e),
                    None => check_obs(&self.prefix, "reset", &obs[i * d..(i + 1) * d]),
                };
                match error {
                    Ok(()) => self.has_reset[i] = true,
                    Err(error) => {
                        self.has_reset[i] = false;
                        on_fail(LaneFailure { lane: i, error });
                    }
                }
            }
        }
        self.update_ready();
    }

    /// Steps every lane `i` with `mask[i] == 1` with the action
    /// `actions[i * action_len..]`: observation into `obs[i * obs_dim..]`,
    /// reward into `rewards[i]`, flags (0 or 1, `truncated` including the
    /// time limit) into `terminated[i]` and `truncated[i]`. Failing lanes go
    /// to `on_fail` (the others are stepped all the same).
    #[expect(
        clippy::too_many_arguments,
        reason = "`ManyEnv::step_many`'s buffers, one argument each"
    )]
    pub fn step_many(
        &mut self,
        mask: &[u8],
        actions: &[f64],
        obs: &mut [f64],
        rewards: &mut [f64],
        terminated: &mut [u8],
        truncated: &mut [u8],
        mut on_fail: impl FnMut(LaneFailure),
    ) {
        let (n, d, a) = (self.n, self.obs_dim, self.action_len);
        assert!(
            mask.len() == n
                && actions.len() == n * a
                && obs.len() == n * d
                && rewards.len() == n
                && terminated.len() == n
                && truncated.len() == n,
            "buffers of {n} lanes"
        );
        let ready = self.all_ready;
        if !ready {
            self.start(mask, true, &mut on_fail);
        }
        // The common case: no lane to refuse (every one was reset and the
        // vector env is not poisoned), so the plugin gets the caller's mask
        // as it is.
        let mut todo = std::mem::take(&mut self.todo);
        let m: &[u8] = if ready { mask } else { &todo };
        let every = all_ones(m);
        fill_sentinels(m, every, d, obs, rewards, terminated, truncated);
        // SAFETY: buffers of n lanes (checked above); a live vector env used
        // by this thread only. `status` is written on a failure only.
        let status = unsafe {
            (self.vt.step)(
                self.handle,
                m.as_ptr(),
                actions.as_ptr(),
                a,
                obs.as_mut_ptr(),
                d,
                rewards.as_mut_ptr(),
                terminated.as_mut_ptr(),
                truncated.as_mut_ptr(),
                self.status.as_mut_ptr(),
            )
        };
        if status == RWG_OK && outputs_ok(obs, rewards, terminated, truncated) {
            self.clock.stepped(m, every, truncated);
            self.todo = todo;
            return;
        }
        if ready {
            todo.copy_from_slice(mask);
        }
        self.todo = todo;
        self.step_failed(status, obs, rewards, terminated, truncated, &mut on_fail);
    }

    /// After a step call that failed or returned something to check: every
    /// lane of `todo` checked (its status, then its outputs), the failures
    /// reported, the time limit applied to the others.
    #[cold]
    #[inline(never)]
    fn step_failed(
        &mut self,
        status: Status,
        obs: &[f64],
        rewards: &[f64],
        terminated: &[u8],
        truncated: &mut [u8],
        on_fail: &mut impl FnMut(LaneFailure),
    ) {
        let d = self.obs_dim;
        for i in 0..self.n {
            if self.todo[i] != 1 {
                continue;
            }
            let lane = &obs[i * d..(i + 1) * d];
            let error = self.lane_error("step", status, i).or_else(|| {
                lane_output_error(&self.prefix, rewards[i], terminated[i], truncated[i], lane)
            });
            if let Some(error) = error {
                self.todo[i] = 0;
                on_fail(LaneFailure { lane: i, error });
            }
        }
        self.status.fill(UNWRITTEN);
        self.clock.stepped(&self.todo, false, truncated);
        self.update_ready();
    }
}

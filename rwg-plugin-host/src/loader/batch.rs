//! [`PluginBatch`]: many instances of one plugin environment, reset and
//! stepped through ABI 1.1's batched calls (`reset_many`, `step_many`) over
//! caller-owned structure-of-arrays buffers.
//!
//! It gives what a [`TimeLimit`](rwg_env::TimeLimit)`<`[`PluginEnv`]`>` per
//! lane gives, call for call: the same checks of what the plugin returns
//! (status, then flags, then reward, then observation), the same error
//! texts, the host's time limit and reset-before-step, and poisoning after
//! `RWG_ERR_PANIC`. A lane that fails does not stop the others: the host
//! calls again for the lanes after it.

use rwg_env::env::{EnvError, EnvSpec};
use rwg_env::plugin::abi::*;

use super::batch_scan::{all_finite, all_ones, fill_sentinels, outputs_ok};
use super::clock::LaneClock;
use super::instance::lane_output_error;
use super::{PluginEnv, PluginEnvType};

/// One lane's failure in a batched call.
#[derive(Debug, Clone, PartialEq)]
pub struct LaneFailure {
    /// The lane (index into the batch).
    pub lane: usize,
    /// What went wrong, as the single call would have reported it.
    pub error: EnvError,
}

/// Many instances of one plugin environment with the same config, used
/// together by ABI 1.1's batched calls. Lane `i` is instance `i`.
///
/// One thread at a time uses a batch (every call takes `&mut self`); it may
/// move between threads between calls.
pub struct PluginBatch {
    envs: Vec<PluginEnv>,
    handles: Vec<*mut RwgEnv>,
    reset_many: ResetManyFn,
    step_many: StepManyFn,
    spec: EnvSpec,
    obs_dim: usize,
    action_len: usize,
    /// Each lane's step count and the time limit.
    clock: LaneClock,
    has_reset: Vec<bool>,
    /// The lanes of the call in progress still to be done (a copy of the
    /// caller's mask; a lane is cleared when it fails).
    todo: Vec<u8>,
    /// Every lane was reset and none is poisoned (so `start` has nothing
    /// to refuse); recomputed after resets and failures.
    all_ready: bool,
}

// SAFETY: as for `PluginEnv`: instances may move between threads between
// calls, and every call goes through `&mut self`.
unsafe impl Send for PluginBatch {}

impl std::fmt::Debug for PluginBatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PluginBatch")
            .field("env", &self.spec.id)
            .field("lanes", &self.envs.len())
            .finish()
    }
}

impl PluginEnvType {
    /// Whether the plugin provides ABI 1.1's batched calls for this env.
    pub fn has_batched_calls(&self) -> bool {
        self.vt.step_many.is_some() && self.vt.reset_many.is_some()
    }

    /// `lanes` instances with `config`, to be used through the batched calls,
    /// with the descriptor's time limit (or `max_episode_steps` if given) as
    /// [`PluginEnvType::make`] applies it. [`EnvError::Unsupported`] if the
    /// plugin has no batched calls (a 1.0 plugin).
    pub fn make_batch(
        &self,
        config: &str,
        lanes: usize,
        max_episode_steps: Option<u32>,
    ) -> Result<PluginBatch, EnvError> {
        let (Some(reset_many), Some(step_many)) = (self.vt.reset_many, self.vt.step_many) else {
            return Err(EnvError::Unsupported(format!(
                "{}: the plugin has no batched calls (ABI 1.1's reset_many/step_many)",
                self.prefix()
            )));
        };
        let envs = (0..lanes)
            .map(|_| self.create(config))
            .collect::<Result<Vec<_>, _>>()?;
        let mut spec = self.spec.clone();
        if max_episode_steps.is_some() {
            spec.max_episode_steps = max_episode_steps;
        }
        let action_len = spec.action_space.flat_dim();
        Ok(PluginBatch {
            handles: envs.iter().map(|e| e.handle).collect(),
            envs,
            reset_many,
            step_many,
            obs_dim: spec.obs_dim(),
            action_len,
            clock: LaneClock::new(lanes, spec.max_episode_steps.unwrap_or(u32::MAX)),
            spec,
            has_reset: vec![false; lanes],
            todo: vec![0; lanes],
            all_ready: false,
        })
    }
}

impl PluginBatch {
    /// Number of lanes.
    pub fn len(&self) -> usize {
        self.envs.len()
    }

    /// Whether the batch has no lanes.
    pub fn is_empty(&self) -> bool {
        self.envs.is_empty()
    }

    /// The environment's spec, with the batch's time limit.
    pub fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    /// The doubles of one lane's action: 1 for a Discrete space (the action
    /// as an integral double), the dimension of a Box.
    pub fn action_len(&self) -> usize {
        self.action_len
    }

    /// The instance of lane `i`.
    pub fn lane(&self, i: usize) -> &PluginEnv {
        &self.envs[i]
    }

    /// Copies `mask` into `todo`, failing (and clearing) the lanes that must
    /// not be called: poisoned ones, and with `need_reset` those never reset.
    fn start(&mut self, mask: &[u8], need_reset: bool, on_fail: &mut impl FnMut(LaneFailure)) {
        let n = self.envs.len();
        assert_eq!(mask.len(), n, "a mask of {n} lanes");
        self.todo.copy_from_slice(mask);
        if need_reset && self.all_ready {
            return;
        }
        for i in 0..n {
            if self.todo[i] == 1 && (self.envs[i].poisoned || (need_reset && !self.has_reset[i])) {
                self.todo[i] = 0;
                let error = if self.envs[i].poisoned {
                    EnvError::Other(format!(
                        "{}: the instance is poisoned by an earlier panic in the plugin",
                        self.envs[i].prefix
                    ))
                } else {
                    EnvError::ResetNeeded
                };
                on_fail(LaneFailure { lane: i, error });
            }
        }
    }

    /// Calls `call(start, failed)` (the batched call on lanes `start..`) until
    /// every lane of `todo` is done: a failing lane is reported (as `what`,
    /// "reset" or "step") and cleared, and the call repeated for the lanes
    /// after it. `first` is the status and failed lane of a first call on
    /// every lane already made, if one was. Returns whether no lane failed.
    fn run(
        &mut self,
        what: &str,
        on_fail: &mut impl FnMut(LaneFailure),
        mut first: Option<(Status, usize)>,
        mut call: impl FnMut(&Self, usize, &mut usize) -> Status,
    ) -> bool {
        let n = self.envs.len();
        let mut start = 0;
        let mut clean = true;
        while start < n {
            let (status, failed) = match first.take() {
                Some(done) => done,
                None => {
                    let mut failed = usize::MAX;
                    (call(self, start, &mut failed), failed)
                }
            };
            if status == RWG_OK {
                return clean;
            }
            clean = false;
            let rest = n - start;
            if failed >= rest {
                // Refused as a whole: every lane still to do fails.
                for i in start..n {
                    if self.todo[i] == 1 {
                        self.todo[i] = 0;
                        let error = EnvError::Other(format!(
                            "{}: {what}_many refused the call with {} ({status}) without naming a lane",
                            self.envs[i].prefix,
                            status_name(status)
                        ));
                        on_fail(LaneFailure { lane: i, error });
                    }
                }
                return false;
            }
            let i = start + failed;
            self.todo[i] = 0;
            self.all_ready = false; // the lane may be poisoned now
            let error = self.envs[i].fail(what, status);
            on_fail(LaneFailure { lane: i, error });
            start = i + 1;
        }
        clean
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
        let (n, d) = (self.envs.len(), self.obs_dim);
        assert!(
            seeds.len() == n && obs.len() == n * d,
            "buffers of {n} lanes"
        );
        self.start(mask, false, &mut on_fail);
        for i in (0..n).filter(|&i| self.todo[i] == 1) {
            self.clock.start(i);
            obs[i * d..(i + 1) * d].fill(f64::NAN);
        }
        let reset_many = self.reset_many;
        let obs_ptr = obs.as_mut_ptr();
        let clean = self.run("reset", &mut on_fail, None, |b, s, failed| {
            // SAFETY: lanes s.. of buffers sized for n lanes; the handles
            // are live instances of this table, used by this thread only.
            unsafe {
                reset_many(
                    b.handles.as_ptr().add(s),
                    n - s,
                    b.todo.as_ptr().add(s),
                    seeds.as_ptr().add(s),
                    obs_ptr.add(s * d),
                    d,
                    failed,
                )
            }
        });
        if clean && all_finite(obs) {
            // The common case (see `step_many`): no lane to check one by one,
            // and no lane failed, so none is newly poisoned.
            for (r, &m) in self.has_reset.iter_mut().zip(&self.todo) {
                *r |= m == 1;
            }
            if self.all_ready {
                return;
            }
        } else {
            for i in 0..n {
                if self.todo[i] == 1 {
                    let lane = &obs[i * d..(i + 1) * d];
                    match self.envs[i].check_obs("reset", lane) {
                        Ok(()) => self.has_reset[i] = true,
                        Err(error) => on_fail(LaneFailure { lane: i, error }),
                    }
                }
            }
        }
        self.all_ready = self
            .envs
            .iter()
            .zip(&self.has_reset)
            .all(|(e, &r)| r && !e.poisoned);
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
        let (n, d, a) = (self.envs.len(), self.obs_dim, self.action_len);
        assert!(
            actions.len() == n * a
                && obs.len() == n * d
                && rewards.len() == n
                && terminated.len() == n
                && truncated.len() == n,
            "buffers of {n} lanes"
        );
        if self.all_ready {
            // The common case: no lane to refuse (every one was reset and
            // none is poisoned), so the plugin gets the caller's mask as it
            // is, and the outputs are checked over whole buffers.
            let every = all_ones(mask);
            fill_sentinels(mask, every, d, obs, rewards, terminated, truncated);
            let mut failed = usize::MAX;
            // SAFETY: buffers sized for n lanes (checked above); the handles
            // are live instances used by this thread only.
            let status = unsafe {
                (self.step_many)(
                    self.handles.as_ptr(),
                    n,
                    mask.as_ptr(),
                    actions.as_ptr(),
                    a,
                    obs.as_mut_ptr(),
                    d,
                    rewards.as_mut_ptr(),
                    terminated.as_mut_ptr(),
                    truncated.as_mut_ptr(),
                    &mut failed,
                )
            };
            if status == RWG_OK && outputs_ok(obs, rewards, terminated, truncated) {
                self.clock.stepped(mask, every, truncated);
                return;
            }
            // Something to report: the lanes one by one, as below.
            self.todo.copy_from_slice(mask);
            self.step_rest(
                Some((status, failed)),
                actions,
                obs,
                rewards,
                terminated,
                truncated,
                &mut on_fail,
            );
            return;
        }
        self.start(mask, true, &mut on_fail);
        let every = all_ones(&self.todo);
        fill_sentinels(&self.todo, every, d, obs, rewards, terminated, truncated);
        self.step_rest(
            None,
            actions,
            obs,
            rewards,
            terminated,
            truncated,
            &mut on_fail,
        );
    }

    /// `step_many` for the lanes of `todo` (sentinels filled): the batched
    /// call until every lane is done (`first`: the result of a first call
    /// on every lane already made), then every lane's outputs checked, the
    /// failures reported, the time limit applied to the others.
    #[expect(
        clippy::too_many_arguments,
        reason = "`step_many`'s buffers and its first call's result"
    )]
    #[cold]
    #[inline(never)]
    fn step_rest(
        &mut self,
        first: Option<(Status, usize)>,
        actions: &[f64],
        obs: &mut [f64],
        rewards: &mut [f64],
        terminated: &mut [u8],
        truncated: &mut [u8],
        on_fail: &mut impl FnMut(LaneFailure),
    ) {
        let (n, d, a) = (self.envs.len(), self.obs_dim, self.action_len);
        let step_many = self.step_many;
        let (obs_ptr, rew_ptr) = (obs.as_mut_ptr(), rewards.as_mut_ptr());
        let (term_ptr, trunc_ptr) = (terminated.as_mut_ptr(), truncated.as_mut_ptr());
        let _ = self.run("step", on_fail, first, |b, s, failed| {
            // SAFETY: lanes s.. of buffers sized for n lanes (checked by
            // the caller); the handles are live instances used by this
            // thread only.
            unsafe {
                step_many(
                    b.handles.as_ptr().add(s),
                    n - s,
                    b.todo.as_ptr().add(s),
                    actions.as_ptr().add(s * a),
                    a,
                    obs_ptr.add(s * d),
                    d,
                    rew_ptr.add(s),
                    term_ptr.add(s),
                    trunc_ptr.add(s),
                    failed,
                )
            }
        });
        for i in 0..n {
            if self.todo[i] != 1 {
                continue;
            }
            let lane = &obs[i * d..(i + 1) * d];
            let prefix = &self.envs[i].prefix;
            if let Some(error) =
                lane_output_error(prefix, rewards[i], terminated[i], truncated[i], lane)
            {
                on_fail(LaneFailure { lane: i, error });
                self.todo[i] = 0;
            }
        }
        // The lanes that did not step (refused, failed, not masked) keep
        // their count; the others get the time limit.
        self.clock.stepped(&self.todo, false, truncated);
    }
}

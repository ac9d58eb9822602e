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
use rwg_env::space::Space;

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
    max_steps: u32,
    elapsed: Vec<u32>,
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
        let action_len = match &spec.action_space {
            Space::Discrete { .. } => 1,
            Space::Box(b) => b.dim(),
        };
        Ok(PluginBatch {
            handles: envs.iter().map(|e| e.handle).collect(),
            envs,
            reset_many,
            step_many,
            obs_dim: spec.obs_dim(),
            action_len,
            max_steps: spec.max_episode_steps.unwrap_or(u32::MAX),
            spec,
            elapsed: vec![0; lanes],
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
    /// after it. Returns whether no lane failed.
    fn run(
        &mut self,
        what: &str,
        on_fail: &mut impl FnMut(LaneFailure),
        mut call: impl FnMut(&Self, usize, &mut usize) -> Status,
    ) -> bool {
        let n = self.envs.len();
        let mut start = 0;
        let mut clean = true;
        while start < n {
            let mut failed = usize::MAX;
            let status = call(self, start, &mut failed);
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
            self.elapsed[i] = 0;
            obs[i * d..(i + 1) * d].fill(f64::NAN);
        }
        let reset_many = self.reset_many;
        let obs_ptr = obs.as_mut_ptr();
        let clean = self.run("reset", &mut on_fail, |b, s, failed| {
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
    #[allow(clippy::too_many_arguments)]
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
        self.start(mask, true, &mut on_fail);
        // Values a plugin cannot leave there by accident unnoticed.
        if all_ones(&self.todo) {
            // Every lane: whole buffers at once.
            obs.fill(f64::NAN);
            rewards.fill(f64::NAN);
            terminated.fill(0xff);
            truncated.fill(0xff);
        } else {
            for i in 0..n {
                if self.todo[i] == 1 {
                    obs[i * d..(i + 1) * d].fill(f64::NAN);
                    rewards[i] = f64::NAN;
                    terminated[i] = 0xff;
                    truncated[i] = 0xff;
                }
            }
        }
        let step_many = self.step_many;
        let (obs_ptr, rew_ptr) = (obs.as_mut_ptr(), rewards.as_mut_ptr());
        let (term_ptr, trunc_ptr) = (terminated.as_mut_ptr(), truncated.as_mut_ptr());
        let _ = self.run("step", &mut on_fail, |b, s, failed| {
            // SAFETY: lanes s.. of buffers sized for n lanes (checked above);
            // the handles are live instances used by this thread only.
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
        // The common case in one pass over whole buffers: every lane's flags
        // are 0 or 1 and its reward and observation finite (lanes not
        // stepped included, so this is a sufficient test, not the exact one:
        // if it fails, the lanes are checked one by one below).
        if flags_ok(terminated) && flags_ok(truncated) && all_finite(rewards) && all_finite(obs) {
            let max = self.max_steps;
            for ((e, t), &m) in self.elapsed.iter_mut().zip(truncated).zip(&self.todo) {
                *e = e.saturating_add(u32::from(m));
                *t |= u8::from(*e >= max) & m;
            }
            return;
        }
        for i in 0..n {
            if self.todo[i] != 1 {
                continue;
            }
            let lane = &obs[i * d..(i + 1) * d];
            if (terminated[i] | truncated[i]) > 1
                || !rewards[i].is_finite()
                || !lane.iter().all(|x| x.is_finite())
            {
                let out = RwgStepOut {
                    reward: rewards[i],
                    terminated: terminated[i],
                    truncated: truncated[i],
                    reserved: [0; 6],
                };
                let error = self.envs[i].step_failure(RWG_OK, &out, lane);
                on_fail(LaneFailure { lane: i, error });
                continue;
            }
            self.elapsed[i] = self.elapsed[i].saturating_add(1);
            if self.elapsed[i] >= self.max_steps {
                truncated[i] = 1;
            }
        }
    }
}

/// The bytes of `bytes` OR-ed together, eight at a time.
#[inline]
fn or_bytes(bytes: &[u8]) -> u8 {
    let mut chunks = bytes.chunks_exact(8);
    let mut acc = 0u64;
    for c in &mut chunks {
        acc |= u64::from_ne_bytes(c.try_into().expect("8 bytes"));
    }
    let acc = acc.to_ne_bytes().iter().fold(0, |a, &b| a | b);
    chunks.remainder().iter().fold(acc, |a, &b| a | b)
}

/// Whether every flag is 0 or 1 (one pass, no branch per value: a value
/// above 1 has a bit above bit 0).
#[inline]
fn flags_ok(flags: &[u8]) -> bool {
    or_bytes(flags) <= 1
}

/// Whether every byte is 1 (a mask of every lane).
#[inline]
fn all_ones(mask: &[u8]) -> bool {
    let mut chunks = mask.chunks_exact(8);
    let ones = u64::from_ne_bytes([1; 8]);
    chunks.all(|c| u64::from_ne_bytes(c.try_into().expect("8 bytes")) == ones)
        && chunks.remainder().iter().all(|&m| m == 1)
}

/// Whether every value is finite, in one pass without a branch per value:
/// `x - x` is 0 for a finite `x` and NaN for an infinite or NaN one, and a
/// NaN stays in a sum (four sums, so the compiler can use vector adds
/// without reordering any one of them).
#[inline]
#[allow(clippy::eq_op)] // `x - x` is the test, not a mistake
fn all_finite(values: &[f64]) -> bool {
    let mut chunks = values.chunks_exact(4);
    let mut acc = [0.0f64; 4];
    for c in &mut chunks {
        for k in 0..4 {
            acc[k] += c[k] - c[k];
        }
    }
    let tail = chunks.remainder().iter().fold(0.0, |a, &x| a + (x - x));
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail == 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_finite_finds_any_non_finite_value_at_any_position() {
        for n in 0..40 {
            let ok: Vec<f64> = (0..n).map(|i| (i as f64 - 7.5) * 1e300).collect();
            assert!(all_finite(&ok), "{n}");
            for i in 0..n {
                for bad in [f64::NAN, -f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                    let mut v = ok.clone();
                    v[i] = bad;
                    assert!(!all_finite(&v), "{n} {i} {bad}");
                }
            }
        }
        assert!(all_finite(&[
            f64::MAX,
            f64::MIN,
            -0.0,
            f64::MIN_POSITIVE / 2.0
        ]));
    }

    #[test]
    fn flags_and_masks_are_checked_at_every_position() {
        for n in 0..40 {
            let zeros = vec![0u8; n];
            let ones = vec![1u8; n];
            assert!(flags_ok(&zeros) && flags_ok(&ones) && all_ones(&ones));
            assert_eq!(all_ones(&zeros), n == 0);
            for i in 0..n {
                for bad in [2u8, 3, 0x80, 0xff] {
                    let mut v = ones.clone();
                    v[i] = bad;
                    assert!(!flags_ok(&v) && !all_ones(&v), "{n} {i} {bad}");
                }
                let mut v = ones.clone();
                v[i] = 0;
                assert!(flags_ok(&v) && !all_ones(&v));
            }
        }
    }
}

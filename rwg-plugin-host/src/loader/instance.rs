//! [`PluginEnv`]: an instance of a plugin environment, the host-side
//! [`Environment`] over the plugin's function table, and how
//! [`PluginEnvType`] creates it.

use std::ffi::{c_char, CStr, CString};

use super::handshake::{buf_message, plugin_text};
use super::{PluginEnvType, PluginInfo, ERR_BUF_LEN};
use rwg_env::env::{Action, EnvError, EnvSpec, Environment, Step};
use rwg_env::plugin::abi::*;
use rwg_env::space::Space;
use rwg_env::time_limit::TimeLimit;

impl PluginEnvType {
    /// The spec from the descriptor (with the plugin's time limit, which
    /// [`PluginEnvType::make`] applies).
    pub fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    /// The environment id.
    pub fn id(&self) -> &str {
        &self.spec.id
    }

    /// The one-line summary.
    pub fn summary(&self) -> &str {
        &self.summary
    }

    /// Facts about the plugin that exports it.
    pub fn plugin(&self) -> &PluginInfo {
        &self.info
    }

    pub(super) fn prefix(&self) -> String {
        format!("plugin '{}' env '{}'", self.info.id, self.spec.id)
    }

    /// Creates a raw instance (no time limit, and reset-before-step left to
    /// the plugin). `config` is passed to the plugin verbatim.
    pub fn create(&self, config: &str) -> Result<PluginEnv, EnvError> {
        let c = CString::new(config).map_err(|_| {
            EnvError::Other(format!("{}: the config contains a NUL byte", self.prefix()))
        })?;
        let mut buf = [0 as c_char; ERR_BUF_LEN];
        let mut out: *mut RwgEnv = std::ptr::null_mut();
        // SAFETY: the arguments follow the header's contract for create.
        let status = unsafe {
            (self.vt.create)(
                self.index,
                c.as_ptr(),
                &mut out,
                buf.as_mut_ptr(),
                buf.len(),
            )
        };
        super::std_fds::refill();
        if status != RWG_OK {
            return Err(EnvError::Other(format!(
                "{}: create failed with {} ({status}): {}",
                self.prefix(),
                status_name(status),
                buf_message(&buf)
            )));
        }
        if out.is_null() {
            return Err(EnvError::Other(format!(
                "{}: create returned RWG_OK but no instance",
                self.prefix()
            )));
        }
        let discrete = matches!(self.spec.action_space, Space::Discrete { .. });
        Ok(PluginEnv {
            prefix: self.prefix(),
            ty: self.clone(),
            config: config.to_string(),
            handle: out,
            poisoned: false,
            discrete,
            obs_dim: self.spec.obs_dim(),
            step_fn: self.vt.step,
        })
    }

    /// Creates an instance wrapped in [`TimeLimit`] with the descriptor's
    /// `max_episode_steps` (or `max_episode_steps` if given): what rwg runs.
    pub fn make(
        &self,
        config: &str,
        max_episode_steps: Option<u32>,
    ) -> Result<TimeLimit<PluginEnv>, EnvError> {
        Ok(TimeLimit::new(self.create(config)?, max_episode_steps))
    }
}

/// A plugin environment instance, implementing [`Environment`] over the
/// plugin's function table.
///
/// It checks what the plugin returns: a non-`RWG_OK` status becomes an
/// [`EnvError`] carrying the plugin's `last_error` message; non-finite
/// observations or rewards and flags other than 0/1 are errors naming the
/// plugin, the env and the value. After `RWG_ERR_PANIC` the instance is
/// poisoned and no longer called. `PluginEnv` has no time limit: use
/// [`PluginEnvType::make`] for the [`TimeLimit`]-wrapped env.
pub struct PluginEnv {
    ty: PluginEnvType,
    pub(super) prefix: String,
    config: String,
    pub(super) handle: *mut RwgEnv,
    pub(super) poisoned: bool,
    discrete: bool,
    /// `spec.obs_dim()` and the table's `step`, kept at hand for the step loop.
    obs_dim: usize,
    step_fn: StepFn,
}

// SAFETY: the ABI allows an instance to move between threads between calls;
// every call goes through `&mut self`, so one thread at a time uses it.
unsafe impl Send for PluginEnv {}
// SAFETY: `&PluginEnv` gives access to nothing that calls the plugin.
unsafe impl Sync for PluginEnv {}

impl std::fmt::Debug for PluginEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PluginEnv")
            .field("plugin", &self.ty.info.id)
            .field("env", &self.ty.spec.id)
            .field("config", &self.config)
            .field("poisoned", &self.poisoned)
            .finish()
    }
}

impl Drop for PluginEnv {
    fn drop(&mut self) {
        // SAFETY: the handle came from this table's create and is destroyed once.
        unsafe { (self.ty.vt.destroy)(self.handle) }
    }
}

impl PluginEnv {
    /// The environment type this instance belongs to.
    pub fn env_type(&self) -> &PluginEnvType {
        &self.ty
    }

    /// The config string it was created with.
    pub fn config(&self) -> &str {
        &self.config
    }

    /// Whether the plugin reported a panic on this instance.
    pub fn is_poisoned(&self) -> bool {
        self.poisoned
    }

    /// A new instance of the same type and config (not a copy of the state).
    pub fn try_clone(&self) -> Result<PluginEnv, EnvError> {
        self.ty.create(&self.config)
    }

    pub(super) fn fail(&mut self, what: &str, status: Status) -> EnvError {
        // SAFETY: valid handle; the string is read before any other call.
        let msg = unsafe {
            let p = (self.ty.vt.last_error)(self.handle);
            if p.is_null() {
                String::new()
            } else {
                plugin_text(CStr::from_ptr(p))
            }
        };
        self.poisoned |= status == RWG_ERR_PANIC;
        call_error(&self.prefix, what, status, &msg)
    }

    fn check_usable(&self, obs: &[f64]) -> Result<(), EnvError> {
        if self.poisoned {
            return Err(EnvError::Other(format!(
                "{}: the instance is poisoned by an earlier panic in the plugin",
                self.prefix
            )));
        }
        let dim = self.obs_dim;
        if obs.len() != dim {
            return Err(EnvError::Other(format!(
                "{}: obs buffer has length {}, the observation space has {dim}",
                self.prefix,
                obs.len()
            )));
        }
        Ok(())
    }

    pub(super) fn check_obs(&self, what: &str, obs: &[f64]) -> Result<(), EnvError> {
        check_obs(&self.prefix, what, obs)
    }

    /// `reset` with the raw `has_seed` flag (rwg's own reset always passes 1).
    pub fn reset_raw(&mut self, has_seed: u8, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.check_usable(obs)?;
        obs.fill(f64::NAN);
        // SAFETY: valid handle; obs is a live buffer of obs.len() doubles.
        let status =
            unsafe { (self.ty.vt.reset)(self.handle, has_seed, seed, obs.as_mut_ptr(), obs.len()) };
        if status != RWG_OK {
            return Err(self.fail("reset", status));
        }
        self.check_obs("reset", obs)
    }

    /// `step` with the action as the raw double array that crosses the ABI
    /// (a discrete action is one integral double). Nothing is checked before
    /// the call: `rwg check` uses this to probe the plugin's own checks.
    pub fn step_raw(&mut self, action: &[f64], obs: &mut [f64]) -> Result<Step, EnvError> {
        if self.poisoned || obs.len() != self.obs_dim {
            return Err(self.unusable(obs));
        }
        obs.fill(f64::NAN);
        // Values a plugin cannot leave there by accident unnoticed.
        let mut out = RwgStepOut {
            reward: f64::NAN,
            terminated: 0xff,
            truncated: 0xff,
            reserved: [0; 6],
        };
        // SAFETY: valid handle; the buffers are live for the call.
        let status = unsafe {
            (self.step_fn)(
                self.handle,
                if action.is_empty() {
                    std::ptr::null()
                } else {
                    action.as_ptr()
                },
                action.len(),
                obs.as_mut_ptr(),
                obs.len(),
                &mut out,
            )
        };
        // One test for everything that can be wrong; the message is built
        // out of line, so the step loop stays small.
        if status != RWG_OK
            || (out.terminated | out.truncated) > 1
            || !out.reward.is_finite()
            || !obs.iter().all(|x| x.is_finite())
        {
            return Err(self.step_failure(status, &out, obs));
        }
        Ok(Step {
            reward: out.reward,
            terminated: out.terminated == 1,
            truncated: out.truncated == 1,
        })
    }

    /// The error of a step whose status, flags, reward or observation is bad,
    /// checked in that order.
    #[cold]
    #[inline(never)]
    pub(super) fn step_failure(
        &mut self,
        status: Status,
        out: &RwgStepOut,
        obs: &[f64],
    ) -> EnvError {
        if status != RWG_OK {
            return self.fail("step", status);
        }
        output_error(&self.prefix, out, obs)
    }

    /// The error of [`PluginEnv::check_usable`], out of line.
    #[cold]
    #[inline(never)]
    fn unusable(&self, obs: &[f64]) -> EnvError {
        match self.check_usable(obs) {
            Err(e) => e,
            Ok(()) => EnvError::Other(format!("{}: unusable instance", self.prefix)),
        }
    }
}

impl Environment for PluginEnv {
    fn spec(&self) -> &EnvSpec {
        &self.ty.spec
    }

    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.reset_raw(1, seed, obs)
    }

    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        match (action, self.discrete) {
            (Action::Discrete(a), true) => {
                // Exactly representable: checked so the plugin sees the same integer.
                if a.unsigned_abs() > MAX_DISCRETE_N {
                    return Err(EnvError::InvalidAction(format!(
                        "{}: discrete action {a} is out of range",
                        self.prefix
                    )));
                }
                self.step_raw(&[a as f64], obs)
            }
            (Action::Continuous(a), false) => self.step_raw(a, obs),
            (Action::Discrete(a), false) => Err(EnvError::InvalidAction(format!(
                "{}: discrete action {a} given to a continuous action space",
                self.prefix
            ))),
            (Action::Continuous(_), true) => Err(EnvError::InvalidAction(format!(
                "{}: a continuous action was given to a discrete action space",
                self.prefix
            ))),
        }
    }
}

/// The error of a call (`what`: "reset", "step") that returned `status`,
/// with the plugin's message `msg`, for the instance or lane `prefix` names.
pub(super) fn call_error(prefix: &str, what: &str, status: Status, msg: &str) -> EnvError {
    let text = format!(
        "{prefix}: {what} failed with {} ({status}){}{msg}",
        status_name(status),
        if msg.is_empty() { "" } else { ": " }
    );
    match status {
        RWG_ERR_INVALID_ARGUMENT if what == "step" => EnvError::InvalidAction(text),
        RWG_ERR_RESET_NEEDED => EnvError::ResetNeeded,
        RWG_ERR_UNSUPPORTED => EnvError::Unsupported(text),
        _ => EnvError::Other(text),
    }
}

/// `Ok` if every value of the observation `what` returned is finite.
pub(super) fn check_obs(prefix: &str, what: &str, obs: &[f64]) -> Result<(), EnvError> {
    match obs.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(i) => Err(EnvError::NonFinite(format!(
            "{prefix}: {what} returned a non-finite observation: obs[{i}] = {}",
            obs[i]
        ))),
    }
}

/// The error of one lane's step outputs (a call that returned `RWG_OK`),
/// or `None` if its flags are 0 or 1 and its reward and observation finite:
/// the lane-by-lane pass of the batched calls and the vector env.
pub(super) fn lane_output_error(
    prefix: &str,
    reward: f64,
    terminated: u8,
    truncated: u8,
    obs: &[f64],
) -> Option<EnvError> {
    let bad =
        (terminated | truncated) > 1 || !reward.is_finite() || !obs.iter().all(|x| x.is_finite());
    bad.then(|| {
        let out = RwgStepOut {
            reward,
            terminated,
            truncated,
            reserved: [0; 6],
        };
        output_error(prefix, &out, obs)
    })
}

/// The error of a step that returned `RWG_OK` with a bad flag, reward or
/// observation, checked in that order.
#[cold]
#[inline(never)]
pub(super) fn output_error(prefix: &str, out: &RwgStepOut, obs: &[f64]) -> EnvError {
    for (name, v) in [("terminated", out.terminated), ("truncated", out.truncated)] {
        if v > 1 {
            return EnvError::Other(format!(
                "{prefix}: step returned {name} = {v} (must be 0 or 1)"
            ));
        }
    }
    if !out.reward.is_finite() {
        return EnvError::NonFinite(format!(
            "{prefix}: step returned a non-finite reward: {}",
            out.reward
        ));
    }
    match check_obs(prefix, "step", obs) {
        Err(e) => e,
        Ok(()) => EnvError::Other(format!("{prefix}: step failed")),
    }
}

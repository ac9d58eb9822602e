//! Whether the lockstep envs' steps run compiled for AVX2.
//!
//! rwg is built for baseline x86-64 (SSE2: two `f64` per vector). An env's
//! step body is also compiled a second time with AVX2 enabled (four per
//! vector) and chosen at run time. Both compile the same IEEE operations in
//! the same order: Rust never contracts `a * b + c` into a fused
//! multiply-add, and AVX2 alone does not enable FMA, so the two give the
//! same bits (the lockstep tests compare lanes with the scalar envs under
//! either). `RWG_LOCKSTEP_AVX2=0` (read once) forces the baseline body.

/// The environment variable that turns the AVX2 step bodies off (`0`).
pub const AVX2_VAR: &str = "RWG_LOCKSTEP_AVX2";

/// [`AVX2_VAR`]: `1` or unset: the AVX2 bodies where the CPU has AVX2, `0`:
/// the baseline; an error naming the variable for any other value.
pub fn avx2_setting() -> Result<bool, rwg_env::vars::VarError> {
    rwg_env::vars::switch(
        AVX2_VAR,
        true,
        "0: the lockstep envs' baseline step bodies, not their AVX2 ones",
    )
}

/// Whether to run the AVX2 bodies: the CPU has AVX2 and
/// `RWG_LOCKSTEP_AVX2=0` is not set.
#[cfg(target_arch = "x86_64")]
pub(crate) fn avx2() -> bool {
    use std::sync::atomic::{AtomicU8, Ordering::Relaxed};
    // 0: not decided yet, 1: no, 2: yes.
    static CHOICE: AtomicU8 = AtomicU8::new(0);
    match CHOICE.load(Relaxed) {
        1 => false,
        2 => true,
        _ => {
            let on = avx2_setting().unwrap_or(true);
            let yes = on && is_x86_feature_detected!("avx2");
            CHOICE.store(if yes { 2 } else { 1 }, Relaxed);
            yes
        }
    }
}

/// For a lockstep env type `$ty<N>` with an inherent, `#[inline(always)]`
/// `step_body` (the arguments of [`rwg_env::many::ManyEnv::step_many`], the
/// per-lane ones as arrays of `N`: [`crate::lockstep::lane_arrays`]),
/// defines `step_dispatch`, which runs `step_body` compiled for AVX2 when
/// [`avx2`] says so and the baseline build otherwise. The env's
/// `step_many` is [`step_many_dispatched`]'s, which calls it.
macro_rules! wide_step {
    ($ty:ident) => {
        impl<const N: usize> $ty<N> {
            /// [`Self::step_body`], compiled for AVX2 or not
            /// ([`crate::lockstep::wide`]).
            #[inline(always)]
            #[allow(clippy::too_many_arguments)]
            fn step_dispatch(
                &mut self,
                mask: &[u8],
                actions: &[f64],
                obs: &mut [f64],
                rewards: &mut [f64],
                terminated: &mut [u8],
                truncated: &mut [u8],
                on_fail: &mut dyn FnMut(usize, EnvError),
            ) {
                let (mask, actions, rewards, terminated, truncated) =
                    $crate::lockstep::lane_arrays::<N>(
                        mask, actions, rewards, terminated, truncated,
                    );
                #[cfg(target_arch = "x86_64")]
                if $crate::lockstep::wide::avx2() {
                    // SAFETY: the CPU has AVX2 (checked at run time).
                    unsafe {
                        return self.step_avx2(
                            mask, actions, obs, rewards, terminated, truncated, on_fail,
                        );
                    }
                }
                self.step_body(mask, actions, obs, rewards, terminated, truncated, on_fail)
            }

            /// [`Self::step_body`] compiled with AVX2 enabled.
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2")]
            #[allow(clippy::too_many_arguments)]
            unsafe fn step_avx2(
                &mut self,
                mask: &[u8; N],
                actions: &[f64; N],
                obs: &mut [f64],
                rewards: &mut [f64; N],
                terminated: &mut [u8; N],
                truncated: &mut [u8; N],
                on_fail: &mut dyn FnMut(usize, EnvError),
            ) {
                self.step_body(mask, actions, obs, rewards, terminated, truncated, on_fail)
            }
        }
    };
}
pub(crate) use wide_step;

/// Inside `impl ManyEnv for $ty<N>`: `step_many` as a call of the
/// `step_dispatch` that [`wide_step`] defines.
macro_rules! step_many_dispatched {
    () => {
        fn step_many(
            &mut self,
            mask: &[u8],
            actions: &[f64],
            obs: &mut [f64],
            rewards: &mut [f64],
            terminated: &mut [u8],
            truncated: &mut [u8],
            on_fail: &mut dyn FnMut(usize, EnvError),
        ) {
            self.step_dispatch(mask, actions, obs, rewards, terminated, truncated, on_fail)
        }
    };
}
pub(crate) use step_many_dispatched;

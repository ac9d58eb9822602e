//! Which instruction set the lockstep envs' steps run compiled for.
//!
//! rwg is built for baseline x86-64 (SSE2: two `f64` per vector). An env's
//! step body is also compiled with AVX2 enabled (four per vector) and with
//! AVX-512F/DQ/VL enabled (eight per vector), and the build to run is
//! [`rwg_env::simd::level`]'s (`RWG_SIMD`, else AVX2 where the CPU has it). All
//! three compile the same IEEE operations in the same order: Rust never
//! contracts `a * b + c` into a fused multiply-add (and the step bodies
//! call no `mul_add`), so they give the same bits (the lockstep tests
//! compare lanes with the scalar envs at every level the CPU has).

/// For a lockstep env type `$ty<N>` with an inherent, `#[inline(always)]`
/// `step_body` (the arguments of [`rwg_env::many::ManyEnv::step_many`], the
/// per-lane ones as arrays of `N`: [`crate::lockstep::lane_arrays`]),
/// defines `step_dispatch`, which runs `step_body` compiled for the level
/// [`rwg_env::simd::level`] names: AVX-512, AVX2, or the baseline build for
/// `scalar`. The env's `step_many` is [`step_many_dispatched`]'s, which
/// calls it.
macro_rules! wide_step {
    ($ty:ident) => {
        impl<const N: usize> $ty<N> {
            /// [`Self::step_body`], compiled for the SIMD level
            /// ([`crate::lockstep::wide`]).
            #[inline(always)]
            #[expect(
                clippy::too_many_arguments,
                reason = "`ManyEnv::step_many`'s buffers, one argument each"
            )]
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
                match rwg_env::simd::level() {
                    // SAFETY: `level` names only a level the CPU has.
                    rwg_env::simd::Simd::Avx512 => unsafe {
                        return self.step_avx512(
                            mask, actions, obs, rewards, terminated, truncated, on_fail,
                        );
                    },
                    // SAFETY: as above.
                    rwg_env::simd::Simd::Avx2 => unsafe {
                        return self.step_avx2(
                            mask, actions, obs, rewards, terminated, truncated, on_fail,
                        );
                    },
                    rwg_env::simd::Simd::Scalar => {}
                }
                self.step_body(mask, actions, obs, rewards, terminated, truncated, on_fail)
            }

            /// [`Self::step_body`] compiled with AVX2 enabled.
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2")]
            #[expect(
                clippy::too_many_arguments,
                reason = "`ManyEnv::step_many`'s buffers, one argument each"
            )]
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

            /// [`Self::step_body`] compiled with AVX-512F, DQ and VL enabled.
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx512f,avx512dq,avx512vl")]
            #[expect(
                clippy::too_many_arguments,
                reason = "`ManyEnv::step_many`'s buffers, one argument each"
            )]
            unsafe fn step_avx512(
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

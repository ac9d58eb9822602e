//! Which SIMD instruction set rwg's vector code runs: the widest the CPU
//! has, or the one `RWG_SIMD` asks for.
//!
//! Every vector path in rwg (the glibc-exact `sin`/`cos` and `pow(x, 2)` of
//! [`crate::lanes_math`], the policy networks' forward pass and `tanh`, the
//! lockstep envs' step bodies) gives the same bits at every level; only the
//! speed differs. One switch picks the level for all of them, so a
//! benchmark or a bug report can compare them:
//!
//! - `RWG_SIMD=avx512`: eight `f64` lanes (AVX-512F, DQ and VL, with AVX2
//!   and FMA);
//! - `RWG_SIMD=avx2`: four lanes (AVX2 and FMA);
//! - `RWG_SIMD=scalar`: the target's baseline (SSE2 on x86-64) and one libm
//!   call per `sin`/`cos`/`pow` element.
//!
//! Unset, rwg runs [`Simd::default_level`]: AVX2 where the CPU
//! has it, else scalar. AVX-512 runs only when asked for (`RWG_SIMD=avx512`
//! on a CPU that has it), because whether it pays depends on the CPU: on an
//! Intel Xeon it ran the peer workloads of `rwg bench peers` in 0.70-0.94 of
//! AVX2's CPU time, on another AVX-512 CPU whole runs took 0.90-1.11 of it.
//! Its algorithms are tested at eight lanes in plain Rust on every CPU, and
//! its own bit-for-bit tests run on any AVX-512 CPU (`cargo test` picks
//! every level the CPU has). The `sin`/`cos`/`pow` code of each level still passes
//! a self-check against libm before it is used (`lanes_math`). A level the
//! CPU lacks is an error naming the variable ([`setting`]); [`level`] then
//! runs the default, and `rwg` refuses to start.

use crate::vars::VarError;
use std::sync::OnceLock;

/// The environment variable that picks the level.
pub const VAR: &str = "RWG_SIMD";

/// An instruction-set level, narrowest first (so `a < b` means `a` is
/// narrower).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Simd {
    /// The target's baseline (SSE2 on x86-64); libm per element.
    Scalar,
    /// AVX2 and FMA: four `f64` lanes.
    Avx2,
    /// AVX-512F, DQ and VL (with AVX2 and FMA): eight `f64` lanes.
    Avx512,
}

impl Simd {
    /// Every level, narrowest first.
    pub const ALL: [Simd; 3] = [Simd::Scalar, Simd::Avx2, Simd::Avx512];

    /// The name `RWG_SIMD` takes: `scalar`, `avx2` or `avx512`.
    pub fn name(self) -> &'static str {
        match self {
            Simd::Scalar => "scalar",
            Simd::Avx2 => "avx2",
            Simd::Avx512 => "avx512",
        }
    }

    /// The level called `name` (see [`Simd::name`]).
    pub fn from_name(name: &str) -> Option<Simd> {
        Simd::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The widest level this CPU has (detected once).
    pub fn cpu() -> Simd {
        static CPU: OnceLock<Simd> = OnceLock::new();
        *CPU.get_or_init(detect)
    }

    /// The level rwg runs when `RWG_SIMD` is unset: the CPU's widest, but
    /// at most [`Simd::Avx2`] (AVX-512 only when asked for: see the module
    /// docs).
    pub fn default_level() -> Simd {
        Simd::cpu().min(Simd::Avx2)
    }

    /// Whether this CPU can run `self`.
    pub fn available(self) -> bool {
        self <= Simd::cpu()
    }

    /// Every level this CPU can run, narrowest first (for tests and
    /// benchmarks that compare them).
    pub fn available_levels() -> Vec<Simd> {
        Simd::ALL.into_iter().filter(|s| s.available()).collect()
    }
}

impl std::fmt::Display for Simd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

fn detect() -> Simd {
    #[cfg(target_arch = "x86_64")]
    {
        let avx2 = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
        let avx512 = avx2
            && is_x86_feature_detected!("avx512f")
            && is_x86_feature_detected!("avx512dq")
            && is_x86_feature_detected!("avx512vl");
        if avx512 {
            return Simd::Avx512;
        }
        if avx2 {
            return Simd::Avx2;
        }
    }
    Simd::Scalar
}

/// `RWG_SIMD`: `None` if unset, the level it names if this CPU has
/// it; an error naming the variable for an unknown name or a level the CPU
/// lacks.
pub fn setting() -> Result<Option<Simd>, VarError> {
    match crate::vars::value(VAR)? {
        None => Ok(None),
        Some(v) => parse(&v).map(Some),
    }
}

/// `value` of `RWG_SIMD` as a level this CPU has (see [`setting`]).
pub fn parse(value: &str) -> Result<Simd, VarError> {
    let names = Simd::ALL.map(Simd::name).join(", ");
    let Some(level) = Simd::from_name(value.trim()) else {
        return Err(VarError {
            var: VAR,
            value: value.into(),
            expected: format!("one of {names} (the SIMD instruction set rwg's vector code runs)"),
        });
    };
    if !level.available() {
        let have = Simd::available_levels()
            .into_iter()
            .map(Simd::name)
            .collect::<Vec<_>>()
            .join(", ");
        return Err(VarError {
            var: VAR,
            value: value.into(),
            expected: format!("a level this CPU has: {have} (it has no {level})"),
        });
    }
    Ok(level)
}

/// The level every vector path runs, decided once per process: `RWG_SIMD`
/// if set to a level the CPU has, else [`Simd::default_level`].
pub fn level() -> Simd {
    static LEVEL: OnceLock<Simd> = OnceLock::new();
    *LEVEL.get_or_init(|| setting().ok().flatten().unwrap_or_else(Simd::default_level))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_order_is_width() {
        for s in Simd::ALL {
            assert_eq!(Simd::from_name(s.name()), Some(s));
        }
        assert!(Simd::Scalar < Simd::Avx2 && Simd::Avx2 < Simd::Avx512);
        assert_eq!(Simd::from_name("sse2"), None);
    }

    #[test]
    fn parse_names_the_variable_and_the_choices() {
        let e = parse("avx1024").unwrap_err();
        assert_eq!(e.var, VAR);
        assert!(e.expected.contains("scalar, avx2, avx512"), "{e}");
        assert_eq!(parse(" scalar ").unwrap(), Simd::Scalar);
        for s in Simd::ALL {
            match parse(s.name()) {
                Ok(got) => assert!(s.available() && got == s),
                Err(e) => {
                    assert!(!s.available());
                    assert!(e.expected.contains("this CPU has"), "{e}");
                }
            }
        }
    }

    #[test]
    fn levels_available_are_a_prefix() {
        let have = Simd::available_levels();
        assert_eq!(have[0], Simd::Scalar);
        assert_eq!(*have.last().unwrap(), Simd::cpu());
        assert_eq!(have.len(), Simd::cpu() as usize + 1);
        assert!(Simd::default_level() <= Simd::Avx2);
        assert!(Simd::default_level().available());
        if Simd::Avx2.available() {
            assert_eq!(Simd::default_level(), Simd::Avx2);
        }
    }
}

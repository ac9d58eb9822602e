//! # rwg-glibc-sincos
//!
//! glibc 2.36's x86-64 `sin` and `cos` (the `__sin_fma` / `__cos_fma`
//! variants its ifuncs pick on CPUs with AVX2 and FMA) over many arguments
//! at once, for |x| < 105414350: the same operations in the same order with
//! the same constants and table, so the same bits. Lanes beyond that range
//! (huge, ±inf, NaN) go to the libm functions the caller passes in.
//!
//! Two widths, one algorithm (`kernel.rs`, written over a trait of vector
//! operations, so both fuse the same products and round the same way):
//!
//! - [`sin_lanes`], [`cos_lanes`], [`sincos_lanes`]: four lanes with AVX2
//!   and FMA (`fma.rs`);
//! - [`avx512::sin_lanes`], [`avx512::cos_lanes`], [`avx512::sincos_lanes`]:
//!   eight lanes with AVX-512F, DQ and VL (`avx512.rs`), same signatures.
//!
//! `rwg_env::lanes_math` uses this crate behind its `glibc-sincos` feature,
//! at the width `rwg_env::simd::level()` picks (`RWG_SIMD`), and only after
//! a one-time self-check of that width against the process's own libm; that
//! module is the interface to use (it falls back to one libm call per
//! element whenever this crate is absent or does not apply). The entry
//! points here are `unsafe`: calling them is sound only on a CPU with their
//! instruction sets. On other architectures the crate is empty.
//!
//! # Example
//!
//! Four arguments at once, the last beyond the vector range (handed to the
//! libm function passed in); every result has the bits of the process's own
//! libm `sin`, which Rust's `f64::sin` calls:
//!
//! ```
//! # #[cfg(target_arch = "x86_64")]
//! # {
//! if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
//!     let x = [0.5, -1.25, 3.0, 1e300];
//!     let mut out = [0.0; 4];
//!     // SAFETY: the CPU has AVX2 and FMA (checked just above).
//!     unsafe { rwg_glibc_sincos::sin_lanes(&x, &mut out, f64::sin) };
//!     for (x, s) in x.iter().zip(out) {
//!         assert_eq!(s.to_bits(), x.sin().to_bits());
//!     }
//! }
//! # }
//! ```
//!
//! # Origin and licence
//!
//! This crate is a translation into Rust (AVX2+FMA intrinsics over four
//! lanes, AVX-512 intrinsics over eight) of parts of the GNU C Library's
//! libm, and is distributed under the same licence as they are: the **GNU
//! Lesser General Public License, version 2.1 or (at your option) any later
//! version** (`COPYING` beside this crate's `Cargo.toml`).
//!
//! - `kernel.rs` (the algorithm and constants), `fma.rs` and `avx512.rs`
//!   (its vector operations at four and eight lanes): `__sin` / `__cos`
//!   (with their helpers `do_sin`, `do_cos`, `reduce_sincos`,
//!   `TAYLOR_SIN`) from glibc's `sysdeps/ieee754/dbl-64/s_sin.c`, IBM Accurate Mathematical Library,
//!   written by International Business Machines Corp., Copyright (C)
//!   2001-2022 Free Software Foundation, Inc.; which products glibc's build
//!   fuses was read off the machine code of `__sin_fma` / `__cos_fma` in
//!   Debian 12's libm (2.36-9).
//! - `table.rs`: `__sincostab` from glibc's
//!   `sysdeps/ieee754/dbl-64/sincostab.c` (same authors and copyright), its
//!   bits read from that libm.
//!
//! The rest of rwg is MIT OR Apache-2.0; an `rwg` binary built with this
//! crate (its default) is a combined work under the LGPL's section 6, and
//! this crate's source is part of rwg's source distribution.

#[cfg(target_arch = "x86_64")]
pub mod avx512;
#[cfg(target_arch = "x86_64")]
mod fma;
#[cfg(target_arch = "x86_64")]
mod kernel;
#[cfg(target_arch = "x86_64")]
mod table;
#[cfg(all(test, target_arch = "x86_64"))]
mod tests;

#[cfg(target_arch = "x86_64")]
pub use fma::{cos_lanes, sin_lanes, sincos_lanes};

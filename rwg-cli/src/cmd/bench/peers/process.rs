//! The processes of `rwg bench peers`: running a side to completion with
//! its children's CPU time, pinning to one core, the scratch directory.

use anyhow::{bail, Context, Result};
use std::path::PathBuf;
use std::process::Command;

/// CPU seconds (user + system) of the waited-for children of this process.
pub(super) fn children_cpu_seconds() -> Result<f64> {
    #[cfg(unix)]
    {
        // SAFETY: an all-zero rusage is a valid value; getrusage only writes it.
        let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
        // SAFETY: `ru` is valid and writable for the call.
        let rc = unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut ru) };
        if rc != 0 {
            bail!("getrusage failed: {}", std::io::Error::last_os_error());
        }
        let t = |tv: libc::timeval| tv.tv_sec as f64 + tv.tv_usec as f64 * 1e-6;
        Ok(t(ru.ru_utime) + t(ru.ru_stime))
    }
    #[cfg(not(unix))]
    {
        bail!("rwg bench peers needs a Unix system (getrusage)")
    }
}

/// Pins this process (and so the children it starts) to `cpu`.
pub(super) fn pin_to(cpu: usize) -> Result<()> {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: an all-zero cpu_set_t is the empty set; CPU_SET writes in bounds
        // (checked against CPU_SETSIZE); sched_setaffinity reads the set.
        unsafe {
            if cpu >= libc::CPU_SETSIZE as usize {
                bail!("--cpu {cpu} is out of range");
            }
            let mut set: libc::cpu_set_t = std::mem::zeroed();
            libc::CPU_SET(cpu, &mut set);
            if libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set) != 0 {
                bail!(
                    "cannot pin to CPU {cpu}: {} (see --cpu, or --no-pin)",
                    std::io::Error::last_os_error()
                );
            }
        }
        Ok(())
    }
    #[cfg(not(target_os = "linux"))]
    {
        bail!("pinning to CPU {cpu} needs Linux; use --no-pin")
    }
}

/// Runs `cmd` to completion; returns (stdout, child CPU seconds, wall seconds).
pub(super) fn measure(mut cmd: Command, what: &str) -> Result<(String, f64, f64)> {
    let cpu0 = children_cpu_seconds()?;
    let t0 = std::time::Instant::now();
    let out = cmd
        .output()
        .with_context(|| format!("cannot start {what}"))?;
    let wall = t0.elapsed().as_secs_f64();
    let cpu = children_cpu_seconds()? - cpu0;
    if !out.status.success() {
        bail!(
            "{what} failed ({}):\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok((String::from_utf8_lossy(&out.stdout).into_owned(), cpu, wall))
}

/// Removes the temporary work directory when dropped.
pub(super) struct TempDir(pub(super) Option<PathBuf>);

impl Drop for TempDir {
    fn drop(&mut self) {
        if let Some(d) = &self.0 {
            let _ = std::fs::remove_dir_all(d);
        }
    }
}

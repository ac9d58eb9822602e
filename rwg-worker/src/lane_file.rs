//! The lane file (`lane_file` in the hello message): 8 bytes the worker
//! maps into memory and into whose first byte it writes the instance it is
//! resetting or stepping (255: none), so that the host can name the episode
//! when the worker dies or hangs. [`LaneFile`] is the host's side,
//! [`LaneMark`] a Rust worker's.

/// The mark of a worker between calls (and before its first).
pub const NO_LANE: u8 = 255;

/// The host's side: creates the file, reads the lane, removes the file.
/// It reads through a handle of its own, so the file's name can be
/// removed as soon as the worker has mapped it ([`LaneFile::mapped`]): a
/// host killed later (SIGKILL skips `Drop`) leaves nothing behind.
pub struct LaneFile {
    path: Option<std::path::PathBuf>,
    file: Option<std::fs::File>,
}

impl LaneFile {
    /// A new lane file in the temporary directory (no file if it cannot be
    /// written: the worker still runs, failures just name no lane).
    pub fn create() -> LaneFile {
        use std::sync::atomic::{AtomicU64, Ordering};
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let p = std::env::temp_dir().join(format!(
            "rwg-gym-lane-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let file = std::fs::write(&p, [255u8; 8])
            .and_then(|()| std::fs::File::open(&p))
            .ok();
        let path = match file {
            Some(_) => Some(p),
            None => {
                let _ = std::fs::remove_file(&p);
                None
            }
        };
        LaneFile { path, file }
    }

    /// Its path, for the hello message.
    pub fn path(&self) -> Option<String> {
        self.path.as_ref().map(|p| p.to_string_lossy().into_owned())
    }

    /// The worker answered its hello, so it has mapped the file: its name
    /// is removed (on unix; elsewhere it stays until `Drop`), its bytes
    /// stay readable through the host's handle and the worker's mapping.
    pub fn mapped(&mut self) {
        #[cfg(unix)]
        if let Some(p) = self.path.take() {
            let _ = std::fs::remove_file(p);
        }
    }

    /// The lane the worker was resetting or stepping, if any.
    pub fn lane(&self) -> Option<usize> {
        self.mark().filter(|&b| b != NO_LANE).map(usize::from)
    }

    /// The byte the worker last wrote: a lane, or [`NO_LANE`] between
    /// calls; `None` without a file.
    pub fn mark(&self) -> Option<u8> {
        let mut byte = [0u8; 1];
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileExt;
            self.file.as_ref()?.read_exact_at(&mut byte, 0).ok()?;
        }
        #[cfg(not(unix))]
        {
            use std::io::{Read, Seek};
            let mut f = self.file.as_ref()?;
            f.seek(std::io::SeekFrom::Start(0)).ok()?;
            f.read_exact(&mut byte).ok()?;
        }
        Some(byte[0])
    }
}

impl Drop for LaneFile {
    fn drop(&mut self) {
        if let Some(p) = &self.path {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// A worker's side: the file mapped shared, so what is written is in the
/// file even if the process is killed the next instant.
pub struct LaneMark {
    #[cfg(unix)]
    map: *mut u8,
}

// SAFETY: the mapping is owned by this value; writes are single bytes.
unsafe impl Send for LaneMark {}

impl LaneMark {
    /// Maps `path` (unix; `None` elsewhere or if it cannot be mapped).
    pub fn open(path: &str) -> Option<LaneMark> {
        #[cfg(unix)]
        {
            use std::os::unix::io::AsRawFd;
            let f = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .open(path)
                .ok()?;
            // SAFETY: mapping 8 bytes of a file we opened read-write; the
            // mapping outlives the descriptor, which may be closed.
            let map = unsafe {
                libc::mmap(
                    std::ptr::null_mut(),
                    8,
                    libc::PROT_READ | libc::PROT_WRITE,
                    libc::MAP_SHARED,
                    f.as_raw_fd(),
                    0,
                )
            };
            if map == libc::MAP_FAILED {
                return None;
            }
            Some(LaneMark {
                map: map as *mut u8,
            })
        }
        #[cfg(not(unix))]
        {
            let _ = path;
            None
        }
    }

    /// Records that instance `lane` is being reset or stepped (`None`: none).
    #[inline]
    pub fn set(&mut self, lane: Option<usize>) {
        let b = lane.map_or(255, |l| l.min(254) as u8);
        #[cfg(unix)]
        // SAFETY: the first byte of a live 8-byte mapping.
        unsafe {
            std::ptr::write_volatile(self.map, b)
        }
        #[cfg(not(unix))]
        let _ = b;
    }
}

impl Drop for LaneMark {
    fn drop(&mut self) {
        #[cfg(unix)]
        // SAFETY: unmapping our own mapping once.
        unsafe {
            libc::munmap(self.map as *mut libc::c_void, 8);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_host_reads_what_the_worker_marks() {
        let f = LaneFile::create();
        assert_eq!(f.lane(), None);
        let path = f.path().unwrap();
        let mut m = LaneMark::open(&path).unwrap();
        m.set(Some(17));
        assert_eq!(f.lane(), Some(17));
        m.set(None);
        assert_eq!(f.lane(), None);
        drop(m);
        drop(f);
        assert!(!std::path::Path::new(&path).exists());
    }

    #[cfg(unix)]
    #[test]
    fn once_mapped_the_file_has_no_name_and_still_reads() {
        let mut f = LaneFile::create();
        let path = f.path().unwrap();
        let mut m = LaneMark::open(&path).unwrap();
        f.mapped();
        assert!(!std::path::Path::new(&path).exists());
        m.set(Some(3));
        assert_eq!(f.lane(), Some(3));
        m.set(None);
        assert_eq!(f.mark(), Some(NO_LANE));
    }
}

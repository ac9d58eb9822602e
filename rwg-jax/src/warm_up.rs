//! A cell's warm-up: its workers taken (started when none is idle) and
//! compiling the cell, until every one is ready to run chunks. A progress
//! display is told when it starts and ends ([`WarmUpObserver`]); the
//! wall time of every warm-up adds up in [`crate::JaxSource::warm_up_time`]
//! (`rwg run --timing` shows it apart from the running).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Told when a JAX cell's workers warm up (from the thread that runs the
/// cell, and from a worker thread at the end).
pub trait WarmUpObserver: Send + Sync {
    /// A cell's workers start warming up: starting, compiling.
    fn warming_up(&self);
    /// Every worker of the cell is ready (or failed): the warm-up took
    /// `elapsed`, wall time.
    fn warmed_up(&self, elapsed: Duration);
}

/// What a source keeps of its warm-ups: who to tell, the time they took.
#[derive(Default)]
pub(crate) struct WarmUps {
    observers: Mutex<Vec<Arc<dyn WarmUpObserver>>>,
    total: Mutex<Duration>,
}

impl WarmUps {
    pub(crate) fn observe(&self, o: Arc<dyn WarmUpObserver>) {
        lock(&self.observers).push(o);
    }

    pub(crate) fn total(&self) -> Duration {
        *lock(&self.total)
    }

    /// A cell's warm-up by `workers` worker threads begins.
    pub(crate) fn begin(&self, workers: usize) -> WarmUp<'_> {
        let observers = lock(&self.observers).clone();
        for o in &observers {
            o.warming_up();
        }
        WarmUp {
            ups: self,
            observers,
            left: AtomicUsize::new(workers),
            t0: Instant::now(),
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// One cell's warm-up, counting the worker threads not yet ready.
pub(crate) struct WarmUp<'a> {
    ups: &'a WarmUps,
    observers: Vec<Arc<dyn WarmUpObserver>>,
    left: AtomicUsize,
    t0: Instant,
}

impl WarmUp<'_> {
    /// A worker thread is ready (or failed to be): the last one ends the
    /// warm-up.
    pub(crate) fn ready(&self) {
        if self.left.fetch_sub(1, Ordering::AcqRel) == 1 {
            let elapsed = self.t0.elapsed();
            *lock(&self.ups.total) += elapsed;
            for o in &self.observers {
                o.warmed_up(elapsed);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Default)]
    struct Seen(Mutex<Vec<String>>);

    impl WarmUpObserver for Seen {
        fn warming_up(&self) {
            lock(&self.0).push("warming up".into());
        }
        fn warmed_up(&self, _elapsed: Duration) {
            lock(&self.0).push("warm".into());
        }
    }

    #[test]
    fn the_last_worker_ready_ends_the_warm_up() {
        let ups = WarmUps::default();
        let seen = Arc::new(Seen::default());
        ups.observe(seen.clone());
        let w = ups.begin(2);
        assert_eq!(*lock(&seen.0), ["warming up"]);
        std::thread::sleep(Duration::from_millis(5));
        w.ready();
        assert_eq!(*lock(&seen.0), ["warming up"]);
        w.ready();
        assert_eq!(*lock(&seen.0), ["warming up", "warm"]);
        let first = ups.total();
        assert!(first >= Duration::from_millis(5), "{first:?}");
        ups.begin(1).ready();
        assert!(ups.total() >= first);
    }
}

//! Progress of `rwg run` when stderr is not a terminal (a pipe, `nohup`, a
//! batch scheduler's log): a plain line every few seconds that reads well in
//! a log file, instead of a redrawn bar. On a terminal, `rwg run` draws the
//! bar; `--quiet` silences both.
//!
//! The interval is 5 s; `RWG_PROGRESS_INTERVAL` (seconds, may be fractional,
//! 0 for a line per block) overrides it.
//!
//! While a JAX cell's workers start and compile ([`Compiling`]), both say
//! "compiling" with the time it has taken so far, and the rates and the
//! time left count only the time outside such warm-ups: a compile of a
//! minute does not make a cell of seconds look slow.

mod bar;

pub use bar::Bar;
use rwg_jax::warm_up::WarmUpObserver;
use rwg_study::runner::Progress;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// JAX warm-ups as a progress display sees them: the one going on (since
/// when) and the time the finished ones took. Every JAX env's source tells
/// it ([`rwg_jax::JaxSource::observe`]).
#[derive(Debug, Default)]
pub struct Compiling {
    state: Mutex<WarmUps>,
}

#[derive(Debug, Default)]
struct WarmUps {
    since: Option<Instant>,
    done: Duration,
}

impl Compiling {
    fn lock(&self) -> std::sync::MutexGuard<'_, WarmUps> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// When the warm-up going on began, if one is.
    pub fn since(&self) -> Option<Instant> {
        self.lock().since
    }

    /// Of `elapsed` (since the display started), the time outside
    /// warm-ups: what the rates and the time left are computed over.
    pub fn active(&self, elapsed: Duration) -> Duration {
        let w = self.lock();
        let going_on = w.since.map_or(Duration::ZERO, |s| s.elapsed());
        elapsed.saturating_sub(w.done + going_on)
    }
}

impl WarmUpObserver for Compiling {
    fn warming_up(&self) {
        self.lock().since = Some(Instant::now());
    }

    fn warmed_up(&self, _elapsed: Duration) {
        let mut w = self.lock();
        if let Some(s) = w.since.take() {
            w.done += s.elapsed();
        }
    }
}

// the default seconds between two progress lines
use crate::env_vars::DEFAULT_PROGRESS_INTERVAL_S as DEFAULT_INTERVAL_S;

/// `h:mm:ss`.
pub fn hms(secs: f64) -> String {
    let s = if secs.is_finite() {
        secs.max(0.0).round() as u64
    } else {
        0
    };
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

/// Plain progress lines on stderr, one per interval: after a block when the
/// interval has passed, and from a ticker thread when no block ends for a
/// whole interval (a slow Gymnasium cell), so a log never falls silent.
pub struct Lines {
    shared: Arc<Shared>,
    ticker: Option<std::thread::JoinHandle<()>>,
}

struct Shared {
    state: Mutex<State>,
    wake: Condvar,
}

struct State {
    interval: Duration,
    t0: Instant,
    last: Instant,
    total: u64,
    done: u64,
    steps: u64,
    label: String,
    finished: bool,
    compiling: Arc<Compiling>,
}

impl State {
    /// The current line: elapsed time, cell, networks done of total,
    /// networks/s, env steps/s and the estimated time left; while a JAX
    /// cell compiles, "compiling" and for how long instead of the rates.
    fn line(&self) -> String {
        let elapsed = self.t0.elapsed();
        let head = format!(
            "[{}] {}: {}/{} networks ({:.1}%)",
            hms(elapsed.as_secs_f64()),
            self.label,
            self.done,
            self.total,
            100.0 * self.done as f64 / self.total.max(1) as f64,
        );
        if let Some(since) = self.compiling.since() {
            return format!(
                "{head}, compiling for {} (JAX workers starting and compiling the cell)",
                hms(since.elapsed().as_secs_f64())
            );
        }
        let secs = self.compiling.active(elapsed).as_secs_f64().max(1e-9);
        let nets = self.done as f64 / secs;
        let eta = if self.done == 0 {
            "unknown".into()
        } else {
            hms(self.total.saturating_sub(self.done) as f64 / nets)
        };
        format!(
            "{head}, {:.0} networks/s, {:.3e} env steps/s, ETA {}",
            nets,
            self.steps as f64 / secs,
            eta
        )
    }

    /// Emits the current line if a whole interval has passed since the last.
    fn emit_if_due(&mut self) {
        if self.last.elapsed() >= self.interval {
            self.last = Instant::now();
            emit(&self.line());
        }
    }
}

fn emit(s: &str) {
    // a closed stderr is no reason to stop the study
    crate::errln!("{s}");
}

impl Lines {
    /// Lines every [`DEFAULT_INTERVAL_S`] seconds, or `RWG_PROGRESS_INTERVAL`,
    /// showing the warm-ups `compiling` is told of.
    pub fn new(compiling: Arc<Compiling>) -> Self {
        // checked before the command ran (`env_vars::check_all`)
        let interval = crate::env_vars::progress_interval()
            .unwrap_or(Duration::from_secs_f64(DEFAULT_INTERVAL_S));
        let now = Instant::now();
        let state = State {
            interval,
            t0: now,
            last: now,
            total: 0,
            done: 0,
            steps: 0,
            label: String::new(),
            finished: false,
            compiling,
        };
        Lines {
            shared: Arc::new(Shared {
                state: Mutex::new(state),
                wake: Condvar::new(),
            }),
            ticker: None,
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        // a panic elsewhere while holding it leaves the counts usable
        self.shared.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Stops the ticker thread, if any.
    fn stop_ticker(&mut self) {
        self.state().finished = true;
        self.shared.wake.notify_all();
        if let Some(t) = self.ticker.take() {
            let _ = t.join();
        }
    }
}

/// The ticker: wakes when the next line is due and emits it unless a block
/// did in the meantime.
fn tick(shared: Arc<Shared>) {
    let mut st = shared.state.lock().unwrap_or_else(|e| e.into_inner());
    while !st.finished {
        let due = st.interval.saturating_sub(st.last.elapsed());
        st = match shared.wake.wait_timeout(st, due) {
            Ok((g, _)) => g,
            Err(e) => e.into_inner().0,
        };
        if !st.finished {
            st.emit_if_due();
        }
    }
}

impl Drop for Lines {
    fn drop(&mut self) {
        self.stop_ticker();
    }
}

impl Progress for Lines {
    fn start(&mut self, networks: u64) {
        let ticks = {
            let mut st = self.state();
            st.t0 = Instant::now();
            st.last = st.t0;
            st.total = networks;
            st.finished = false;
            if networks > 0 {
                emit(&format!(
                    "[0:00:00] {networks} networks to compute; a progress line every {} s",
                    st.interval.as_secs_f64()
                ));
            }
            // With interval 0 (a line per block) there is nothing to tick.
            networks > 0 && !st.interval.is_zero()
        };
        if ticks && self.ticker.is_none() {
            let shared = Arc::clone(&self.shared);
            self.ticker = std::thread::Builder::new()
                .name("rwg-progress".into())
                .spawn(move || tick(shared))
                .ok();
        }
    }

    fn cell(&mut self, label: &str) {
        self.state().label = label.to_string();
    }

    fn block(&mut self, label: &str, networks: u64, env_steps: u64) {
        let mut st = self.state();
        st.label = label.to_string();
        st.done += networks;
        st.steps += env_steps;
        st.emit_if_due();
    }

    fn finish(&mut self, ok: bool) {
        self.stop_ticker();
        let mut st = self.state();
        if st.total > 0 {
            let what = if ok { "done" } else { "stopped" };
            st.label = what.into();
            emit(&st.line());
        }
    }
}

/// No progress at all (`--quiet`).
pub struct Silent;

impl Progress for Silent {
    fn start(&mut self, _networks: u64) {}
    fn cell(&mut self, _label: &str) {}
    fn block(&mut self, _label: &str, _networks: u64, _env_steps: u64) {}
    fn finish(&mut self, _ok: bool) {}
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_and_lines() {
        assert_eq!(hms(0.0), "0:00:00");
        assert_eq!(hms(3725.4), "1:02:05");
        assert_eq!(hms(f64::INFINITY), "0:00:00");
        let compiling = Arc::new(Compiling::default());
        let mut l = Lines::new(Arc::clone(&compiling));
        l.start(100);
        l.cell("cell 1/2 (0 done): A");
        assert!(
            l.state()
                .line()
                .ends_with("0/100 networks (0.0%), 0 networks/s, 0.000e0 env steps/s, ETA unknown"),
            "{}",
            l.state().line()
        );
        l.state().done = 25;
        assert!(l
            .state()
            .line()
            .contains("cell 1/2 (0 done): A: 25/100 networks (25.0%)"));
        assert!(!l.state().line().contains("ETA unknown"));

        // a compile going on: said, with its time so far, and no rate
        compiling.warming_up();
        let line = l.state().line();
        assert!(
            line.ends_with(
                "25/100 networks (25.0%), compiling for 0:00:00 (JAX workers starting and \
                 compiling the cell)"
            ),
            "{line}"
        );
        std::thread::sleep(Duration::from_millis(30));
        compiling.warmed_up(Duration::ZERO);
        assert!(compiling.since().is_none());
        // the rates count the time outside it
        let elapsed = Duration::from_millis(1000);
        let active = compiling.active(elapsed);
        assert!(active <= elapsed - Duration::from_millis(30), "{active:?}");
        assert!(l.state().line().contains("networks/s"));
    }
}

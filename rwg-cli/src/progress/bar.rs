//! The progress bar of `rwg run` on a terminal: networks done, networks/s
//! and env steps/s, the time left; "compiling" with its time so far while
//! a JAX cell's workers compile.

use super::{hms, Compiling};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use rwg_study::runner::Progress;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The bar on stderr.
pub struct Bar {
    bar: Option<ProgressBar>,
    t0: Option<Instant>,
    steps: u64,
    compiling: Arc<Compiling>,
}

impl Bar {
    /// A bar that shows the warm-ups `compiling` is told of.
    pub fn new(compiling: Arc<Compiling>) -> Self {
        Bar {
            bar: None,
            t0: None,
            steps: 0,
            compiling,
        }
    }
}

/// `compiling 0:00:12` during a warm-up; else `ETA h:mm:ss` from the rate
/// outside warm-ups (`ETA unknown` before the first networks).
fn time_left(compiling: &Compiling, t0: Instant, state: &ProgressState) -> String {
    if let Some(since) = compiling.since() {
        return format!("compiling {}", hms(since.elapsed().as_secs_f64()));
    }
    let done = state.pos();
    let active = compiling.active(t0.elapsed());
    match state.len() {
        Some(len) if done > 0 && !active.is_zero() => {
            let rate = done as f64 / active.as_secs_f64();
            format!("ETA {}", hms(len.saturating_sub(done) as f64 / rate))
        }
        _ => "ETA unknown".into(),
    }
}

impl Progress for Bar {
    fn start(&mut self, networks: u64) {
        let bar = ProgressBar::with_draw_target(Some(networks), ProgressDrawTarget::stderr());
        let t0 = Instant::now();
        let compiling = Arc::clone(&self.compiling);
        bar.set_style(
            ProgressStyle::with_template(
                "{msg}\n[{elapsed_precise}] {wide_bar} {pos}/{len} networks ({rwg_left})",
            )
            .expect("valid template")
            .with_key(
                "rwg_left",
                move |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = w.write_str(&time_left(&compiling, t0, state));
                },
            ),
        );
        // redrawn while no block ends (a compile's time goes on)
        bar.enable_steady_tick(Duration::from_secs(1));
        self.bar = Some(bar);
        self.t0 = Some(t0);
    }

    fn cell(&mut self, label: &str) {
        if let Some(bar) = &self.bar {
            bar.set_message(label.to_string());
        }
    }

    fn block(&mut self, label: &str, networks: u64, env_steps: u64) {
        let (Some(bar), Some(t0)) = (&self.bar, self.t0) else {
            return;
        };
        self.steps += env_steps;
        bar.inc(networks);
        let secs = self.compiling.active(t0.elapsed()).as_secs_f64().max(1e-9);
        let nets = bar.position() as f64 / secs;
        let rate = self.steps as f64 / secs;
        bar.set_message(format!(
            "{label}  {nets:.0} networks/s, {rate:.3e} env steps/s"
        ));
    }

    fn finish(&mut self, ok: bool) {
        if let Some(bar) = &self.bar {
            if ok {
                bar.finish_and_clear();
            } else {
                bar.abandon();
            }
        }
    }
}

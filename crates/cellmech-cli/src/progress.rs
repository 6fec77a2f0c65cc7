//! A progress bar per analysis step, fed by solver events.

use cellmech_fem::solve::{FailureReason, IncrementReport, Observer, Problem};
use indicatif::{ProgressBar, ProgressStyle};

/// Shows one bar per step with the step time, increments and cutbacks.
pub struct StepProgress {
    bar: Option<ProgressBar>,
    steps: usize,
    cutbacks: usize,
}

impl StepProgress {
    /// A progress display for `steps` steps.
    pub fn new(steps: usize) -> Self {
        StepProgress {
            bar: None,
            steps,
            cutbacks: 0,
        }
    }

    /// Ends the current bar.
    pub fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish();
        }
    }
}

impl Observer for StepProgress {
    fn on_step_start(&mut self, index: usize, name: &str) {
        self.finish();
        let bar = ProgressBar::new(1000);
        bar.set_style(
            ProgressStyle::with_template("{prefix:>24} [{bar:30}] {percent:>3}% {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_prefix(format!("step {}/{} {name}", index + 1, self.steps));
        self.cutbacks = 0;
        self.bar = Some(bar);
    }

    fn on_increment(&mut self, _problem: &Problem, report: &IncrementReport<'_>) {
        if let Some(bar) = &self.bar {
            bar.set_position((report.step_time * 1000.0).round() as u64);
            bar.set_message(format!(
                "increment {} ({} iterations, {} cutbacks)",
                report.increment, report.iterations, self.cutbacks
            ));
        }
    }

    fn on_cutback(&mut self, _t: f64, _dt: f64, _reason: &FailureReason) {
        self.cutbacks += 1;
    }
}

//! A progress line for work that can take longer than a few seconds:
//! what is being done, how far, and the robot time spent. On a terminal it
//! is an indicatif bar; otherwise (a log file, a pipe, CI) a plain line
//! every few seconds, so a long run never looks hung.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// How often the plain line is printed when stderr is not a terminal.
const PLAIN_EVERY: Duration = Duration::from_secs(5);

/// One step's progress.
pub struct Progress {
    bar: ProgressBar,
    /// What is being done ("self-exploration").
    what: &'static str,
    /// What is counted ("DoF measurements").
    unit: &'static str,
    done: u64,
    total: u64,
    /// Robot time spent, and the budget it is spent from, s.
    robot: Option<(f64, Option<f64>)>,
    /// When the last plain line was printed; `None` on a terminal.
    plain: Option<Instant>,
}

impl Progress {
    /// Progress of `what`, counted in `unit`.
    pub fn new(what: &'static str, unit: &'static str) -> Progress {
        let style = ProgressStyle::with_template("{prefix:24} [{bar:30}] {pos}/{len} {msg}")
            .expect("a valid template")
            .progress_chars("=> ");
        let bar = ProgressBar::new(0).with_style(style).with_prefix(what);
        let plain = (!std::io::stderr().is_terminal()).then(Instant::now);
        Progress { bar, what, unit, done: 0, total: 0, robot: None, plain }
    }

    /// `done` of `total` units.
    pub fn set(&mut self, done: u64, total: u64) {
        (self.done, self.total) = (done, total);
        self.show();
    }

    /// `spent_s` of robot time so far, of `budget_s` if the step has one.
    pub fn robot_time(&mut self, spent_s: f64, budget_s: Option<f64>) {
        self.robot = Some((spent_s, budget_s));
        self.show();
    }

    /// Removes the bar.
    pub fn finish(self) {
        self.bar.finish_and_clear();
    }

    /// The counted units and the robot time, as the line shows them.
    fn message(&self) -> String {
        let robot = match self.robot {
            Some((spent, Some(budget))) => format!(", {spent:.0} s of robot time (budget {budget:.0} s)"),
            Some((spent, None)) => format!(", {spent:.0} s of robot time"),
            None => String::new(),
        };
        format!("{}{robot}", self.unit)
    }

    fn show(&mut self) {
        self.bar.set_length(self.total);
        self.bar.set_position(self.done);
        self.bar.set_message(self.message());
        if let Some(last) = &mut self.plain {
            if last.elapsed() >= PLAIN_EVERY {
                *last = Instant::now();
                eprintln!("{}: {}/{} {}", self.what, self.done, self.total, self.message());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_says_what_is_counted_and_the_robot_time_of_the_budget() {
        let mut p = Progress::new("self-exploration", "DoF measurements");
        p.set(3, 28);
        assert_eq!(p.message(), "DoF measurements");
        p.robot_time(35.4, Some(1800.0));
        assert_eq!(p.message(), "DoF measurements, 35 s of robot time (budget 1800 s)");
        p.robot_time(2.0, None);
        assert_eq!(p.message(), "DoF measurements, 2 s of robot time");
        p.finish();
    }
}

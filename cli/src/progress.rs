//! A progress bar on stderr for long runs.

use std::io::{IsTerminal, Write};
use std::time::Instant;

/// A progress bar on stderr for runs longer than a second, when stderr is a terminal
/// or `ITGFX_PROGRESS=1`.
pub struct Progress {
    start: Instant,
    last: f64,
    enabled: bool,
    unit: &'static str,
}

impl Progress {
    /// A new progress reporter.
    #[must_use]
    pub fn new() -> Self {
        let enabled = std::io::stderr().is_terminal() || std::env::var_os("ITGFX_PROGRESS").is_some_and(|v| v == "1");
        Self { start: Instant::now(), last: 0.0, enabled, unit: "Mlines/s" }
    }

    /// A reporter whose rate (millions of units done per second) is named `unit`.
    #[must_use]
    pub fn with_unit(unit: &'static str) -> Self {
        Self { unit, ..Self::new() }
    }

    /// Reports `done` of `total` lines.
    pub fn update(&mut self, done: u64, total: u64) {
        let el = self.start.elapsed().as_secs_f64();
        if !self.enabled || el < 1.0 || (el - self.last < 0.2 && done < total) {
            return;
        }
        self.last = el;
        let frac = done as f64 / total.max(1) as f64;
        let width = 30;
        let fill = (frac * width as f64) as usize;
        let rate = done as f64 / el / 1e6;
        let eta = if done > 0 { el * (total - done) as f64 / done as f64 } else { 0.0 };
        let mut e = std::io::stderr().lock();
        let _ = write!(
            e,
            "\r[{}{}] {:5.1}%  {:.2} {}  eta {:.0}s ",
            "#".repeat(fill),
            " ".repeat(width - fill),
            frac * 100.0,
            rate,
            self.unit,
            eta
        );
        if done >= total {
            let _ = writeln!(e);
        }
    }
}

impl Default for Progress {
    fn default() -> Self {
        Self::new()
    }
}

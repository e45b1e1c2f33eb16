//! Progress of long work on stderr, and the interrupt flag that stops it between steps.
//!
//! One type, [`Progress`], for every long command: the reference's tiles, a GPU frame's passes (when
//! the frame takes more than one submission), `bench`'s and `quality`'s frames, `bounds`' rows. How it
//! shows is decided once per [`Progress`] by `SHUTTER_PROGRESS`:
//!
//! * unset or `auto`: a live bar with the ETA when stderr is a terminal; otherwise sparse lines —
//!   nothing for the first [`LINES_FIRST_AFTER`], then one line every [`LINES_EVERY`] — so the logs of
//!   short runs (CI, tests) carry none and a long run redirected to a file still says where it is;
//! * `bar`, `lines` (one line per [`LINES_EVERY`] from the start), `off`.
//!
//! Interrupting (Ctrl-C in the CLI) is cooperative: the handler calls [`request_interrupt`]; work checks
//! [`check_interrupt`] between steps (tiles, submissions, frames) and returns [`Error::Interrupted`], so
//! the device is idle and every RAII wrapper frees its handle on the way out — no validation message,
//! no half-written file.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::error::{Error, Result};

/// Without a terminal (`auto`): the first line after this long.
pub const LINES_FIRST_AFTER: Duration = Duration::from_secs(10);
/// Without a terminal: at most one line this often.
pub const LINES_EVERY: Duration = Duration::from_secs(30);

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Asks running work to stop at its next step (what a Ctrl-C handler calls).
pub fn request_interrupt() {
    INTERRUPTED.store(true, Ordering::SeqCst);
}

/// Whether [`request_interrupt`] was called.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// [`Error::Interrupted`] once an interrupt was requested.
pub fn check_interrupt() -> Result<()> {
    if interrupted() {
        Err(Error::Interrupted)
    } else {
        Ok(())
    }
}

/// How a [`Progress`] shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressMode {
    /// A live bar with the ETA (a terminal).
    Bar,
    /// A line every [`LINES_EVERY`], the first after `first_after`.
    Lines { first_after: Duration },
    /// Nothing.
    Off,
}

impl ProgressMode {
    /// The mode `SHUTTER_PROGRESS` asks for, `auto` deciding by whether stderr is a terminal.
    pub fn from_env() -> Self {
        use std::io::IsTerminal;
        match std::env::var("SHUTTER_PROGRESS").as_deref() {
            Ok("off") | Ok("0") => ProgressMode::Off,
            Ok("bar") => ProgressMode::Bar,
            Ok("lines") => ProgressMode::Lines { first_after: Duration::ZERO },
            _ if std::io::stderr().is_terminal() => ProgressMode::Bar,
            _ => ProgressMode::Lines { first_after: LINES_FIRST_AFTER },
        }
    }
}

/// Progress through `total` steps of one piece of work, shown on stderr as [`ProgressMode`] says;
/// cleared when finished or dropped. Shareable across threads (`inc` from rayon workers).
pub struct Progress {
    label: String,
    unit: &'static str,
    total: u64,
    mode: ProgressMode,
    bar: Option<ProgressBar>,
    done: AtomicU64,
    start: Instant,
    /// When the last line was printed, and the message shown with the count.
    state: Mutex<(Option<Instant>, String)>,
}

impl Progress {
    /// `total` steps of `unit` (e.g. "tiles", "frames") under `label`, shown as the environment says.
    pub fn new(label: impl Into<String>, total: u64, unit: &'static str) -> Self {
        Self::with_mode(label, total, unit, ProgressMode::from_env())
    }

    /// [`Progress::new`] in a given mode.
    pub fn with_mode(label: impl Into<String>, total: u64, unit: &'static str, mode: ProgressMode) -> Self {
        let label = label.into();
        let bar = (mode == ProgressMode::Bar).then(|| {
            let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
            let template =
                format!("{label} [{{bar:30}}] {{pos}}/{{len}} {unit}, {{elapsed}}, eta {{eta}} {{msg}}");
            if let Ok(style) = ProgressStyle::with_template(&template) {
                bar.set_style(style);
            }
            bar
        });
        Progress {
            label,
            unit,
            total,
            mode,
            bar,
            done: AtomicU64::new(0),
            start: Instant::now(),
            state: Mutex::new((None, String::new())),
        }
    }

    /// Shows nothing.
    pub fn hidden() -> Self {
        Self::with_mode("", 0, "", ProgressMode::Off)
    }

    /// A short note shown with the count (the configuration being timed, say).
    pub fn set_message(&self, message: impl Into<String>) {
        let message = message.into();
        if let Some(bar) = &self.bar {
            bar.set_message(message.clone());
        }
        if let Ok(mut s) = self.state.lock() {
            s.1 = message;
        }
    }

    /// `n` more steps done.
    pub fn inc(&self, n: u64) {
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        match self.mode {
            ProgressMode::Bar => {
                if let Some(bar) = &self.bar {
                    bar.inc(n);
                }
            }
            ProgressMode::Lines { first_after } => {
                let now = Instant::now();
                let elapsed = now - self.start;
                let Ok(mut s) = self.state.lock() else { return };
                let due = match s.0 {
                    None => elapsed >= first_after,
                    Some(last) => now - last >= LINES_EVERY,
                };
                if due && done < self.total {
                    s.0 = Some(now);
                    // Not `eprintln!`, which panics when stderr is closed.
                    use std::io::Write;
                    let _ = writeln!(std::io::stderr().lock(), "{}", self.line(done, elapsed, &s.1));
                }
            }
            ProgressMode::Off => {}
        }
    }

    /// The sparse mode's line: count, percentage, elapsed time and ETA.
    fn line(&self, done: u64, elapsed: Duration, message: &str) -> String {
        let secs = elapsed.as_secs_f64();
        let eta =
            if done > 0 { secs * (self.total.saturating_sub(done)) as f64 / done as f64 } else { f64::NAN };
        let message = if message.is_empty() { String::new() } else { format!(" ({message})") };
        format!(
            "{}{message}: {done}/{} {} ({:.0} %), {} elapsed, eta {}",
            self.label,
            self.total,
            self.unit,
            100.0 * done as f64 / self.total.max(1) as f64,
            format_secs(secs),
            if eta.is_finite() { format_secs(eta) } else { "?".into() }
        )
    }

    /// Clears the bar (also on drop).
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}

/// `75 s`, `12 min 5 s`, `2 h 3 min`.
fn format_secs(secs: f64) -> String {
    let s = secs.round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, s / 60 % 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_say_count_share_and_eta() {
        let p = Progress::with_mode("render", 200, "passes", ProgressMode::Off);
        let line = p.line(50, Duration::from_secs(30), "pinhole");
        assert_eq!(line, "render (pinhole): 50/200 passes (25 %), 30 s elapsed, eta 1 min 30 s");
        assert_eq!(p.line(0, Duration::ZERO, ""), "render: 0/200 passes (0 %), 0 s elapsed, eta ?");
        assert_eq!(format_secs(7384.0), "2 h 3 min");
    }
}

//! Render progress on stderr: an indicatif bar when stderr is a terminal; otherwise (a log
//! file, a farm's output, a program reading it) one line every [`LOG_INTERVAL_SECONDS`] at
//! most, or every `--progress-interval` seconds ([`interval`]),
//! `rendering: 42% after 12.0 s, eta 16.5 s`, with the ETA extrapolated linearly from the
//! pixels done so far.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Seconds between two progress lines when stderr is not a terminal.
pub const LOG_INTERVAL_SECONDS: f64 = 5.0;

/// The longest `--progress-interval`: a day.
pub const MAX_INTERVAL_SECONDS: f64 = 86_400.0;

/// `--progress-interval SECONDS` checked: a number from 0 (a line for every finished tile) to
/// [`MAX_INTERVAL_SECONDS`].
pub fn interval(seconds: f64) -> anyhow::Result<f64> {
    if !(0.0..=MAX_INTERVAL_SECONDS).contains(&seconds) {
        anyhow::bail!("--progress-interval {seconds}: must be a number of seconds from 0 to {MAX_INTERVAL_SECONDS}");
    }
    Ok(seconds)
}

/// Progress over a known number of pixels.
pub enum Progress {
    Bar(ProgressBar),
    Log { total: u64, done: AtomicU64, start: Instant, last: Mutex<f64>, every: f64 },
}

impl Progress {
    /// A bar on a terminal, otherwise log lines at least `every` seconds apart.
    pub fn new(total_pixels: u64, every: f64) -> Progress {
        if std::io::stderr().is_terminal() {
            let style = ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed_precise} (eta {eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar());
            let bar = ProgressBar::with_draw_target(Some(total_pixels), ProgressDrawTarget::stderr()).with_style(style);
            Progress::Bar(bar)
        } else {
            let (done, start, last) = (AtomicU64::new(0), Instant::now(), Mutex::new(0.0));
            Progress::Log { total: total_pixels, done, start, last, every }
        }
    }

    /// `pixels` more are done.
    pub fn inc(&self, pixels: u64) {
        match self {
            Progress::Bar(bar) => bar.inc(pixels),
            Progress::Log { total, done, start, last, every } => {
                let done = done.fetch_add(pixels, Ordering::Relaxed) + pixels;
                let elapsed = start.elapsed().as_secs_f64();
                let Ok(mut last) = last.try_lock() else { return };
                if elapsed - *last >= *every && done < *total {
                    *last = elapsed;
                    eprintln!("{}", log_line(done, *total, elapsed));
                }
            }
        }
    }

    /// Clears the bar (a log needs nothing).
    pub fn finish(&self) {
        if let Progress::Bar(bar) = self {
            bar.finish_and_clear();
        }
    }
}

/// `rendering: 42% after 12.0 s, eta 16.5 s`.
pub fn log_line(done: u64, total: u64, elapsed_seconds: f64) -> String {
    let fraction = done as f64 / total.max(1) as f64;
    let eta = if done > 0 { elapsed_seconds * (1.0 - fraction) / fraction } else { f64::NAN };
    format!("rendering: {:.0}% after {elapsed_seconds:.1} s, eta {eta:.1} s", 100.0 * fraction)
}

#[cfg(test)]
mod tests {
    #[test]
    fn eta_is_linear() {
        assert_eq!(super::log_line(25, 100, 10.0), "rendering: 25% after 10.0 s, eta 30.0 s");
    }
}

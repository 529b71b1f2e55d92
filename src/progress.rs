//! Progress of a render, as the person or the log watching it wants it: a
//! bar on a terminal, one plain line every few seconds elsewhere (logs,
//! CI, batch jobs), or nothing. Both say the samples per pixel done, the
//! pass, the speed and the time left.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// How a render reports its progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressMode {
    Off,
    /// A bar redrawn in place on stderr (for terminals).
    Bar,
    /// A line on stderr at most every `every` (for logs).
    Plain {
        every: Duration,
    },
}

enum Report {
    Off,
    Bar(ProgressBar),
    Plain {
        every: Duration,
        last: Mutex<Instant>,
    },
}

/// The progress of one render: units report their samples with
/// [`Progress::add`] from any thread.
pub struct Progress {
    report: Report,
    pixels: u64,
    spp_total: u32,
    passes: usize,
    pass: AtomicUsize,
    done: AtomicU64,
    start: Instant,
}

impl Progress {
    /// For an image of `pixels` pixels at `spp_total` samples each, in
    /// `passes` passes.
    pub fn new(mode: ProgressMode, pixels: u64, spp_total: u32, passes: usize) -> Progress {
        let total = pixels * spp_total as u64;
        let start = Instant::now();
        let report = match mode {
            ProgressMode::Off => Report::Off,
            ProgressMode::Bar => {
                let b = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
                b.set_style(
                    ProgressStyle::with_template(
                        "{spinner} [{elapsed_precise}] [{wide_bar}] {percent:>3}% {msg}, ETA {eta}",
                    )
                    .expect("valid progress template"),
                );
                Report::Bar(b)
            }
            ProgressMode::Plain { every } => Report::Plain {
                every,
                last: Mutex::new(start),
            },
        };
        Progress {
            report,
            pixels: pixels.max(1),
            spp_total,
            passes,
            pass: AtomicUsize::new(0),
            done: AtomicU64::new(0),
            start,
        }
    }

    /// Pass `index` (from 0) has begun.
    pub fn start_pass(&self, index: usize) {
        self.pass.store(index, Ordering::Relaxed);
        if let Report::Bar(b) = &self.report {
            b.set_message(self.status(self.done.load(Ordering::Relaxed)));
        }
    }

    /// A unit finished `samples` camera samples.
    pub fn add(&self, samples: u64) {
        let done = self.done.fetch_add(samples, Ordering::Relaxed) + samples;
        match &self.report {
            Report::Off => {}
            Report::Bar(b) => {
                b.set_message(self.status(done));
                b.inc(samples);
            }
            Report::Plain { every, last } => {
                let now = Instant::now();
                let mut last = last.lock().unwrap_or_else(|e| e.into_inner());
                if now.duration_since(*last) >= *every {
                    *last = now;
                    eprintln!("render: {}", self.line(done));
                }
            }
        }
    }

    /// Clears the bar (the caller prints its own summary).
    pub fn finish(&self) {
        if let Report::Bar(b) = &self.report {
            b.finish_and_clear();
        }
    }

    /// "24/64 spp, pass 6/9, 1.23 M samples/s"
    fn status(&self, done: u64) -> String {
        let secs = self.start.elapsed().as_secs_f64().max(1e-9);
        format!(
            "{}/{} spp, pass {}/{}, {:.2} M samples/s",
            done / self.pixels,
            self.spp_total,
            self.pass.load(Ordering::Relaxed) + 1,
            self.passes,
            done as f64 / secs / 1e6
        )
    }

    /// The plain line: percentage, status, elapsed time and time left.
    fn line(&self, done: u64) -> String {
        let total = self.pixels * self.spp_total as u64;
        let fraction = done as f64 / total.max(1) as f64;
        let elapsed = self.start.elapsed().as_secs_f64();
        let left = if fraction > 0.0 {
            elapsed * (1.0 - fraction) / fraction
        } else {
            f64::INFINITY
        };
        format!(
            "{:3.0}% {}, {} elapsed, ETA {}",
            100.0 * fraction,
            self.status(done),
            clock(elapsed),
            clock(left)
        )
    }
}

/// Seconds as h:mm:ss (or "?" when unknown).
fn clock(secs: f64) -> String {
    if !secs.is_finite() || secs > 1e7 {
        return "?".into();
    }
    let s = secs.round() as u64;
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_lines_say_spp_pass_speed_and_time_left() {
        let p = Progress::new(ProgressMode::Off, 100, 64, 9);
        p.start_pass(5);
        p.add(100 * 24);
        let line = p.line(100 * 24);
        assert!(line.starts_with(" 38% 24/64 spp, pass 6/9, "), "{line}");
        assert!(
            line.contains(" M samples/s, 0:00:00 elapsed, ETA "),
            "{line}"
        );
        assert_eq!(clock(3725.0), "1:02:05");
        // The bar's template is valid (it is parsed when the bar is made).
        let bar = Progress::new(ProgressMode::Bar, 10, 4, 3);
        bar.start_pass(1);
        bar.add(20);
        bar.finish();
        assert_eq!(clock(f64::INFINITY), "?");
    }
}

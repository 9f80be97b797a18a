//! What a render says on stderr: a progress bar on a terminal, rpict's
//! `-t N` reports, and a one-line summary at the end.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

use crate::render::RayCounts;

/// How often the progress thread looks at the counter.
const TICK: Duration = Duration::from_millis(100);

/// Progress of a render as units done out of a total (rows of a
/// sequential render, pixels of a parallel one), shown by a thread of its
/// own: an animated bar when stderr is a terminal and no `-t` is given,
/// and a line `progress: P% done after S s` every `-t` seconds.
pub(super) struct Progress {
    done: Arc<AtomicU64>,
    stop: Option<mpsc::Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl Progress {
    /// Starts showing progress of `total` `unit`s; `report` is `-t`'s
    /// seconds (0 or `None`: no reports); `bar` asks for a bar where one
    /// may be drawn.
    pub(super) fn start(total: u64, unit: &str, report: Option<u64>, bar: bool) -> Self {
        let done = Arc::new(AtomicU64::new(0));
        let every = report.filter(|&s| s > 0).map(Duration::from_secs);
        let bar = if bar && every.is_none() && std::io::stderr().is_terminal() {
            let b = ProgressBar::new(total);
            let template = format!(
                "{{spinner}} rendering [{{bar:40}}] {{pos}}/{{len}} {unit} {{elapsed_precise}} (eta {{eta}})"
            );
            if let Ok(style) = ProgressStyle::with_template(&template) {
                b.set_style(style.progress_chars("=> "));
            }
            Some(b)
        } else {
            None
        };
        if bar.is_none() && every.is_none() {
            return Self {
                done,
                stop: None,
                thread: None,
            };
        }
        let (tx, rx) = mpsc::channel::<()>();
        let counter = done.clone();
        let thread = std::thread::Builder::new()
            .name("progress".into())
            .spawn(move || {
                let t0 = Instant::now();
                let mut next = every.map(|e| t0 + e);
                loop {
                    let finished =
                        !matches!(rx.recv_timeout(TICK), Err(mpsc::RecvTimeoutError::Timeout));
                    let n = counter.load(Ordering::Relaxed).min(total);
                    if let Some(b) = &bar {
                        b.set_position(n);
                    }
                    if finished {
                        break;
                    }
                    if let (Some(at), Some(e)) = (next, every) {
                        let now = Instant::now();
                        if now >= at {
                            eprintln!("{}", report_line(n, total, now - t0));
                            next = Some(now + e);
                        }
                    }
                }
                if let Some(b) = bar {
                    b.finish_and_clear();
                }
            })
            .ok();
        Self {
            done,
            stop: Some(tx),
            thread,
        }
    }

    /// The counter the render adds to.
    pub(super) fn counter(&self) -> Arc<AtomicU64> {
        self.done.clone()
    }

    /// Sets the units done (for callers that know the total so far).
    pub(super) fn set(&self, n: u64) {
        self.done.store(n, Ordering::Relaxed);
    }

    /// Stops the display and clears the bar.
    pub(super) fn finish(mut self) {
        self.stop_thread();
    }

    fn stop_thread(&mut self) {
        drop(self.stop.take());
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.stop_thread();
    }
}

/// rpict's `-t` report, shortened: `progress: 42.19% done after 3.0 s`.
pub(super) fn report_line(done: u64, total: u64, elapsed: Duration) -> String {
    let pct = if total == 0 {
        100.0
    } else {
        100.0 * done as f64 / total as f64
    };
    format!(
        "progress: {pct:.2}% done after {:.1} s",
        elapsed.as_secs_f64()
    )
}

/// Rays of a render: primary, shadow (tested rays and segments through
/// transparent surfaces) and the others (reflection, refraction, pass
/// through, ambient).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct Rays {
    pub primary: u64,
    pub shadow: u64,
    pub other: u64,
}

impl Rays {
    pub(super) fn total(&self) -> u64 {
        self.primary + self.shadow + self.other
    }
}

impl From<&RayCounts> for Rays {
    fn from(r: &RayCounts) -> Self {
        Rays {
            primary: r.primary,
            shadow: r.shadow.tested + r.shadow.transparent_segments,
            other: r.reflection + r.refraction + r.pass_through + r.ambient,
        }
    }
}

/// The line printed after every render, e.g.
/// `rendered 48x48 in 0.52 s (render 0.40 s): 12345 rays (2304 primary,
/// 9000 shadow, 1041 other), 0.03 Mrays/s; effects: area shadows,
/// reflection`. Mrays/s counts the render's seconds.
pub(super) fn summary_line(
    width: usize,
    height: usize,
    wall_s: f64,
    render_s: f64,
    rays: Rays,
    effects: &[&str],
) -> String {
    let mrays = if render_s > 0.0 {
        rays.total() as f64 / render_s / 1e6
    } else {
        0.0
    };
    let effects = if effects.is_empty() {
        "none".to_string()
    } else {
        effects.join(", ")
    };
    format!(
        "rendered {width}x{height} in {wall_s:.3} s (render {render_s:.3} s): {} rays ({} primary, {} shadow, {} other), {mrays:.3} Mrays/s; effects: {effects}",
        rays.total(),
        rays.primary,
        rays.shadow,
        rays.other
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_line_adds_up() {
        let r = Rays {
            primary: 100,
            shadow: 250,
            other: 50,
        };
        let s = summary_line(10, 10, 2.0, 0.5, r, &["reflection", "area shadows"]);
        assert_eq!(
            s,
            "rendered 10x10 in 2.000 s (render 0.500 s): 400 rays (100 primary, 250 shadow, 50 other), 0.001 Mrays/s; effects: reflection, area shadows"
        );
        let s = summary_line(1, 1, 0.0, 0.0, Rays::default(), &[]);
        assert!(s.ends_with("0.000 Mrays/s; effects: none"), "{s}");
    }

    #[test]
    fn report_line_says_percent_and_time() {
        assert_eq!(
            report_line(1, 3, Duration::from_millis(2500)),
            "progress: 33.33% done after 2.5 s"
        );
        assert_eq!(
            report_line(0, 0, Duration::ZERO),
            "progress: 100.00% done after 0.0 s"
        );
    }

    #[test]
    fn progress_without_display_just_counts() {
        let p = Progress::start(10, "rows", None, false);
        p.set(4);
        p.counter().fetch_add(3, Ordering::Relaxed);
        assert_eq!(p.counter().load(Ordering::Relaxed), 7);
        p.finish();
    }
}

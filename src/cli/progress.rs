//! Progress display: a live line on a terminal, plain periodic lines otherwise.

use pathmix::render::Progress;
use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

pub struct ProgressDisplay {
    mode: Mode,
    last_line: Option<Instant>,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Mode {
    Quiet,
    Live,
    Periodic,
}

/// How often a non-terminal stderr gets a line.
const PERIODIC_INTERVAL: Duration = Duration::from_secs(5);

impl ProgressDisplay {
    pub fn new(quiet: bool) -> ProgressDisplay {
        let mode = if quiet {
            Mode::Quiet
        } else if std::io::stderr().is_terminal() {
            Mode::Live
        } else {
            Mode::Periodic
        };
        ProgressDisplay {
            mode,
            last_line: None,
        }
    }

    pub fn update(&mut self, progress: &Progress) {
        let mut line = if progress.max_samples == u32::MAX {
            format!("{} spp", progress.samples)
        } else {
            format!("{}/{} spp", progress.samples, progress.max_samples)
        };
        line += &format!(
            "  {:.1} s  {:.2} M paths/s",
            progress.elapsed.as_secs_f64(),
            progress.paths_per_second / 1e6
        );
        if let Some(error) = progress.relative_error {
            line += &format!("  error {error:.4}");
        }
        if let Some(eta) = progress.eta {
            line += &format!("  ETA {:.0} s", eta.as_secs_f64());
        }
        match self.mode {
            Mode::Quiet => {}
            Mode::Live => {
                eprint!("\r\x1b[2K{line}");
                let _ = std::io::stderr().flush();
            }
            Mode::Periodic => {
                if self
                    .last_line
                    .is_none_or(|t| t.elapsed() >= PERIODIC_INTERVAL)
                {
                    eprintln!("{line}");
                    self.last_line = Some(Instant::now());
                }
            }
        }
    }

    /// Ends the live line so later output starts on a fresh one.
    pub fn finish(&mut self) {
        if self.mode == Mode::Live {
            eprint!("\r\x1b[2K");
        }
    }
}

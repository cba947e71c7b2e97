//! Ctrl-C (SIGINT) and SIGTERM during a render: the first asks the run to stop
//! after the submission in flight, so the command can save what it has; a
//! second one exits at once, after removing the temporaries being written (every
//! file is written atomically, so nothing is left half-written under its own
//! name, and no temporary is left beside it).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

pub struct Signals {
    /// Set by the first signal: the engine's "stop requested" flag.
    pub stop: Arc<AtomicBool>,
    which: Arc<AtomicUsize>,
}

impl Signals {
    /// Installs the handlers (Unix); elsewhere the flag is never set and
    /// Ctrl-C ends the process as usual.
    pub fn install() -> Result<Signals, String> {
        let signals = Signals {
            stop: Arc::new(AtomicBool::new(false)),
            which: Arc::new(AtomicUsize::new(0)),
        };
        #[cfg(unix)]
        {
            use signal_hook::consts::{SIGINT, SIGTERM};
            let mut incoming = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])
                .map_err(|e| format!("cannot install signal handlers: {e}"))?;
            let (stop, which) = (Arc::clone(&signals.stop), Arc::clone(&signals.which));
            // A thread, not the handler, so the second signal may remove files.
            std::thread::spawn(move || {
                for signal in incoming.forever() {
                    if stop.load(Ordering::SeqCst) {
                        pathmix::output::remove_temporaries_for_exit();
                        std::process::exit(128 + signal);
                    }
                    which.store(signal as usize, Ordering::SeqCst);
                    stop.store(true, Ordering::SeqCst);
                }
            });
        }
        Ok(signals)
    }

    /// The signal that stopped the run, and the exit code it calls for:
    /// 130 for SIGINT, 143 for SIGTERM (128 + the signal number).
    pub fn received(&self) -> Option<(&'static str, u8)> {
        #[cfg(unix)]
        {
            use signal_hook::consts::{SIGINT, SIGTERM};
            match self.which.load(Ordering::SeqCst) as i32 {
                SIGINT => return Some(("SIGINT", 130)),
                SIGTERM => return Some(("SIGTERM", 143)),
                _ => {}
            }
        }
        self.stop
            .load(Ordering::SeqCst)
            .then_some(("an interrupt", 130))
    }
}

//! SIGINT and SIGTERM: the first stops the work cleanly (the render writes what is finished and
//! exits with 128 + the signal's number: 130 for SIGINT, 143 for SIGTERM); a second one exits at
//! once with that code — unless files are being written, which always finish first (they are
//! written atomically, so even `kill -9` cannot leave a truncated one).

use anyhow::{Context, Result};
use signal_hook::consts::{SIGINT, SIGTERM};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};

/// The stop flag the signals raise, and which signal came first.
#[derive(Clone)]
pub(crate) struct Interrupt {
    stop: Arc<AtomicBool>,
    signal: Arc<AtomicI32>,
    writing: Arc<AtomicBool>,
    /// Set once there is work to save: before that (while a scene and its grids load) a signal
    /// exits at once, since nothing would be lost.
    armed: Arc<AtomicBool>,
}

impl Interrupt {
    /// Starts listening for SIGINT and SIGTERM.
    pub(crate) fn install() -> Result<Self> {
        let me = Interrupt {
            stop: Arc::new(AtomicBool::new(false)),
            signal: Arc::new(AtomicI32::new(0)),
            writing: Arc::new(AtomicBool::new(false)),
            armed: Arc::new(AtomicBool::new(false)),
        };
        let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])
            .context("cannot install the SIGINT and SIGTERM handlers")?;
        let handler = me.clone();
        std::thread::spawn(move || {
            for sig in signals.forever() {
                if !handler.armed.load(Ordering::SeqCst) {
                    let name = if sig == SIGINT { "SIGINT" } else { "SIGTERM" };
                    eprintln!("error: {name} while loading; nothing written");
                    std::process::exit(128 + sig);
                }
                match handler.signal.compare_exchange(0, sig, Ordering::SeqCst, Ordering::SeqCst) {
                    Ok(_) => handler.stop.store(true, Ordering::SeqCst),
                    Err(first) => {
                        if !handler.writing.load(Ordering::SeqCst) {
                            std::process::exit(128 + first);
                        }
                    }
                }
            }
        });
        Ok(me)
    }

    /// From now on a signal stops the work cleanly instead of exiting at once.
    pub(crate) fn arm(&self) {
        self.armed.store(true, Ordering::SeqCst);
    }

    /// The flag to hand to the library (raised by the first signal).
    pub(crate) fn flag(&self) -> &AtomicBool {
        &self.stop
    }

    /// The first signal's name, if one came.
    pub(crate) fn name(&self) -> Option<&'static str> {
        match self.signal.load(Ordering::SeqCst) {
            0 => None,
            SIGINT => Some("SIGINT"),
            SIGTERM => Some("SIGTERM"),
            _ => Some("a signal"),
        }
    }

    /// The documented exit code of an interrupted command (128 + the signal), if one came.
    pub(crate) fn exit_code(&self) -> Option<ExitCode> {
        match self.signal.load(Ordering::SeqCst) {
            0 => None,
            sig => Some(ExitCode::from((128 + sig) as u8)),
        }
    }

    /// Runs `write` with a second signal deferred until it returns.
    pub(crate) fn writing<T>(&self, write: impl FnOnce() -> T) -> T {
        self.writing.store(true, Ordering::SeqCst);
        let out = write();
        self.writing.store(false, Ordering::SeqCst);
        out
    }
}

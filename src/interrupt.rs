//! Signals that end a run (SIGINT, SIGTERM, SIGHUP) turned into a flag the
//! headless loops and the window read between ticks, so a session ends
//! cleanly: the trial under way is logged as aborted (`interrupted`), the
//! log is closed and the CSV is whole (issue 31). A shell: only the command
//! line installs the handlers ([`Interrupt::install`]); the library reads
//! the flag.
//!
//! A second signal while the first is being handled ends the process at
//! once, with the same exit code (`128 + the signal's number`).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// A signal that ends a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    /// SIGINT: Ctrl-C in the terminal.
    Int,
    /// SIGTERM: a session manager, `timeout`, `kill`.
    Term,
    /// SIGHUP: the terminal closed.
    Hup,
}

impl Signal {
    const ALL: [Signal; 3] = [Signal::Int, Signal::Term, Signal::Hup];

    /// The signal's number (POSIX).
    #[must_use]
    pub fn number(self) -> u8 {
        match self {
            Signal::Hup => 1,
            Signal::Int => 2,
            Signal::Term => 15,
        }
    }

    /// Its name: `SIGINT`, `SIGTERM`, `SIGHUP`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Signal::Int => "SIGINT",
            Signal::Term => "SIGTERM",
            Signal::Hup => "SIGHUP",
        }
    }

    /// The conventional exit code of a process it ended: 128 + its number
    /// (130, 143, 129).
    #[must_use]
    pub fn exit_code(self) -> u8 {
        128 + self.number()
    }

    fn from_number(n: usize) -> Option<Signal> {
        Signal::ALL
            .into_iter()
            .find(|s| usize::from(s.number()) == n)
    }
}

/// The flag a run reads: which signal asked it to stop, if any. Clones
/// share the flag. [`Interrupt::default`] never fires unless
/// [`Interrupt::raise`]d.
#[derive(Debug, Clone, Default)]
pub struct Interrupt {
    signal: Arc<AtomicUsize>,
}

impl Interrupt {
    /// Installs handlers for SIGINT, SIGTERM and SIGHUP that set the flag;
    /// a second signal ends the process at once (exit 128 + its number).
    ///
    /// # Errors
    /// The handlers could not be installed.
    #[cfg(unix)]
    pub fn install() -> std::io::Result<Interrupt> {
        use signal_hook::flag;
        let interrupt = Interrupt::default();
        let armed = Arc::new(AtomicBool::new(false));
        for signal in Signal::ALL {
            let number = i32::from(signal.number());
            // The shutdown goes first: on the first signal `armed` is
            // still false; the second finds it set.
            flag::register_conditional_shutdown(
                number,
                i32::from(signal.exit_code()),
                Arc::clone(&armed),
            )?;
            flag::register(number, Arc::clone(&armed))?;
            flag::register_usize(
                number,
                Arc::clone(&interrupt.signal),
                usize::from(signal.number()),
            )?;
        }
        Ok(interrupt)
    }

    /// Elsewhere only Ctrl-C's default applies: the flag never fires.
    ///
    /// # Errors
    /// None.
    #[cfg(not(unix))]
    pub fn install() -> std::io::Result<Interrupt> {
        Ok(Interrupt::default())
    }

    /// The signal that asked the run to stop, if one did.
    #[must_use]
    pub fn signal(&self) -> Option<Signal> {
        Signal::from_number(self.signal.load(Ordering::SeqCst))
    }

    /// Asks the run to stop as `signal` would (tests; the window).
    pub fn raise(&self, signal: Signal) {
        self.signal
            .store(usize::from(signal.number()), Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_raised_signal_is_seen_by_every_clone_with_its_exit_code() {
        let a = Interrupt::default();
        let b = a.clone();
        assert_eq!(b.signal(), None);
        a.raise(Signal::Term);
        assert_eq!(b.signal(), Some(Signal::Term));
        assert_eq!(Signal::Term.exit_code(), 143);
        assert_eq!(Signal::Int.exit_code(), 130);
        assert_eq!(Signal::Hup.exit_code(), 129);
    }
}

//! The stop signals of the command line. SIGINT (Ctrl-C) and SIGTERM (a scheduler's) ask a run
//! to stop between iterations; it saves what it has, and the process then exits with 128 + the
//! signal's number (130, 143) so that `ceworld ... && next` does not go on. A second signal
//! while the first is being honoured exits at once.

use std::sync::atomic::{AtomicI32, AtomicUsize, Ordering};

/// The first stop signal received (0: none).
static RECEIVED: AtomicI32 = AtomicI32::new(0);

/// The handlers of SIGINT and SIGTERM before [`install`] (0: not installed), put back by
/// [`restore`]: a command line run inside another program (Python's `cehmm` console script,
/// or `cehmm.cli.main` called from a session) leaves its handlers as it found them.
#[cfg(unix)]
static PREVIOUS: [AtomicUsize; 2] = [AtomicUsize::new(0), AtomicUsize::new(0)];

#[cfg(unix)]
extern "C" fn on_signal(signal: libc::c_int) {
    if RECEIVED.swap(signal, Ordering::SeqCst) != 0 {
        // SAFETY: `_exit` is async-signal-safe.
        unsafe { libc::_exit(128 + signal) }
    }
}

/// Installs the handlers (once per process).
pub(crate) fn install() {
    #[cfg(unix)]
    {
        let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
        for (previous, signal) in PREVIOUS.iter().zip([libc::SIGINT, libc::SIGTERM]) {
            // SAFETY: the handler only touches an atomic and calls `_exit`, both async-signal-safe.
            let before = unsafe { libc::signal(signal, handler) };
            if before != handler {
                previous.store(before + 1, Ordering::SeqCst);
            }
        }
    }
    #[cfg(not(unix))]
    {
        let _ = ctrlc::set_handler(|| {
            if RECEIVED.swap(2, Ordering::SeqCst) != 0 {
                std::process::exit(130);
            }
        });
    }
}

/// Whether a stop signal was received.
pub(crate) fn requested() -> bool {
    RECEIVED.load(Ordering::SeqCst) != 0
}

/// For a run's [`crate::run::RunOptions::stop`]: stop once a stop signal was received.
pub(crate) fn flow() -> crate::Flow {
    if requested() { crate::Flow::Stop } else { crate::Flow::Continue }
}

/// The exit status after a stop signal: 128 + its number (130 for SIGINT, 143 for SIGTERM).
pub(crate) fn exit_code() -> Option<u8> {
    match RECEIVED.load(Ordering::SeqCst) {
        0 => None,
        signal => u8::try_from(128 + signal).ok(),
    }
}

/// Puts back the handlers [`install`] replaced and forgets any signal received: the next
/// command line run starts afresh.
pub(crate) fn restore() {
    #[cfg(unix)]
    for (previous, signal) in PREVIOUS.iter().zip([libc::SIGINT, libc::SIGTERM]) {
        let before = previous.swap(0, Ordering::SeqCst);
        if before != 0 {
            // SAFETY: a handler this process had installed before, put back as it was.
            unsafe { libc::signal(signal, before - 1) };
        }
    }
    RECEIVED.store(0, Ordering::SeqCst);
}

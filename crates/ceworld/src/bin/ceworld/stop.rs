//! The stop signals of the command line. SIGINT (Ctrl-C) and SIGTERM (a scheduler's) ask a run
//! to stop between iterations; it saves what it has, and the process then exits with 128 + the
//! signal's number (130, 143) so that `ceworld ... && next` does not go on. A second signal
//! while the first is being honoured exits at once.

use std::sync::atomic::{AtomicI32, Ordering};

/// The first stop signal received (0: none).
static RECEIVED: AtomicI32 = AtomicI32::new(0);

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
        // SAFETY: the handler only touches an atomic and calls `_exit`, both async-signal-safe.
        unsafe {
            libc::signal(libc::SIGINT, handler);
            libc::signal(libc::SIGTERM, handler);
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

/// The exit status after a stop signal: 128 + its number (130 for SIGINT, 143 for SIGTERM).
pub(crate) fn exit_code() -> Option<u8> {
    match RECEIVED.load(Ordering::SeqCst) {
        0 => None,
        signal => u8::try_from(128 + signal).ok(),
    }
}

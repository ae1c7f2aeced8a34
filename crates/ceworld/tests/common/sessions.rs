//! A controller search stopped at every third iteration (a Ctrl-C) and resumed from its
//! checkpoint until it ends, as the resume tests run it.

use ceworld::ce::controller::{ControllerOutcome, Valued, optimize_controller_with};
use ceworld::{Checkpointing, ControllerConfig, Flow, StopReason};

/// The outcome of the session that ended the search, and how many sessions it took.
pub fn in_sessions(
    valued: Valued<'_>,
    config: &ControllerConfig,
    checkpointing: &Checkpointing,
) -> (ControllerOutcome, usize) {
    for sessions in 1..20 {
        let mut seen = 0;
        let out = optimize_controller_with(valued, config, Some(checkpointing), |_| {
            seen += 1;
            if seen == 3 { Flow::Stop } else { Flow::Continue }
        })
        .unwrap();
        if out.stop != StopReason::Interrupted {
            return (out, sessions);
        }
    }
    panic!("never ends")
}

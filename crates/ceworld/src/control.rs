//! How long computations are run: on a rayon pool of a chosen size, stopped between iterations
//! when the caller's observer asks, and between steps when another thread asks ([`Interrupt`]).

use std::sync::Arc;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use crate::error::{Error, Result};

/// What the caller's observer says after each iteration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// Go on.
    Continue,
    /// Stop now and return what there is (marked as interrupted).
    Stop,
    /// Stop now as a stopping rule does (stop reason `callback`): the run ends after this
    /// iteration, its result evaluated in full; its checkpoint keeps the run, so that a resume
    /// goes on from there.
    Finish,
}

impl Flow {
    /// The stronger of two answers: a stop over a finish over going on.
    #[must_use]
    pub fn and(self, other: Flow) -> Flow {
        match (self, other) {
            (Flow::Stop, _) | (_, Flow::Stop) => Flow::Stop,
            (Flow::Finish, _) | (_, Flow::Finish) => Flow::Finish,
            _ => Flow::Continue,
        }
    }
}

/// A stop asked of a computation from another thread (the interpreter's main thread when the
/// user presses Ctrl-C). The first request stops the work at the next step (the optimisers drop
/// the iteration it cuts, keep what they had, and evaluate it for at most [`GRACE`]); the second
/// aborts everything at once ([`Error::Interrupted`]). Cloning shares the request.
#[derive(Clone, Debug)]
pub struct Interrupt(Arc<Requests>);

#[derive(Debug)]
struct Requests {
    count: AtomicU32,
    /// Nanoseconds after `since` until which a stop request does not cut the work (0: none).
    grace_until: AtomicU64,
    since: Instant,
}

/// How long an interrupted run may go on evaluating what it kept (its best policy, and the
/// score that chooses between restarts) before that too is cut.
pub const GRACE: Duration = Duration::from_millis(500);

impl Default for Interrupt {
    fn default() -> Self {
        Interrupt(Arc::new(Requests {
            count: AtomicU32::new(0),
            grace_until: AtomicU64::new(0),
            since: Instant::now(),
        }))
    }
}

impl Interrupt {
    /// Asks the work to stop (a second request aborts it).
    pub fn request(&self) {
        self.0.count.fetch_add(1, Ordering::SeqCst);
    }

    /// Whether a stop has been asked.
    pub fn stopping(&self) -> bool {
        self.0.count.load(Ordering::SeqCst) > 0
    }

    /// For an optimiser's observer: stop once a stop was asked.
    pub fn flow(&self) -> Flow {
        if self.stopping() { Flow::Stop } else { Flow::Continue }
    }

    /// Whether a second stop has been asked: nothing goes on.
    pub fn aborted(&self) -> bool {
        self.0.count.load(Ordering::SeqCst) > 1
    }

    /// [`Error::Interrupted`] where the work must stop here: aborted, or a stop asked and no
    /// grace running.
    pub fn check(&self) -> Result<()> {
        let graced = || {
            let until = self.0.grace_until.load(Ordering::SeqCst);
            until > 0 && (self.0.since.elapsed().as_nanos() as u64) < until
        };
        if self.aborted() || (self.stopping() && !graced()) { Err(Error::Interrupted) } else { Ok(()) }
    }

    /// Lets the work of the next `time` run although a stop was asked (an abort still stops it).
    pub fn grace(&self, time: Duration) {
        let until = (self.0.since.elapsed() + time).as_nanos() as u64;
        self.0.grace_until.store(until.max(1), Ordering::SeqCst);
    }
}

/// Most worker threads of one pool.
pub const MAX_THREADS: usize = 1024;

/// Refuses a thread count outside `1..=MAX_THREADS`, naming it.
pub fn check_threads(n: usize) -> Result<()> {
    if n == 0 || n > MAX_THREADS {
        return Err(Error::invalid("threads", format!("{n} (expected 1..={MAX_THREADS}, or none for one per core)")));
    }
    Ok(())
}

/// A rayon pool of `threads` workers (all cores when `None`).
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    // A world written in Python runs its code on these threads: their stacks are as deep as a
    // main thread's (Rust's default of 2 MiB overflows where a Python thread would not).
    let mut builder = rayon::ThreadPoolBuilder::new().stack_size(WORKER_STACK_BYTES);
    if let Some(n) = threads {
        check_threads(n)?;
        builder = builder.num_threads(n);
    }
    builder.build().map_err(|e| Error::invalid("threads", e.to_string()))
}

/// The stack of each worker thread: 16 MiB, twice a Linux main thread's default (reserved
/// address space, used only as deep as the code goes).
pub const WORKER_STACK_BYTES: usize = 16 << 20;

/// Runs `f`, turning a panic in it (or in a rayon task it waits for) into [`Error::Internal`].
pub fn catch_panics<T>(f: impl FnOnce() -> Result<T>) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".into());
        Err(Error::Internal(message))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    #[test]
    fn an_interrupt_cuts_once_asked_spares_a_grace_and_aborts_on_the_second_request() {
        let interrupt = Interrupt::default();
        assert!(interrupt.check().is_ok() && !interrupt.stopping());
        let shared = interrupt.clone();
        shared.request();
        assert!(interrupt.stopping() && !interrupt.aborted());
        assert!(matches!(interrupt.check(), Err(Error::Interrupted)));
        interrupt.grace(Duration::from_secs(60));
        assert!(interrupt.check().is_ok(), "a grace lets the work go on");
        interrupt.grace(Duration::ZERO);
        assert!(interrupt.check().is_err(), "a grace ends");
        interrupt.grace(Duration::from_secs(60));
        shared.request();
        assert!(interrupt.aborted());
        assert!(matches!(interrupt.check(), Err(Error::Interrupted)), "an abort cuts in a grace too");
    }

    #[test]
    fn the_stronger_flow_wins() {
        let all = [Flow::Continue, Flow::Finish, Flow::Stop];
        for (i, a) in all.iter().enumerate() {
            for (j, b) in all.iter().enumerate() {
                assert_eq!(a.and(*b), all[i.max(j)], "{a:?} and {b:?}");
            }
        }
    }

    #[test]
    fn a_panic_in_a_rayon_task_becomes_an_internal_error() {
        let pool = thread_pool(Some(2)).unwrap();
        let r: Result<u64> = catch_panics(|| {
            Ok(pool
                .install(|| (0..1000u64).into_par_iter().map(|k| if k == 777 { panic!("task {k}") } else { k }).sum()))
        });
        let e = r.unwrap_err();
        assert!(matches!(&e, Error::Internal(m) if m == "task 777"), "{e}");
        assert!(e.to_string().starts_with("internal error"));
        assert_eq!(catch_panics(|| Ok(3)).unwrap(), 3);
    }
}

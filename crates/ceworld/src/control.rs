//! How long computations are run: on a rayon pool of a chosen size, and stopped between steps
//! when the caller's observer asks.

use crate::error::{Error, Result};

/// What the caller's observer says after each iteration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// Go on.
    Continue,
    /// Stop now and return what there is (marked as interrupted).
    Stop,
}

/// Most worker threads of one pool.
pub const MAX_THREADS: usize = 1024;

pub(crate) fn check_threads(n: usize) -> Result<()> {
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

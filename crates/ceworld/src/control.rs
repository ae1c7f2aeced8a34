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
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        check_threads(n)?;
        builder = builder.num_threads(n);
    }
    builder.build().map_err(|e| Error::invalid("threads", e.to_string()))
}

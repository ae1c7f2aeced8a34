//! The cross-entropy method (model §3): episodes of world × policy, the counts of the elite, the
//! forward–backward alternative for the memory, and the optimiser that iterates them; and the
//! same method over whole deterministic controllers of a tabular world (model §8).

pub mod budget;
pub mod checkpoint;
pub mod config;
pub mod controller;
pub mod counting;
pub mod init;
pub mod iterations;
pub mod limits;
pub mod optimize;
pub mod posterior;
pub mod random_search;
pub mod record;
pub mod rerun;
pub mod resume;
pub mod runs;
pub mod stepped;
pub mod stopping;

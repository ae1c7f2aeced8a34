//! # ceworld
//!
//! Cross-entropic learning of finite-memory policies for partially observable worlds, after
//! Dambreville, "Cross-Entropic Learning of a Machine for the Decision in a Partially
//! Observable Universe". A policy is a hierarchical HMM with input (observation) and output
//! (decision); its tables are optimised by Rubinstein's cross-entropy method. The conventions
//! are those of the project's model document, `docs/model.md`, cited as `model §N`.
//!
//! ```
//! use ceworld::{CeConfig, TargetTracking, optimize, uniform_policy, Flow};
//! let world = TargetTracking::new(1).unwrap();
//! let config = CeConfig { samples: 200, max_iterations: Some(3), eval_episodes: 100, ..CeConfig::default() };
//! let result = optimize(&world, uniform_policy(&world, &[4]).unwrap(), &config, |_| Flow::Continue).unwrap();
//! assert_eq!(result.history.len(), 3);
//! ```

pub mod ce;
#[cfg(feature = "cli")]
pub mod cli;
pub mod control;
pub mod episodes;
pub mod error;
pub mod evaluate;
pub mod exact;
pub mod files;
pub mod memory;
pub mod pointbased;
pub mod policy;
pub mod progress;
pub mod qlearn;
pub mod rng;
pub mod run;
pub mod settings;
pub mod world;

pub use ce::checkpoint::CeCheckpoint;
pub use ce::config::{CeConfig, DEFAULT_LEVELS, MemoryUpdate, STRONG_PATIENCE, WEAK_PATIENCE};
pub use ce::controller::{ControllerConfig, ControllerOutcome, optimize_controller};
pub use ce::init::{Init, clock_policy, random_policy, uniform_policy};
pub use ce::optimize::{optimize, optimize_with};
pub use ce::record::{CeResult, IterationRecord};
pub use ce::resume::Checkpointing;
pub use ce::stopping::{Observed, StopReason};
pub use control::{Flow, Interrupt, catch_panics, thread_pool};
pub use episodes::{Episodes, Shape};
pub use error::{Error, Result};
pub use evaluate::{Evaluation, evaluate};
pub use policy::file::PolicyFile;
pub use policy::{Hhmm, Layout};
pub use qlearn::{
    ContinuingWorld, Greedy, KnownState, QConfig, QLearner, QTable, Ties, WindowConfig, WindowPolicy, WindowReport,
    evaluate_windows,
};
pub use world::World;
pub use world::pomdp::{PomdpParams, PomdpWorld};
pub use world::registry::AnyWorld;
pub use world::tracking::{TargetTracking, TrackingParams};

/// The engine's version, written into policy files.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

//! Where a world outside the engine went wrong ([`super::outside`]): which world, which episode
//! (or batch) of which stream, which call, as its errors name them.

use serde_json::Value;

use crate::episodes::Streams;
use crate::error::Error;
use crate::rng::Purpose;

/// How errors name a world: its `"id"` (a Gymnasium environment's) or its `"class"`.
pub(super) fn label(description: &Value) -> String {
    let text = |key: &str| description.get(key).and_then(Value::as_str).map(str::to_owned);
    text("id")
        .or_else(|| text("class"))
        .map_or_else(|| format!("world {:?}", crate::world::registry::OUTSIDE), |c| format!("world {c}"))
}

/// Where something went wrong: which world, which episode (or batch) of which stream, which
/// step (from 1; 0 is the reset).
pub(super) struct Place {
    pub(super) world: String,
    pub(super) streams: Streams,
    pub(super) episodes: (usize, usize),
    pub(super) episode: usize,
    /// Episodes per controller, where the episodes are those of controllers.
    pub(super) per_controller: Option<usize>,
    pub(super) step: usize,
}

impl Place {
    fn stream(&self) -> String {
        match self.streams.purpose {
            Purpose::Optimise | Purpose::Controllers => format!("iteration {}", self.streams.iteration),
            other => format!("{other:?}").to_lowercase(),
        }
    }

    /// Episode `k`, or episode `k mod K` of controller `k div K`.
    fn episode(&self, k: usize) -> String {
        match self.per_controller {
            Some(per) => format!("controller {}, episode {}", k / per, k % per),
            None => format!("episode {k}"),
        }
    }

    /// An error of one episode.
    pub(super) fn error(&self, message: &str) -> Error {
        Error::World(format!(
            "{}, {} ({}), {}: {message}",
            self.world,
            self.episode(self.episode),
            self.stream(),
            self.call()
        ))
    }

    /// The call that returned the value: `reset`, or `step k` (the k-th, from 1).
    fn call(&self) -> String {
        if self.step == 0 { "reset".to_string() } else { format!("step {}", self.step) }
    }

    /// An error of a call for the whole batch.
    pub(super) fn wrap(&self, error: &Error) -> Error {
        let (a, b) = self.episodes;
        let episodes = match self.per_controller {
            Some(_) if b == a + 1 => self.episode(a),
            Some(_) => format!("{} to {}", self.episode(a), self.episode(b - 1)),
            None if b == a + 1 => format!("episode {a}"),
            None => format!("episodes {a}..{b}"),
        };
        Error::World(format!("{}, {episodes} ({}), {}: {error}", self.world, self.stream(), self.call()))
    }
}

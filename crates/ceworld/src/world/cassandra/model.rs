//! The parsed model and the parse options.

/// Whether the file's `R:` values are rewards or costs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Values {
    /// `values: reward` (also the default when the line is absent).
    #[default]
    Reward,
    /// `values: cost`: the values are costs, to be minimised. They are
    /// stored as written, *not* negated.
    Cost,
}

/// Parse options.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// How far a probability row (each `T(·|a,s)`, each `O(·|a,s')`, the
    /// start belief) may sum from 1 and still be accepted; accepted rows that
    /// are off by more than rounding noise (1e-10) are renormalised and noted
    /// in [`Pomdp::renormalised`]. Default [`Options::DEFAULT_TOLERANCE`].
    pub tolerance: f64,
    /// The most entries a dense table (`T` is A×S×S, `O` is A×S×O) may have.
    /// Larger models are refused with an error before anything is allocated.
    /// Default [`Options::DEFAULT_MAX_ENTRIES`] (2^28, i.e. 2 GiB of `f64`).
    pub max_entries: usize,
}

impl Options {
    /// The default tolerance, 1e-5: twice the worst error of the published
    /// benchmark files (rows of six-decimal numbers such as `0.333333 ×3`, off
    /// by up to 5e-6), and four orders of magnitude below the smallest real
    /// mistake known (ejs7's observation row that sums to 1.1).
    pub const DEFAULT_TOLERANCE: f64 = 1e-5;
    /// The default cap on the size of a dense table: 2^28 entries.
    pub const DEFAULT_MAX_ENTRIES: usize = 1 << 28;
}

impl Default for Options {
    fn default() -> Self {
        Options { tolerance: Self::DEFAULT_TOLERANCE, max_entries: Self::DEFAULT_MAX_ENTRIES }
    }
}

/// One `R:` value as written, with wildcards (`*`) as `None`. A row or a
/// matrix in the file gives one entry per number, in file order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RewardEntry {
    pub action: Option<usize>,
    pub state: Option<usize>,
    pub next_state: Option<usize>,
    pub observation: Option<usize>,
    pub value: f64,
}

impl RewardEntry {
    /// Whether this entry applies to `(a, s, s2, o)`.
    #[must_use]
    pub fn matches(&self, a: usize, s: usize, s2: usize, o: usize) -> bool {
        self.action.is_none_or(|x| x == a)
            && self.state.is_none_or(|x| x == s)
            && self.next_state.is_none_or(|x| x == s2)
            && self.observation.is_none_or(|x| x == o)
    }
}

/// A POMDP as read from a `.pomdp` file.
///
/// `T` and `O` are dense and validated: every row sums to 1 (after any
/// renormalisation within [`Options::tolerance`]) and has no negative entry.
/// Rewards are kept as the list of entries in file order (see
/// [`Pomdp::reward`], [`Pomdp::expected_reward`]), because a dense
/// `R(a, s, s', o)` is far too large for the bigger files.
#[derive(Clone, Debug, PartialEq)]
pub struct Pomdp {
    /// `None` when the file has no `discount:` line.
    pub discount: Option<f64>,
    /// Reward or cost (default reward).
    pub values: Values,
    /// State names; a count N gives the names "0" .. "N-1".
    pub states: Vec<String>,
    pub actions: Vec<String>,
    pub observations: Vec<String>,
    /// `None` when the file has no `start` line; otherwise a distribution
    /// over states.
    pub start: Option<Vec<f64>>,
    /// `T(s'|s,a)` at index `(a*S + s)*S + s'`.
    pub transition: Vec<f64>,
    /// `O(o|a,s')` at index `(a*S + s')*O + o`.
    pub observation: Vec<f64>,
    /// The `R:` entries in file order; later entries override earlier ones.
    pub rewards: Vec<RewardEntry>,
    /// One note per probability row that was renormalised: which row and
    /// what it summed to.
    pub renormalised: Vec<String>,
}

impl Pomdp {
    /// Number of states `S`.
    #[must_use]
    pub fn num_states(&self) -> usize {
        self.states.len()
    }

    /// Number of actions `A`.
    #[must_use]
    pub fn num_actions(&self) -> usize {
        self.actions.len()
    }

    /// Number of observations `O`.
    #[must_use]
    pub fn num_observations(&self) -> usize {
        self.observations.len()
    }

    /// The start belief, uniform when the file gives none.
    #[must_use]
    pub fn start_or_uniform(&self) -> Vec<f64> {
        if let Some(b) = &self.start {
            return b.clone();
        }
        let n = self.num_states();
        // A count of states is far below 2^52, so this is exact.
        #[allow(clippy::cast_precision_loss)]
        let p = 1.0 / n as f64;
        vec![p; n]
    }

    /// `T(s2 | s, a)`; 0 for indices out of range.
    #[must_use]
    pub fn transition_prob(&self, a: usize, s: usize, s2: usize) -> f64 {
        let n = self.num_states();
        if a >= self.num_actions() || s >= n || s2 >= n {
            return 0.0;
        }
        self.transition.get((a * n + s) * n + s2).copied().unwrap_or(0.0)
    }

    /// `O(o | a, s2)`; 0 for indices out of range.
    #[must_use]
    pub fn observation_prob(&self, a: usize, s2: usize, o: usize) -> f64 {
        let (n, m) = (self.num_states(), self.num_observations());
        if a >= self.num_actions() || s2 >= n || o >= m {
            return 0.0;
        }
        self.observation.get((a * n + s2) * m + o).copied().unwrap_or(0.0)
    }

    /// `R(a, s, s2, o)` as written: the value of the last entry that matches,
    /// or 0 when none does.
    #[must_use]
    pub fn reward(&self, a: usize, s: usize, s2: usize, o: usize) -> f64 {
        self.rewards.iter().rev().find(|e| e.matches(a, s, s2, o)).map_or(0.0, |e| e.value)
    }

    /// Whether any entry names a specific next state or observation, i.e.
    /// whether the reward may depend on more than `(a, s)`.
    #[must_use]
    pub fn reward_depends_on_next(&self) -> bool {
        self.rewards.iter().any(|e| e.next_state.is_some() || e.observation.is_some())
    }
}

//! A tabular POMDP world read from a Cassandra `.pomdp` file or an APPL `.pomdpx` file, flattened
//! (model §7).
//!
//! An observation follows each action and none precedes the first: at `t = 1` the world emits
//! the start symbol `|O|`, so a policy sees `|O| + 1` observations. The episode's reward is
//! `Σ_{t=1..H} γ^(t-1) r_t` with `r_t = R(s_t, a_t, s_{t+1}, o_{t+1})` (costs negated), `γ` from
//! the file (1 when it has none) unless overridden. A step draws `(s_{t+1}, o_{t+1})` jointly
//! from one alias table per `(s_t, a_t)` over the pairs of positive probability, each pair
//! carrying its reward.

use std::path::Path;
use std::sync::Arc;

use rand::Rng;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::error::{Error, Result};
use crate::policy::alias::{AliasEntry, AliasScratch, build_alias, pick};
use crate::rng::EngineRng;
use crate::world::World;
use crate::world::cassandra::{Options, Pomdp, Values, parse_bytes};

pub use crate::world::cassandra::MAX_FILE_BYTES;
/// Most `(s', o)` outcomes of positive probability over all `(s, a)` (memory guard).
pub const MAX_OUTCOMES: usize = 1 << 26;
/// Most entries of each dense table a world parses (`T`, A×S×S, and `O`, A×S×O): 2^26, 512 MiB
/// of `f64` each. A world samples at most [`MAX_OUTCOMES`] outcomes, so a larger model could
/// only be refused after its tables were built; a few bytes of header (16384 states and
/// wildcards) are refused at once instead of after gigabytes.
pub const MAX_DENSE_ENTRIES: usize = 1 << 26;

/// The parameters of a tabular world, as stored in policy files.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PomdpParams {
    /// The `.pomdp` file, as given (relative paths are from the working directory).
    pub file: String,
    /// Steps per episode `H`.
    pub horizon: usize,
    /// The discount `γ` in `(0, 1]`; `None`: the file's (1 when it has none).
    pub discount: Option<f64>,
    /// The SHA-256 of the file's bytes (hex); when given, the file read must have it.
    pub sha256: Option<String>,
    /// What a step adds to the episode's reward: `"sampled"`, the drawn `R(s, a, s', o)`, or
    /// `"belief"`, its expectation given what the policy has seen, `Σ_s b_t(s) r(s, a)` with
    /// `b_t` the exact belief (Bayes filter). Both have the same expectation, so a policy's
    /// value is the same; the belief reward leaves out the luck of the hidden state, which
    /// otherwise fills the CE elite with lucky episodes (model §7).
    #[serde(default)]
    pub reward: RewardKind,
}

/// What a step adds to the episode's reward (see [`PomdpParams::reward`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RewardKind {
    /// The drawn reward `R(s_t, a_t, s_{t+1}, o_{t+1})`.
    #[default]
    Sampled,
    /// Its expectation given the observations and decisions so far.
    Belief,
}

impl Default for PomdpParams {
    fn default() -> Self {
        PomdpParams { file: String::new(), horizon: 100, discount: None, sha256: None, reward: RewardKind::Sampled }
    }
}

/// The sampling tables of a parsed model.
#[derive(Debug)]
pub struct Tables {
    /// The model as parsed (names, dense `T` and `O`, reward entries).
    pub pomdp: Pomdp,
    /// The discount used.
    pub gamma: f64,
    /// The start distribution over states.
    pub start: Vec<f64>,
    start_alias: Vec<AliasEntry>,
    /// `offsets[s·A + a] .. offsets[s·A + a + 1]`: the outcomes of `(s, a)`.
    pub offsets: Vec<usize>,
    /// Each outcome's `(s', o)`.
    pub next: Vec<(u32, u32)>,
    /// Each outcome's probability `T(s'|s,a) O(o|a,s')`.
    pub prob: Vec<f64>,
    /// Each outcome's reward `R(a, s, s', o)`, costs negated.
    pub reward: Vec<f64>,
    alias: Vec<AliasEntry>,
    /// `r(s, a)` at `s·A + a`: the expected immediate reward.
    expected: Vec<f64>,
}

/// A tabular POMDP world.
#[derive(Clone, Debug)]
pub struct PomdpWorld {
    params: PomdpParams,
    tables: Arc<Tables>,
}

impl PartialEq for PomdpWorld {
    fn eq(&self, other: &Self) -> bool {
        self.params == other.params
    }
}

/// The state of an episode: the hidden state, the last observation, the weight of the next
/// reward (`γ^(t-1)`), the discounted reward so far and, for belief rewards, the belief.
#[derive(Clone, Debug)]
pub struct PomdpState {
    /// The hidden state `s_t`.
    pub s: u32,
    /// The observation `y_t` (`|O|` at `t = 1`).
    pub y: u32,
    weight: f64,
    total: f64,
    belief: Vec<f64>,
    scratch: Vec<f64>,
}

/// The hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    crate::files::hex(&Sha256::digest(bytes))
}

impl PomdpWorld {
    /// The name in policy files and on the command line.
    pub const NAME: &'static str = "pomdp";

    /// Reads `params.file` (refusing a file whose SHA-256 differs from `params.sha256`), parses
    /// it and builds the sampling tables.
    pub fn with_params(params: PomdpParams) -> Result<PomdpWorld> {
        if params.file.is_empty() {
            return Err(Error::invalid("pomdp.file", "\"\" (expected the path of a .pomdp or .pomdpx file)"));
        }
        if params.horizon == 0 || params.horizon > 1_000_000 {
            return Err(Error::invalid("pomdp.horizon", format!("{} (expected 1..=1000000)", params.horizon)));
        }
        if let Some(g) = params.discount
            && !(0.0..=1.0).contains(&g)
        {
            // The domain of a file's own `discount:`.
            return Err(Error::invalid("pomdp.discount", format!("{g} (expected 0 <= discount <= 1)")));
        }
        let bytes = crate::files::read_limited(Path::new(&params.file), MAX_FILE_BYTES, "pomdp.file")?;
        let digest = sha256_hex(&bytes);
        if let Some(expected) = &params.sha256
            && *expected != digest
        {
            return Err(Error::Mismatch(format!(
                "{} has SHA-256 {digest}, not {expected}: the model changed since the policy was made",
                params.file
            )));
        }
        let options = Options { max_entries: MAX_DENSE_ENTRIES, ..Options::default() };
        // An XML document is APPL's factored `.pomdpx`, flattened; any other text Cassandra's.
        let parsed = if crate::world::pomdpx::looks_like_pomdpx(&bytes) {
            crate::world::pomdpx::parse_bytes(&bytes, &options)
        } else {
            parse_bytes(&bytes, &options)
        };
        let pomdp = parsed.map_err(|mut e| {
            e.file = Some(params.file.clone());
            Error::ModelFormat(e.to_string())
        })?;
        let gamma = params.discount.or(pomdp.discount).unwrap_or(1.0);
        let tables = Arc::new(Tables::new(pomdp, gamma)?);
        // An episode's value must stay a number: its rewards' largest discounted sum.
        let largest = tables.reward.iter().chain(&tables.expected).fold(0.0, |m: f64, r| m.max(r.abs()));
        let steps = if gamma < 1.0 {
            (1.0 - gamma.powi(params.horizon.min(i32::MAX as usize) as i32)) / (1.0 - gamma)
        } else {
            params.horizon as f64
        };
        if !(largest * steps).is_finite() {
            return Err(Error::invalid(
                "pomdp.file",
                format!(
                    "{}: rewards up to {largest:e} over {} steps (discount {gamma}) sum past the largest number, {:e} (expected smaller rewards or a shorter horizon)",
                    params.file,
                    params.horizon,
                    f64::MAX
                ),
            ));
        }
        Ok(PomdpWorld { params: PomdpParams { sha256: Some(digest), ..params }, tables })
    }

    /// The world of `file` with horizon `horizon` (and the file's discount unless `discount`).
    pub fn from_file(file: impl Into<String>, horizon: usize, discount: Option<f64>) -> Result<PomdpWorld> {
        Self::with_params(PomdpParams { file: file.into(), horizon, discount, ..PomdpParams::default() })
    }

    /// The parameters, with the file's SHA-256.
    pub fn params(&self) -> &PomdpParams {
        &self.params
    }

    /// The model and its sampling tables.
    pub fn tables(&self) -> &Tables {
        &self.tables
    }

    /// `policy` as a policy graph over the file's observations (its first memory drawn after
    /// the start symbol), laws below `prune` left out, equivalent nodes merged when it is
    /// deterministic.
    pub fn graph(&self, policy: &crate::policy::Hhmm, prune: f64) -> Result<crate::policy::graph::Graph> {
        crate::policy::graph::check_prune("prune", prune)?;
        policy.check_shape(self.n_observations(), self.n_decisions())?;
        let n_o = self.tables.n_observations();
        Ok(crate::policy::graph::Graph::of(policy, n_o, n_o, prune)?.minimized())
    }
}

/// The `(s, a, s', o)` with `T(s'|s,a) > 0` and `O(o|a,s') > 0`: the outcomes a world stores (at
/// most; a product of two tiny probabilities may round to 0 and not be stored).
fn count_outcomes(pomdp: &Pomdp) -> u64 {
    let (n_s, n_a, n_o) = (pomdp.num_states(), pomdp.num_actions(), pomdp.num_observations());
    let seen: Vec<u64> =
        pomdp.observation.chunks(n_o.max(1)).map(|row| row.iter().filter(|&&p| p > 0.0).count() as u64).collect();
    let mut total = 0u64;
    for a in 0..n_a {
        for s in 0..n_s {
            let row = &pomdp.transition[(a * n_s + s) * n_s..(a * n_s + s + 1) * n_s];
            total +=
                row.iter().zip(&seen[a * n_s..(a + 1) * n_s]).filter(|(t, _)| **t > 0.0).map(|(_, k)| k).sum::<u64>();
        }
    }
    total
}

impl Tables {
    fn new(pomdp: Pomdp, gamma: f64) -> Result<Tables> {
        let (n_s, n_a, n_o) = (pomdp.num_states(), pomdp.num_actions(), pomdp.num_observations());
        let sign = match pomdp.values {
            Values::Reward => 1.0,
            Values::Cost => -1.0,
        };
        let start = pomdp.start_or_uniform();
        let mut scratch = AliasScratch::default();
        let mut start_alias = vec![AliasEntry::default(); n_s];
        build_alias(&start, &mut start_alias, &mut scratch);
        // The outcomes counted (at most: a product may round to 0) and checked against the memory
        // before any is stored.
        let total = count_outcomes(&pomdp);
        if total > MAX_OUTCOMES as u64 {
            return Err(Error::invalid(
                "pomdp",
                format!("{total} (s', o) outcomes of positive probability (at most {MAX_OUTCOMES})"),
            ));
        }
        let bytes = total * (size_of::<(u32, u32)>() + 2 * size_of::<f64>() + size_of::<AliasEntry>()) as u64;
        let what = format!("the {total} outcomes (s', o) of a model with {n_s} states and {n_a} actions");
        crate::memory::check_memory(&what, bytes, crate::memory::available_memory())?;
        let total = total as usize;
        let mut offsets = Vec::with_capacity(n_s * n_a + 1);
        offsets.push(0);
        let (mut next, mut prob, mut reward) =
            (Vec::with_capacity(total), Vec::with_capacity(total), Vec::with_capacity(total));
        // The reward of each outcome: the last matching entry in file order.
        let mut rewards = pomdp.outcome_rewards();
        for s in 0..n_s {
            for a in 0..n_a {
                rewards.select(a, s);
                for s2 in 0..n_s {
                    let t = pomdp.transition[(a * n_s + s) * n_s + s2];
                    if t == 0.0 {
                        continue;
                    }
                    let row = rewards.row(s2);
                    for (o, &r) in row.iter().enumerate() {
                        let p = t * pomdp.observation[(a * n_s + s2) * n_o + o];
                        if p > 0.0 {
                            next.push((s2 as u32, o as u32));
                            prob.push(p);
                            reward.push(sign * r);
                        }
                    }
                }
                offsets.push(next.len());
            }
        }
        let mut alias = vec![AliasEntry::default(); next.len()];
        let mut expected = Vec::with_capacity(offsets.len() - 1);
        for w in offsets.windows(2) {
            build_alias(&prob[w[0]..w[1]], &mut alias[w[0]..w[1]], &mut scratch);
            expected.push((w[0]..w[1]).map(|k| prob[k] * reward[k]).sum());
        }
        Ok(Tables { pomdp, gamma, start, start_alias, offsets, next, prob, reward, alias, expected })
    }

    /// Number of states `S`.
    pub fn n_states(&self) -> usize {
        self.pomdp.num_states()
    }

    /// Number of actions `A`.
    pub fn n_actions(&self) -> usize {
        self.pomdp.num_actions()
    }

    /// Number of observations `|O|` of the file (the world emits one more: the start symbol).
    pub fn n_observations(&self) -> usize {
        self.pomdp.num_observations()
    }

    /// The outcomes of `(s, a)`: a range of `next`, `prob` and `reward`.
    pub fn outcomes(&self, s: usize, a: usize) -> std::ops::Range<usize> {
        let k = s * self.n_actions() + a;
        self.offsets[k]..self.offsets[k + 1]
    }

    /// The expected immediate reward `r(s, a) = Σ_{s', o} T O R`, costs negated.
    pub fn expected_reward(&self, s: usize, a: usize) -> f64 {
        self.expected[s * self.n_actions() + a]
    }

    /// The belief after `a` and `o` from `belief` (Bayes filter), written to `next`; the
    /// probability of `o` is returned (0: `o` was impossible, `next` is then all zero).
    pub fn filter(&self, belief: &[f64], a: usize, o: usize, next: &mut [f64]) -> f64 {
        next.fill(0.0);
        for (s, &b) in belief.iter().enumerate() {
            if b > 0.0 {
                for k in self.outcomes(s, a) {
                    let (s2, o2) = self.next[k];
                    if o2 as usize == o {
                        next[s2 as usize] += b * self.prob[k];
                    }
                }
            }
        }
        let total: f64 = next.iter().sum();
        if total > 0.0 {
            for p in next.iter_mut() {
                *p /= total;
            }
        }
        total
    }

    /// The largest `|R|` of any outcome.
    pub fn max_abs_reward(&self) -> f64 {
        self.reward.iter().fold(0.0, |m, r| m.max(r.abs()))
    }
}

impl World for PomdpWorld {
    type State = PomdpState;

    fn tabular(&self) -> Option<&PomdpWorld> {
        Some(self)
    }

    fn n_observations(&self) -> usize {
        self.tables.n_observations() + 1
    }

    fn n_decisions(&self) -> usize {
        self.tables.n_actions()
    }

    fn horizon(&self) -> usize {
        self.params.horizon
    }

    fn reset(&self, rng: &mut EngineRng) -> PomdpState {
        let t = &self.tables;
        let s = pick(&t.start_alias, 0, t.n_states(), rng.next_u64());
        let belief = match self.params.reward {
            RewardKind::Sampled => Vec::new(),
            RewardKind::Belief => t.start.clone(),
        };
        let scratch = vec![0.0; belief.len()];
        PomdpState { s: s as u32, y: t.n_observations() as u32, weight: 1.0, total: 0.0, belief, scratch }
    }

    #[inline]
    fn observe(&self, state: &PomdpState, _rng: &mut EngineRng) -> usize {
        state.y as usize
    }

    #[inline]
    fn step(&self, state: &mut PomdpState, decision: usize, rng: &mut EngineRng) {
        let t = &self.tables;
        let range = t.outcomes(state.s as usize, decision);
        let k = range.start + pick(&t.alias, range.start, range.len(), rng.next_u64());
        (state.s, state.y) = t.next[k];
        let r = match self.params.reward {
            RewardKind::Sampled => t.reward[k],
            RewardKind::Belief => {
                let n_a = t.n_actions();
                let r = state.belief.iter().enumerate().map(|(s, &b)| b * t.expected[s * n_a + decision]).sum();
                t.filter(&state.belief, decision, state.y as usize, &mut state.scratch);
                std::mem::swap(&mut state.belief, &mut state.scratch);
                r
            }
        };
        state.total += state.weight * r;
        state.weight *= t.gamma;
    }

    fn reward(&self, state: &PomdpState) -> f64 {
        state.total
    }

    fn discount(&self) -> Option<f64> {
        Some(self.tables.gamma)
    }

    fn state_labels(&self) -> Vec<&'static str> {
        vec!["state", "observation"]
    }

    fn describe(&self, state: &PomdpState, out: &mut Vec<i64>) {
        out.extend([i64::from(state.s), i64::from(state.y)]);
    }

    fn to_json(&self) -> serde_json::Value {
        let mut json = serde_json::to_value(&self.params).expect("parameters serialise");
        json["name"] = Self::NAME.into();
        json
    }
}

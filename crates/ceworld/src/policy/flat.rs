//! An HHMM as its sizes and flat table entries, for serde (checkpoints and result records): floats
//! in their shortest exact form, read back exactly.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::policy::{Hhmm, Layout};

/// An HHMM as its sizes and flat table entries; read back through [`Hhmm::from_flat`].
#[derive(Serialize, Deserialize)]
pub(crate) struct PolicyTables {
    n_obs: usize,
    n_actions: usize,
    levels: Vec<usize>,
    probs: Vec<f64>,
}

impl PolicyTables {
    pub(crate) fn of(policy: &Hhmm) -> PolicyTables {
        let layout = policy.layout();
        PolicyTables {
            n_obs: layout.n_obs,
            n_actions: layout.n_actions,
            levels: layout.levels.clone(),
            probs: policy.probs().to_vec(),
        }
    }

    pub(crate) fn into_policy<E: serde::de::Error>(self) -> std::result::Result<Hhmm, E> {
        let layout = Layout::new(self.n_obs, self.n_actions, &self.levels).map_err(E::custom)?;
        Hhmm::from_flat(layout, self.probs).map_err(E::custom)
    }
}

/// `#[serde(with = ...)]` for an [`Hhmm`]: its sizes and flat entries.
pub(crate) mod policy_serde {
    use super::{Deserialize, Deserializer, Hhmm, PolicyTables, Serialize, Serializer};

    pub fn serialize<S: Serializer>(policy: &Hhmm, s: S) -> Result<S::Ok, S::Error> {
        PolicyTables::of(policy).serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Hhmm, D::Error> {
        PolicyTables::deserialize(d)?.into_policy()
    }
}

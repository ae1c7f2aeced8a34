//! The best so far of model-search (model §10) and what replaces it: a plan whose gain over it on
//! the same selection episodes is more than their noise.

use serde::{Deserialize, Serialize};

use crate::evaluate::{Evaluation, mean};
use crate::policy::controller::Controller;

/// The best controller so far, with its mean value over every selection episode it was valued on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Incumbent {
    /// The controller.
    pub controller: Controller,
    /// Its mean value on the selection episodes it was valued on.
    pub value: f64,
    /// How many.
    pub episodes: usize,
}

/// Whether a plan of values `challenger` on the selection episodes replaces the best so far, of
/// values `held` on the same ones (in order): where its mean beats the best's by more than
/// `margin` standard errors of its gains episode by episode (0: by anything). The best of
/// several plans on a few episodes is biased up; the gains of one plan over the best on the same
/// episodes are not.
pub(super) fn replaces(challenger: &[f64], held: &[f64], margin: f64) -> bool {
    let gains: Vec<f64> = challenger.iter().zip(held).map(|(c, h)| c - h).collect();
    let noise = Evaluation::from_rewards(&gains).std_error.max(0.0);
    mean(challenger.iter().copied()) - mean(held.iter().copied()) > margin * noise
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plan_replaces_the_best_by_more_than_the_noise_of_its_gains() {
        let held = [0.0; 4];
        // Gains 1, 0, 1, 0: mean 0.5, standard error 0.289.
        let lucky = [1.0, 0.0, 1.0, 0.0];
        assert!(replaces(&lucky, &held, 0.0) && replaces(&lucky, &held, 1.0) && !replaces(&lucky, &held, 2.0));
        // The same gain on every episode has no noise: any margin.
        assert!(replaces(&[0.5; 4], &held, 100.0));
        // Equal values never replace it; nor does a loss.
        assert!(!replaces(&held, &held, 0.0) && !replaces(&[-1.0; 4], &held, 0.0));
        // Paired: the episodes' own spread does not count, the gains' does.
        let hard = [5.0, -5.0, 5.0, -5.0];
        let better = [5.1, -4.9, 5.1, -4.9];
        assert!(replaces(&better, &hard, 3.0));
    }
}

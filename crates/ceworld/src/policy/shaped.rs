//! An HHMM from its tables as arrays, each a shape and its entries (model §6): what a front end
//! that holds arrays (numpy's, in `cehmm.Policy.from_tables`) gives.

use crate::error::{Error, Result};
use crate::policy::{Hhmm, Layout};

impl Hhmm {
    /// A policy from its tables as arrays (`(shape, entries in row-major order)`, in the order
    /// `h0, h1, upper[0].start, upper[0].step, ...`, model §6): the layout is read from the
    /// shapes, then every shape is checked against it (the error names the table and the shape
    /// it needs), then the entries as [`Hhmm::from_flat`] does.
    pub fn from_shaped(tables: &[(&[usize], &[f64])]) -> Result<Hhmm> {
        let names = ["h0".to_string(), "h1".to_string()]
            .into_iter()
            .chain(
                (0..tables.len().saturating_sub(2) / 2)
                    .flat_map(|k| [format!("upper[{k}].start"), format!("upper[{k}].step")]),
            )
            .collect::<Vec<_>>();
        // What each table's axes are (model §6): h0, h1, then a start and a step per level.
        let axes = |k: usize| ["(|M_1|, D)", "(Y, U, |M_1|)", "(U, |M_l|)", "(|M_l-1|, U, |M_l|)"][k.min(2 + k % 2)];
        let dim = |k: usize, axis: usize| -> Result<usize> {
            let (shape, rank) = (tables[k].0, axes(k).matches(',').count() + 1);
            if shape.len() != rank {
                let (got, needs) = (shape_text(shape), axes(k));
                return Err(Error::format(format!("{} has shape {got} (expected {rank} axes {needs})", names[k])));
            }
            Ok(shape[axis])
        };
        if tables.len() < 2 || tables.len() % 2 != 0 {
            return Err(Error::format(format!(
                "{} tables (expected h0, h1 and a start and a step per upper level)",
                tables.len()
            )));
        }
        let mut sizes = vec![dim(0, 0)?];
        let (n_actions, n_obs) = (dim(0, 1)?, dim(1, 0)?);
        for k in (2..tables.len()).step_by(2) {
            sizes.push(dim(k, 1)?);
            dim(k + 1, 0)?;
        }
        let layout = Layout::new(n_obs, n_actions, &sizes).map_err(|e| Error::format(e.to_string()))?;
        let mut probs = Vec::with_capacity(layout.len);
        for ((shape, entries), table) in tables.iter().zip(&layout.tables) {
            if *shape != table.dims.as_slice() || entries.len() != table.rows * table.cols {
                let (got, needs) = (shape_text(shape), shape_text(&table.dims));
                return Err(Error::format(format!("{} has shape {got} (expected {needs})", table.name)));
            }
            probs.extend_from_slice(entries);
        }
        Hhmm::from_flat(layout, probs)
    }
}

/// `(16, 16)`: a shape as Python and the model document print it.
pub fn shape_text(dims: &[usize]) -> String {
    match dims {
        [one] => format!("({one},)"),
        _ => format!("({})", dims.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, stream};

    #[test]
    fn tables_from_their_shapes_round_trip_and_name_a_wrong_shape() {
        let h = Hhmm::random(3, 2, &[4, 3], &mut stream(7, Purpose::Init, 0, 0)).unwrap();
        let tables: Vec<(&[usize], &[f64])> =
            h.layout().tables.iter().enumerate().map(|(k, t)| (t.dims.as_slice(), h.table(k))).collect();
        assert_eq!(Hhmm::from_shaped(&tables).unwrap().probs(), h.probs());
        // upper[0].step cut to (4, 3): the rank it needs is named.
        let mut wrong = tables.clone();
        wrong[3] = (&[4, 3], &h.table(3)[..12]);
        let error = Hhmm::from_shaped(&wrong).unwrap_err().to_string();
        assert!(error.contains("upper[0].step has shape (4, 3) (expected 3 axes (|M_l-1|, U, |M_l|))"), "{error}");
        // h1 with one outcome too few: its shape is named beside the one it needs.
        let short: Vec<f64> = vec![0.5; 3 * 3 * 3];
        let mut wrong = tables.clone();
        wrong[1] = (&[3, 3, 3], &short);
        let error = Hhmm::from_shaped(&wrong).unwrap_err().to_string();
        assert!(error.contains("h1 has shape (3, 3, 3) (expected (3, 3, 4))"), "{error}");
        assert!(Hhmm::from_shaped(&tables[..3]).is_err());
    }
}

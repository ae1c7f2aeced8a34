//! `cehmm._core.Policy`: an HHMM policy with its world and provenance (`ceworld::PolicyFile`,
//! model §6); wrapped by `cehmm.Policy`.

use std::path::PathBuf;

use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::{Value, json};

use ceworld::evaluate::{check_fits, rollout};
use ceworld::{Error, Hhmm, Init, Layout, PolicyFile, thread_pool, with_world};

use crate::arg::WorldArg;
use crate::convert::{count, flag, levels, object, optional_count, real, seed, text, to_py};
use crate::errors::{OrRaise, detached, raise};
use crate::outside::run_outside;
use crate::signals::Signals;
use crate::world::PyWorld;

#[pyclass(module = "cehmm._core", name = "Policy", frozen)]
pub struct PyPolicy {
    pub file: PolicyFile,
}

impl PyPolicy {
    pub fn new(policy: Hhmm, world: Value, provenance: Value) -> Self {
        PyPolicy { file: PolicyFile { policy, world, provenance } }
    }
}

#[pymethods]
impl PyPolicy {
    /// The starting policy `init` (`"uniform"`, `"random"` drawn from `seed`, or `"clock"`) with
    /// `levels` sized for `world`.
    #[staticmethod]
    fn start(
        py: Python<'_>,
        world: &Bound<'_, PyAny>,
        levels: &Bound<'_, PyAny>,
        init: &Bound<'_, PyAny>,
        seed: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let init: Init = text("init", init)?.parse().or_raise()?;
        let (sizes, seed) = (self::levels(levels)?, self::seed("seed", seed)?);
        let (policy, world) = WorldArg::of(world)?.run(py, |w| Ok((init.policy(w, &sizes, seed)?, w.description())))?;
        Ok(Self::new(policy, world, json!({})))
    }

    /// A policy from float64 tables; the layout is read from the shapes, then every shape and
    /// row is checked. With a world, the policy must fit it.
    #[staticmethod]
    #[pyo3(signature = (h0, h1, upper, world = None, provenance = None))]
    fn from_tables(
        py: Python<'_>,
        h0: PyReadonlyArrayDyn<'_, f64>,
        h1: PyReadonlyArrayDyn<'_, f64>,
        upper: Vec<(PyReadonlyArrayDyn<'_, f64>, PyReadonlyArrayDyn<'_, f64>)>,
        world: Option<&Bound<'_, PyAny>>,
        provenance: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let arrays: Vec<_> =
            [&h0, &h1].into_iter().chain(upper.iter().flat_map(|(start, step)| [start, step])).collect();
        let entries: Vec<Vec<f64>> = arrays.iter().map(|a| a.as_array().iter().copied().collect()).collect();
        let shaped: Vec<_> = arrays.iter().zip(&entries).map(|(a, e)| (a.shape(), e.as_slice())).collect();
        let policy = Hhmm::from_shaped(&shaped).or_raise()?;
        let world = match world {
            Some(w) => WorldArg::of(w)?.run(py, |w| check_fits(w, &policy).map(|()| w.description()))?,
            None => json!({}),
        };
        Ok(Self::new(policy, world, Value::Object(object("provenance", provenance)?)))
    }

    /// Reads and checks a policy file (model §6).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        Ok(PyPolicy { file: PolicyFile::load(path).or_raise()? })
    }

    /// Reads and checks a policy document (model §6) from its JSON text.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        Ok(PyPolicy { file: PolicyFile::parse(text).or_raise()? })
    }

    /// Writes the policy file (model §6); an existing file is replaced only when `overwrite`.
    #[pyo3(signature = (path, *, overwrite = false))]
    fn save(&self, path: PathBuf, overwrite: bool) -> PyResult<()> {
        if !overwrite {
            ceworld::files::check_new("path", &path, "give overwrite=True").or_raise()?;
        }
        self.file.save(path).or_raise()
    }

    /// The most likely policy: every law at its likeliest outcome (a deterministic controller
    /// with the same memory), the provenance marking it so.
    fn most_likely(&self) -> PyPolicy {
        let mut file = self.file.clone();
        file.policy = file.policy.most_likely();
        if let Some(map) = file.provenance.as_object_mut() {
            map.insert("derived".into(), json!("most likely (each law at its likeliest outcome)"));
        }
        PyPolicy { file }
    }

    /// The policy document (model §6) as JSON text.
    fn to_json(&self) -> String {
        self.file.to_text()
    }

    /// Memory sizes per level, bottom first.
    #[getter]
    fn levels(&self) -> Vec<usize> {
        self.file.policy.levels().to_vec()
    }

    /// Number of observations `Y`.
    #[getter]
    fn n_obs(&self) -> usize {
        self.file.policy.layout().n_obs
    }

    /// Number of decisions `D`.
    #[getter]
    fn n_actions(&self) -> usize {
        self.file.policy.layout().n_actions
    }

    /// The paper's count of free parameters (start tables excluded).
    #[getter]
    fn parameter_count(&self) -> usize {
        self.file.policy.layout().parameter_count()
    }

    /// The `"world"` object of the file.
    #[getter]
    fn world<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.file.world)
    }

    /// The `"provenance"` object of the file.
    #[getter]
    fn provenance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.file.provenance)
    }

    /// `{"h0": array, "h1": array, "upper": [{"start": array, "step": array}, ...]}`, float64,
    /// shapes as in model §6.
    fn tables<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let h = &self.file.policy;
        let layout = h.layout();
        let array = |index: usize| {
            let dims = &layout.tables[index].dims;
            ArrayD::from_shape_vec(IxDyn(dims), h.table(index).to_vec()).expect("table sizes match").into_pyarray(py)
        };
        let d = PyDict::new(py);
        d.set_item("h0", array(0))?;
        d.set_item("h1", array(1))?;
        let mut upper = Vec::new();
        for level in 2..=layout.depth() {
            let entry = PyDict::new(py);
            entry.set_item("start", array(Layout::start_table(level)))?;
            entry.set_item("step", array(Layout::step_table(level)))?;
            upper.push(entry);
        }
        d.set_item("upper", upper)?;
        Ok(d)
    }

    /// Reward statistics over `episodes` fresh episodes (streams `(seed, Evaluate, 0, k)`).
    #[pyo3(signature = (world, episodes, seed, threads = None))]
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        world: &Bound<'_, PyAny>,
        episodes: &Bound<'_, PyAny>,
        seed: &Bound<'_, PyAny>,
        threads: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (episodes, seed_, threads) =
            (count("episodes", episodes)?, self::seed("seed", seed)?, optional_count("threads", threads)?);
        ceworld::evaluate::check_episodes(episodes).or_raise()?;
        let (world, policy) = (WorldArg::of(world)?, &self.file.policy);
        let pool = thread_pool(threads).or_raise()?;
        // Ctrl-C stops the evaluation within a step of a world written in Python (between
        // slices of episodes of one run by the engine), raising KeyboardInterrupt.
        let mut signals = Signals::default();
        let rewards = world
            .run_watched(py, &mut signals, |w| pool.install(|| ceworld::evaluate::rewards(w, policy, episodes, seed_)));
        signals.finish(py)?;
        let rewards = rewards?;
        crate::results::evaluation(py, &ceworld::Evaluation::from_rewards(&rewards))
    }

    /// Rewards of episodes `first..first + n` of `(seed, purpose, iteration)` (`purpose`:
    /// "optimise", "evaluate" or "select"): a shard of an iteration's or an evaluation's
    /// episodes, as a worker elsewhere runs it; the very rewards of those episodes here.
    #[pyo3(signature = (world, seed, purpose, iteration, first, n, threads = None))]
    #[allow(clippy::too_many_arguments)]
    fn shard_rewards<'py>(
        &self,
        py: Python<'py>,
        world: &Bound<'py, PyAny>,
        seed: &Bound<'py, PyAny>,
        purpose: &str,
        iteration: &Bound<'py, PyAny>,
        first: &Bound<'py, PyAny>,
        n: &Bound<'py, PyAny>,
        threads: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let streams = ceworld::episodes::Streams {
            seed: self::seed("seed", seed)?,
            purpose: ceworld::rng::Purpose::of_episodes(purpose).or_raise()?,
            iteration: self::seed("iteration", iteration)?,
        };
        let (first, n) = (count("first", first)?, count("n", n)?);
        ceworld::evaluate::check_episodes(n).or_raise()?;
        let (world, policy) = (WorldArg::of(world)?, &self.file.policy);
        let pool = thread_pool(optional_count("threads", threads)?).or_raise()?;
        let rewards = world.run(py, |w| {
            let mut values = vec![0.0; n + 1];
            let batch = ceworld::episodes::Batch { values: &mut values[..n], records: None };
            check_fits(w, policy)?;
            let steps = pool.install(|| w.run(policy, streams, first, batch))?;
            values[n] = steps as f64;
            Ok(values)
        })?;
        Ok(PyArray1::from_vec(py, rewards))
    }

    /// The sampled counts (laid out as the flat tables) of `episodes` of iteration `iteration`
    /// of a run seeded `seed`, each re-run from its stream and counted
    /// (`ceworld::ce::rerun::rerun_counts`): what a worker sends back instead of trajectories.
    #[pyo3(signature = (world, seed, iteration, episodes, threads = None))]
    fn rerun_counts<'py>(
        &self,
        py: Python<'py>,
        world: &Bound<'py, PyAny>,
        seed: &Bound<'py, PyAny>,
        iteration: &Bound<'py, PyAny>,
        episodes: Vec<usize>,
        threads: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let streams = ceworld::episodes::Streams {
            seed: self::seed("seed", seed)?,
            purpose: ceworld::rng::Purpose::Optimise,
            iteration: self::seed("iteration", iteration)?,
        };
        let (world, policy) = (WorldArg::of(world)?, &self.file.policy);
        let pool = thread_pool(optional_count("threads", threads)?).or_raise()?;
        let counts =
            world.run(py, |w| pool.install(|| ceworld::ce::rerun::rerun_counts(w, policy, streams, &episodes)))?;
        Ok(PyArray1::from_vec(py, counts))
    }

    /// One recorded episode: episode `episode` of `evaluate(world, _, seed)`.
    #[pyo3(signature = (world, seed, episode))]
    fn rollout<'py>(
        &self,
        py: Python<'py>,
        world: &Bound<'_, PyAny>,
        seed: &Bound<'_, PyAny>,
        episode: &Bound<'_, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (seed, episode) = (self::seed("seed", seed)?, self::seed("episode", episode)?);
        let policy = &self.file.policy;
        let recorded = match WorldArg::of(world)? {
            WorldArg::Engine(w) => {
                let world = &w.world;
                detached(py, || with_world!(world, w => rollout(w, policy, seed, episode)))?
            }
            WorldArg::Outside(w) => {
                run_outside(py, &w, None, |w| ceworld::episodes::outside::rollout(w, policy, seed, episode))?
            }
            WorldArg::Remote(_) => {
                return Err(raise(Error::invalid(
                    "world",
                    "a world sampled elsewhere (a rollout is one episode, recorded here: roll out the world itself)",
                )));
            }
        };
        crate::results::rollout(py, recorded)
    }

    /// The exact expected reward on a tabular world (model §7): at `horizon` (the world's when
    /// `None`), or with `infinite` the infinite-horizon value to within `tolerance`.
    #[pyo3(signature = (world, horizon, infinite, tolerance))]
    fn evaluate_exact<'py>(
        &self,
        py: Python<'py>,
        world: &Bound<'_, PyAny>,
        horizon: Option<&Bound<'_, PyAny>>,
        infinite: &Bound<'_, PyAny>,
        tolerance: &Bound<'_, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let world = &tabular(world, "exact evaluation")?;
        let (horizon, infinite, tolerance) =
            (optional_count("horizon", horizon)?, flag("infinite", infinite)?, real("tolerance", tolerance)?);
        let policy = &self.file.policy;
        let value = detached(py, || {
            if infinite {
                ceworld::exact::infinite_horizon(world, policy, tolerance)
            } else {
                ceworld::exact::finite_horizon(world, policy, horizon)
            }
        })?;
        crate::results::exact_value(py, &value)
    }

    /// The policy as a policy graph on a tabular world (`ceworld::policy::graph`): `"text"` in
    /// the file's names, `"json"` (a dict), or `"pg"` (pomdp-solve's format; deterministic
    /// policies only).
    fn graph<'py>(
        &self,
        py: Python<'py>,
        world: &Bound<'py, PyAny>,
        form: &str,
        prune: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let world = tabular(world, "a policy graph")?;
        let graph = world.graph(&self.file.policy, real("prune", prune)?).or_raise()?;
        let model = &world.tables().pomdp;
        to_py(py, &graph.render(form, &model.actions, &model.observations).or_raise()?)
    }
}

/// The tabular world `world` (a `PomdpWorld`), else an error saying that `what` needs one and
/// what `world` is (an engine world of another kind, or a world that runs outside the engine).
fn tabular(world: &Bound<'_, PyAny>, what: &str) -> PyResult<ceworld::PomdpWorld> {
    let shown = match world.extract::<PyRef<'_, PyWorld>>() {
        Ok(w) => match w.world.tabular() {
            Some(pomdp) => return Ok(pomdp.clone()),
            None => w.world.name().to_string(),
        },
        Err(_) => "a world that runs outside the engine (written in Python, or sampled elsewhere)".to_string(),
    };
    Err(raise(Error::invalid("world", format!("{shown} ({what} needs a tabular world, e.g. cehmm.PomdpWorld)"))))
}

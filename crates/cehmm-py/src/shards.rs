//! The worker's side of episodes sampled elsewhere (model §9): `controller_values`,
//! `controller_credit`, `controller_steps` and `controller_exact_values`, a shard of a controller
//! search's iteration as a worker runs it.

use numpy::PyArray1;
use pyo3::prelude::*;

use ceworld::Error;
use ceworld::ce::controller::ControllerValue;
use ceworld::episodes::credit::StepCredit;
use ceworld::episodes::{Shape, Streams};
use ceworld::policy::controller::Controller;
use ceworld::rng::Purpose;

use crate::arg::WorldArg;
use crate::convert::{count, seed};
use crate::errors::{OrRaise, raise};

/// `controllers` (JSON text: a list of `{"act": [...], "next": [...]}`), checked against
/// `shape`.
fn read_controllers(text: &str, shape: Shape) -> PyResult<Vec<Controller>> {
    let controllers: Vec<Controller> = serde_json::from_str(text)
        .map_err(|e| raise(Error::invalid("controllers", format!("{e} (expected a JSON list of controllers)"))))?;
    controllers.iter().try_for_each(|c| c.check(shape.observations, shape.decisions)).or_raise()?;
    Ok(controllers)
}

/// The values of episodes `0..episodes` of `(seed, purpose, iteration)` of each controller of
/// `controllers` (JSON text: a list of `{"act": [...], "next": [...]}`), controller by
/// controller, then the world's steps they took: a shard of a controller search's iteration or
/// selection, as a worker runs it.
#[pyfunction]
#[pyo3(signature = (world, controllers, seed, purpose, iteration, episodes, threads = None))]
#[allow(clippy::too_many_arguments)]
pub fn controller_values<'py>(
    py: Python<'py>,
    world: &Bound<'py, PyAny>,
    controllers: &str,
    seed: &Bound<'py, PyAny>,
    purpose: &str,
    iteration: &Bound<'py, PyAny>,
    episodes: &Bound<'py, PyAny>,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let run = Shard::read(py, world, controllers, seed, purpose, iteration, episodes, threads)?;
    let pool = ceworld::control::thread_pool(run.threads).or_raise()?;
    let values = run.world.run(py, |w| {
        let n = run.controllers.len() * run.episodes;
        let mut values = vec![0.0; n + 1];
        let steps =
            pool.install(|| w.run_controllers(&run.controllers, run.streams, run.episodes, &mut values[..n]))?;
        values[n] = steps as f64;
        Ok(values)
    })?;
    Ok(PyArray1::from_vec(py, values))
}

/// As [`controller_values`], with the credit of each controller's decision rows within its
/// episodes (model §8), controller by controller: whether credited, its values, its rows'
/// visits and summed credit (`ceworld::episodes::credit::StepCredit::to_blocks`); then the
/// world's steps they took.
#[pyfunction]
#[pyo3(signature = (world, controllers, seed, purpose, iteration, episodes, threads = None))]
#[allow(clippy::too_many_arguments)]
pub fn controller_credit<'py>(
    py: Python<'py>,
    world: &Bound<'py, PyAny>,
    controllers: &str,
    seed: &Bound<'py, PyAny>,
    purpose: &str,
    iteration: &Bound<'py, PyAny>,
    episodes: &Bound<'py, PyAny>,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let run = Shard::read(py, world, controllers, seed, purpose, iteration, episodes, threads)?;
    // One shape per shard (the search's): the first's rows.
    let rows = run.controllers.first().map_or(0, StepCredit::rows_of);
    let blocks = run.credited(py, StepCredit::new(run.controllers.len(), rows), |credit, credited, values| {
        credit.to_blocks(credited, values, run.episodes)
    })?;
    Ok(PyArray1::from_vec(py, blocks))
}

/// As [`controller_values`], with every step of each episode, episode by episode: its value,
/// whether credited, the discount, its length and its observations and rewards
/// (`ceworld::episodes::credit::StepCredit::to_steps`: what a learner of memory from every step
/// keeps, model §10); then the world's steps they took.
#[pyfunction]
#[pyo3(signature = (world, controllers, seed, purpose, iteration, episodes, threads = None))]
#[allow(clippy::too_many_arguments)]
pub fn controller_steps<'py>(
    py: Python<'py>,
    world: &Bound<'py, PyAny>,
    controllers: &str,
    seed: &Bound<'py, PyAny>,
    purpose: &str,
    iteration: &Bound<'py, PyAny>,
    episodes: &Bound<'py, PyAny>,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let run = Shard::read(py, world, controllers, seed, purpose, iteration, episodes, threads)?;
    // Only the steps are read: no credit is counted.
    let numbers = run.credited(py, StepCredit::traced(run.controllers.len(), 0), |credit, credited, values| {
        credit.to_steps(credited, values)
    })?;
    Ok(PyArray1::from_vec(py, numbers))
}

/// A shard of controllers to run, its arguments read.
struct Shard<'py> {
    world: WorldArg<'py>,
    controllers: Vec<Controller>,
    streams: Streams,
    episodes: usize,
    threads: Option<usize>,
}

impl<'py> Shard<'py> {
    /// Runs the shard with `credit` (`Episodes::run_controllers_credited`): what `answer` makes
    /// of the credit, whether credited and the values, then the world's steps they took.
    fn credited(
        &self,
        py: Python<'py>,
        mut credit: StepCredit,
        answer: impl Fn(&StepCredit, bool, &[f64]) -> Vec<f64> + Send + Sync,
    ) -> PyResult<Vec<f64>> {
        let pool = ceworld::control::thread_pool(self.threads).or_raise()?;
        let (controllers, streams, episodes) = (&self.controllers, self.streams, self.episodes);
        self.world.run(py, |w| {
            let mut values = vec![0.0; controllers.len() * episodes];
            let (steps, credited) =
                pool.install(|| w.run_controllers_credited(controllers, streams, episodes, &mut values, &mut credit))?;
            let mut numbers = answer(&credit, credited, &values);
            numbers.push(steps as f64);
            Ok(numbers)
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn read(
        py: Python<'py>,
        world: &Bound<'py, PyAny>,
        controllers: &str,
        seed: &Bound<'py, PyAny>,
        purpose: &str,
        iteration: &Bound<'py, PyAny>,
        episodes: &Bound<'py, PyAny>,
        threads: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Shard<'py>> {
        let streams = Streams {
            seed: self::seed("seed", seed)?,
            purpose: Purpose::of_episodes(purpose).or_raise()?,
            iteration: self::seed("iteration", iteration)?,
        };
        let episodes = count("episodes", episodes)?;
        ceworld::evaluate::check_episodes(episodes).or_raise()?;
        let threads = crate::convert::optional_count("threads", threads)?;
        // Checked here, in the order of the arguments; each caller builds its pool once.
        threads.map(ceworld::control::check_threads).transpose().or_raise()?;
        let world = WorldArg::of(world)?;
        let controllers = read_controllers(controllers, world.run(py, |w| Ok(w.shape()))?)?;
        Ok(Shard { world, controllers, streams, episodes, threads })
    }
}

/// The exact values of `controllers` (JSON text, as for [`controller_values`]) on a tabular
/// world, to `tolerance` (model §8): a shard of an iteration of a search on exact values, as a
/// worker runs it.
#[pyfunction]
#[pyo3(signature = (world, controllers, tolerance, threads = None))]
pub fn controller_exact_values<'py>(
    py: Python<'py>,
    world: &Bound<'py, PyAny>,
    controllers: &str,
    tolerance: &Bound<'py, PyAny>,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let tolerance = crate::convert::real("tolerance", tolerance)?;
    ceworld::ce::controller::ControllerConfig { tolerance, ..Default::default() }.validate().or_raise()?;
    let pool = ceworld::control::thread_pool(crate::convert::optional_count("threads", threads)?).or_raise()?;
    let world = WorldArg::of(world)?;
    let tabular = world
        .tabular()
        .ok_or_else(|| raise(Error::invalid("world", "not tabular (exact values need a cehmm.PomdpWorld)")))?;
    let controllers = read_controllers(controllers, ceworld::episodes::Episodes::shape(tabular))?;
    let exact = ControllerValue::new(tabular, tolerance);
    let values = py.detach(|| pool.install(|| exact.values(&controllers)));
    Ok(PyArray1::from_vec(py, values))
}

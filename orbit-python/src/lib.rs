//! The native module of the `orbit_rs` Python package (`orbit_rs._native`): a task's batch of
//! envs, stepped from Python with numpy arrays. The package's Python code builds gymnasium's
//! vector env and the learning libraries' adapters on it.
//!
//! Each call copies at most once: actions are read in place from a contiguous `float32` array,
//! and every array returned is a new one filled from the env's buffers.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use orbit_envs::{BoxedVecEnv, RunConfigs, VecEnv};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;

create_exception!(
    _native,
    OrbitError,
    PyException,
    "An error from orbit-rs: a bad config, an invalid action, a failed physics backend."
);

/// An orbit-rs error as a Python exception with the same message.
fn error(e: impl std::fmt::Display) -> PyErr {
    OrbitError::new_err(e.to_string())
}

/// The registered tasks: `(id, description, trainable, black_box)`, sorted by id.
#[pyfunction]
fn tasks() -> Vec<(&'static str, &'static str, bool, bool)> {
    orbit::link_registrations();
    orbit::managers::tasks()
        .into_iter()
        .map(|t| (t.id, t.description, t.agent.is_some(), t.is_black_box()))
        .collect()
}

/// A batch of self-resetting envs of one task (step-based, or black-box: one movement
/// primitive per step).
#[pyclass(module = "orbit_rs._native", unsendable)]
struct NativeEnv {
    env: BoxedVecEnv,
    name: String,
    backend: String,
    black_box: bool,
    /// What built it, to build it again with another seed.
    configs: RunConfigs,
    overrides: Vec<String>,
    black_box_overrides: Vec<String>,
    /// Wall time spent inside the env's steps, to tell Python's share of a step from Rust's.
    stepping: Duration,
    /// Which backend `sim.backend = "auto"` chose and why (none when the config named one).
    backend_choice: Option<String>,
}

impl NativeEnv {
    /// Builds the envs of `configs` with env and black-box overrides.
    fn build(
        configs: RunConfigs,
        overrides: Vec<String>,
        black_box_overrides: Vec<String>,
        backend: String,
    ) -> PyResult<Self> {
        let (env, _) =
            orbit::make_vec_env(&configs, &overrides, &black_box_overrides, None).map_err(error)?;
        Ok(Self {
            env,
            black_box: configs.black_box.is_some(),
            name: configs.name.clone(),
            backend,
            configs,
            overrides,
            black_box_overrides,
            stepping: Duration::ZERO,
            backend_choice: None,
        })
    }
}

/// A new `[rows, cols]` array of `values`.
fn matrix<'py>(py: Python<'py>, values: &[f32], cols: usize) -> Bound<'py, PyArray2<f32>> {
    let rows = values.len().checked_div(cols).unwrap_or(0);
    let out = PyArray2::<f32>::zeros(py, [rows, cols], false);
    // A new array is C-contiguous and not shared.
    unsafe { out.as_slice_mut() }
        .expect("a new array is contiguous")
        .copy_from_slice(values);
    out
}

/// The rows of `values` (`cols` wide) whose `mask` is set, as a new array.
fn masked_rows<'py>(
    py: Python<'py>,
    values: &[f32],
    cols: usize,
    mask: &[bool],
) -> Bound<'py, PyArray2<f32>> {
    let rows = mask.iter().filter(|&&m| m).count();
    let out = PyArray2::<f32>::zeros(py, [rows, cols], false);
    let mut slice = unsafe { out.as_slice_mut() }.expect("a new array is contiguous");
    for (row, _) in values
        .chunks_exact(cols.max(1))
        .zip(mask)
        .filter(|(_, m)| **m)
    {
        let (head, tail) = slice.split_at_mut(cols);
        head.copy_from_slice(row);
        slice = tail;
    }
    out
}

#[pymethods]
impl NativeEnv {
    /// Number of envs.
    #[getter]
    fn num_envs(&self) -> usize {
        self.env.num_envs()
    }

    /// Width of one env's action.
    #[getter]
    fn num_actions(&self) -> usize {
        self.env.num_actions()
    }

    /// Width of one env's actor observation (group `policy`).
    #[getter]
    fn num_obs(&self) -> usize {
        self.env.num_obs()
    }

    /// Width of one env's critic observation (group `critic`, else `policy`).
    #[getter]
    fn num_critic_obs(&self) -> usize {
        self.env.num_critic_obs()
    }

    /// Steps after which an episode times out.
    #[getter]
    fn max_episode_length(&self) -> u32 {
        self.env.max_episode_length()
    }

    /// The task id, or the env file's name.
    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    /// The physics backend the env runs on.
    #[getter]
    fn backend(&self) -> &str {
        &self.backend
    }

    /// Seconds spent inside the Rust env's steps since the env was built: a step's time as a
    /// Rust program would see it, without the call from Python and the arrays returned.
    #[getter]
    fn step_seconds(&self) -> f64 {
        self.stepping.as_secs_f64()
    }

    /// Which backend `sim.backend = "auto"` chose and why, for the package to log (`None`
    /// when the config or `backend=` named the backend).
    #[getter]
    fn backend_choice(&self) -> Option<&str> {
        self.backend_choice.as_deref()
    }

    /// Each action value's raw range beyond which it acts the same: `(low, high)`, new
    /// `float32` arrays `[num_actions]` (infinite where nothing saturates it).
    fn action_bounds<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<f32>>) {
        let (low, high): (Vec<f32>, Vec<f32>) = self.env.action_bounds().into_iter().unzip();
        (PyArray1::from_vec(py, low), PyArray1::from_vec(py, high))
    }

    /// Whether one step is one movement primitive (a black-box task).
    #[getter]
    fn black_box(&self) -> bool {
        self.black_box
    }

    /// Actor observations, a new `float32` array `[num_envs, num_obs]`.
    fn observations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        matrix(py, self.env.observations(), self.env.num_obs())
    }

    /// Critic observations, a new `float32` array `[num_envs, num_critic_obs]`.
    fn critic_observations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        matrix(
            py,
            self.env.critic_observations(),
            self.env.num_critic_obs(),
        )
    }

    /// The same envs built again from `seed` (the env's random streams start from it).
    fn reseeded(&self, seed: u64) -> PyResult<Self> {
        let mut overrides = self.overrides.clone();
        overrides.push(format!("seed={seed}"));
        let bb = self.black_box_overrides.clone();
        Self::build(self.configs.clone(), overrides, bb, self.backend.clone())
    }

    /// Steps each env has taken in its episode, a new `uint32` array.
    fn episode_lengths<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let lengths = self.env.episode_lengths().map_err(error)?;
        Ok(PyArray1::from_slice(py, lengths))
    }

    /// Moves each env to step `lengths[i]` of its episode (RSL-RL's random start).
    fn set_episode_lengths(&mut self, lengths: numpy::PyReadonlyArray1<'_, u32>) -> PyResult<()> {
        self.env
            .set_episode_lengths(lengths.as_slice()?)
            .map_err(error)
    }

    /// Resets the listed envs alone (gymnasium's `reset_mask`); the others keep their state.
    fn reset_envs(&mut self, env_ids: Vec<usize>) -> PyResult<()> {
        self.env.reset_envs(&env_ids).map_err(error)
    }

    /// Resets every env.
    fn reset(&mut self) -> PyResult<()> {
        self.env.reset().map_err(error)
    }

    /// Keeps the observations each finished episode ended in (see `final_observations`).
    fn keep_final_observations(&mut self, keep: bool) {
        self.env.keep_final_observations(keep);
    }

    /// The actor (or, with `critic`, critic) observations the episodes that ended in the last
    /// step ended in, one row per env whose `mask` entry is set, in env order; `None` unless
    /// kept.
    #[pyo3(signature = (mask, critic = false))]
    fn final_observations<'py>(
        &self,
        py: Python<'py>,
        mask: numpy::PyReadonlyArray1<'py, bool>,
        critic: bool,
    ) -> PyResult<Option<Bound<'py, PyArray2<f32>>>> {
        let mask = mask.as_slice()?;
        if mask.len() != self.env.num_envs() {
            return Err(PyValueError::new_err(format!(
                "the mask has {} entries, the env {}",
                mask.len(),
                self.env.num_envs()
            )));
        }
        let (values, cols) = if critic {
            (
                self.env.final_critic_observations(),
                self.env.num_critic_obs(),
            )
        } else {
            (self.env.final_observations(), self.env.num_obs())
        };
        Ok(values.map(|v| masked_rows(py, v, cols, mask)))
    }

    /// Applies one action per env (`float32`, C-contiguous, `[num_envs, num_actions]`) and
    /// advances one step. Returns new arrays `(rewards, terminated, time_outs)`, the episode
    /// statistics of the envs that finished (a dict, empty if none did) and the env steps
    /// each env took.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<(
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
        BTreeMap<String, f32>,
        u32,
    )> {
        let (n, a) = (self.env.num_envs(), self.env.num_actions());
        if actions.shape() != [n, a] {
            return Err(PyValueError::new_err(format!(
                "actions have shape {:?}; the env takes ({n}, {a}): one row of {a} per env",
                actions.shape()
            )));
        }
        let start = Instant::now();
        let step = self.env.step(actions.as_slice()?).map_err(error)?;
        self.stepping += start.elapsed();
        Ok((
            PyArray1::from_slice(py, step.rewards),
            PyArray1::from_slice(py, step.terminated),
            PyArray1::from_slice(py, step.time_outs),
            step.log.clone(),
            step.interactions,
        ))
    }
}

/// Builds the envs of a registered task (or of the env file `config`), as `train` builds them:
/// the task's black-box wrapper, if it has one, around its step-based env.
#[pyfunction]
#[pyo3(signature = (task = None, *, num_envs = None, backend = None, seed = None, overrides = Vec::new(), config = None, black_box_overrides = Vec::new()))]
fn make(
    task: Option<&str>,
    num_envs: Option<usize>,
    backend: Option<&str>,
    seed: Option<u64>,
    overrides: Vec<String>,
    config: Option<PathBuf>,
    black_box_overrides: Vec<String>,
) -> PyResult<NativeEnv> {
    orbit::link_registrations();
    if task.is_none() && config.is_none() {
        return Err(PyValueError::new_err(
            "name a registered task (orbit_rs.tasks() lists them) or an env config file",
        ));
    }
    let configs = RunConfigs::resolve(task, orbit::DEFAULT_TASK, config.as_deref(), None, None)
        .map_err(error)?;
    let user: Vec<String> = overrides.iter().map(|o| orbit::env_override(o)).collect();
    let mut overrides = orbit::run_overrides(num_envs, seed, backend, &user);
    let choice = orbit::pick_run_backend(&configs.env, &mut overrides).map_err(error)?;
    let line = orbit::backend_choice_line(&choice);
    let mut env = NativeEnv::build(configs, overrides, black_box_overrides, choice.name)?;
    env.backend_choice = line;
    Ok(env)
}

/// The `orbit_rs._native` module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(make, m)?)?;
    m.add_function(wrap_pyfunction!(tasks, m)?)?;
    m.add_class::<NativeEnv>()?;
    m.add("OrbitError", m.py().get_type::<OrbitError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

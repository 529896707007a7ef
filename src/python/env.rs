//! `EnvBatch`: the native env batch behind the Python envs, built from a
//! `ResolvedConfig`. Each call converts, calls the core's [`EnvBatch`] of the
//! configuration's scene and hands back fresh NumPy arrays that the core wrote into
//! directly. Batch steps and resets release the GIL; `step_one` (a single env, about
//! a microsecond) keeps it, since releasing and re-taking it would cost a sizeable
//! part of the step.

use super::config::{resolve, ResolvedConfig, SceneTask};
use super::convert::{check_shape, error, shape_text, type_error, ActionSlice, Actions, Floats};
use super::reality::{param_arrays, params_dict, write_rig_arrays};
use crate::env::EnvParams;
use crate::env::{
    AutoresetMode, CheckedTask, EnvBatch, EpisodeEnds, Real, Snapshot, StepOutputs, DIAGNOSTICS,
    RNG_BYTES,
};
use crate::geometry::{Planar, Spatial};
use crate::lanes::{LaneScene, Precision};
use numpy::{
    Element, PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

/// The env batch of the configuration's scene.
enum SceneEnvBatch {
    Spatial(EnvBatch<Spatial>),
    Planar(EnvBatch<Planar>),
}

/// Runs `$body` with `$b` bound to the env batch inside `$batch` (a `SceneEnvBatch`).
macro_rules! scene {
    ($batch:expr, $b:ident => $body:expr) => {
        dispatch!(SceneEnvBatch, $batch, $b => $body)
    };
}

/// `(num_envs, seed, mode, diagnostics)` of a new batch.
type BatchShape = (usize, u64, AutoresetMode, bool);

/// A batch of `task`'s envs, built without checking the task again.
fn env_batch<G: LaneScene>(
    task: &CheckedTask<G>,
    (num_envs, seed, mode, diagnostics): BatchShape,
) -> crate::error::Result<EnvBatch<G>> {
    EnvBatch::from_checked(task.clone(), num_envs, seed, mode, diagnostics)
}

/// The native env batch (Python name `EnvBatch`); its shape and mode never change.
#[pyclass(module = "chaincart_env._core", name = "EnvBatch")]
pub struct PyEnvBatch {
    batch: SceneEnvBatch,
    num_envs: usize,
    state_dim: usize,
    /// Numbers per observation: the state, then the target's signs when observed.
    obs_dim: usize,
    force_dim: usize,
    n_links: usize,
    planar: bool,
    mode: AutoresetMode,
    obs_f64: bool,
    /// The resolved configuration it was built from.
    config: Py<ResolvedConfig>,
}

fn new_array<'py, T: Element>(py: Python<'py>, shape: &[usize]) -> Bound<'py, PyArrayDyn<T>> {
    PyArrayDyn::<T>::zeros(py, shape, false)
}

/// `(obs, rewards, terminated, truncated, n_ended)` of a batch step.
type StepArrays<'py, T> = (
    Bound<'py, PyArrayDyn<T>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<bool>>,
    Bound<'py, PyArrayDyn<bool>>,
    usize,
);

/// Runs one batch step writing into fresh arrays of shape `obs_shape` / `(n,)`.
fn step_into<'py, G: LaneScene, T: Element + Real>(
    py: Python<'py>,
    batch: &mut EnvBatch<G>,
    actions: &Actions<'py>,
    obs_shape: &[usize],
) -> PyResult<StepArrays<'py, T>> {
    let n = batch.num_envs();
    let obs = new_array::<T>(py, obs_shape);
    let rewards = new_array::<f64>(py, &[n]);
    let terminated = new_array::<bool>(py, &[n]);
    let truncated = new_array::<bool>(py, &[n]);
    let ended = {
        let (mut o, mut r, mut te, mut tr) = (
            obs.readwrite(),
            rewards.readwrite(),
            terminated.readwrite(),
            truncated.readwrite(),
        );
        let contiguous = |e: numpy::NotContiguousError| error(e.to_string());
        let out = StepOutputs {
            obs: o.as_slice_mut().map_err(contiguous)?,
            rewards: r.as_slice_mut().map_err(contiguous)?,
            terminated: te.as_slice_mut().map_err(contiguous)?,
            truncated: tr.as_slice_mut().map_err(contiguous)?,
        };
        let slice = actions.slice();
        py.detach(|| match &slice {
            ActionSlice::F32(a) => batch.step(a, out),
            ActionSlice::F64(a) => batch.step(a, out),
        })?
    };
    Ok((obs, rewards, terminated, truncated, ended))
}

/// One step of a batch of one, returning `(obs, reward, terminated, truncated, events)`.
fn step_one_into<'py, G: LaneScene, T: Element + Real>(
    py: Python<'py>,
    batch: &mut EnvBatch<G>,
    action: &Actions<'py>,
    obs_shape: &[usize],
) -> PyResult<Bound<'py, PyTuple>> {
    let obs = new_array::<T>(py, obs_shape);
    let (mut reward, mut terminated, mut truncated) = ([0.0], [false], [false]);
    {
        let mut o = obs.readwrite();
        let out = StepOutputs {
            obs: o.as_slice_mut().map_err(|e| error(e.to_string()))?,
            rewards: &mut reward,
            terminated: &mut terminated,
            truncated: &mut truncated,
        };
        match action.slice() {
            ActionSlice::F32(a) => batch.step(&a, out)?,
            ActionSlice::F64(a) => batch.step(&a, out)?,
        };
    }
    (
        obs,
        reward[0],
        terminated[0],
        truncated[0],
        batch.events()[0],
    )
        .into_pyobject(py)
}

fn reset_into<'py, G: LaneScene, T: Element + Real>(
    py: Python<'py>,
    batch: &mut EnvBatch<G>,
    seeds: Option<&[Option<u64>]>,
    mask: Option<&[bool]>,
    obs_shape: &[usize],
) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
    let obs = new_array::<T>(py, obs_shape);
    {
        let mut o = obs.readwrite();
        let o = o.as_slice_mut().map_err(|e| error(e.to_string()))?;
        py.detach(|| batch.reset(seeds, mask, o))?;
    }
    Ok(obs)
}

impl PyEnvBatch {
    fn obs_shape(&self, single: bool) -> Vec<usize> {
        if single {
            vec![self.obs_dim]
        } else {
            vec![self.num_envs, self.obs_dim]
        }
    }
    fn states_shape(&self) -> [usize; 2] {
        [self.num_envs, self.state_dim]
    }
    fn check_single(&self) -> PyResult<()> {
        if self.num_envs == 1 {
            Ok(())
        } else {
            Err(error(format!(
                "step_one/reset_one need num_envs = 1, this batch has {}",
                self.num_envs
            )))
        }
    }
}

#[pymethods]
impl PyEnvBatch {
    /// A batch of `num_envs` envs of `config`: a `ResolvedConfig`, or a dict of
    /// configuration keys (any subset; `scene` names the scene whose values fill the
    /// rest), resolved here.
    #[new]
    #[pyo3(signature = (config, num_envs=1, *, autoreset_mode="next_step", seed=0))]
    fn new(
        config: &Bound<'_, PyAny>,
        num_envs: usize,
        autoreset_mode: &str,
        seed: u64,
    ) -> PyResult<Self> {
        let py = config.py();
        let config: Py<ResolvedConfig> = match config.cast::<ResolvedConfig>() {
            Ok(resolved) => resolved.clone().unbind(),
            Err(_) => Py::new(py, resolve(config.cast::<PyDict>()?)?)?,
        };
        let resolved = config.get();
        let mode = AutoresetMode::from_name(autoreset_mode)?;
        // Built from the task checked at resolve: nothing is checked again.
        let build = (num_envs, seed, mode, resolved.diagnostics);
        let batch = match &resolved.checked {
            SceneTask::Spatial(t) => SceneEnvBatch::Spatial(env_batch(t, build)?),
            SceneTask::Planar(t) => SceneEnvBatch::Planar(env_batch(t, build)?),
        };
        let chain = resolved.chain();
        Ok(Self {
            batch,
            num_envs,
            state_dim: chain.state_dim(),
            obs_dim: resolved.task().obs_dim(chain.state_dim()),
            force_dim: chain.force_dim(),
            n_links: chain.n_links(),
            planar: chain.is_planar(),
            mode,
            obs_f64: resolved.obs_f64,
            config,
        })
    }

    #[getter]
    fn num_envs(&self) -> usize {
        self.num_envs
    }
    #[getter]
    fn state_dim(&self) -> usize {
        self.state_dim
    }
    /// Numbers per observation: `state_dim`, plus `n_links` target signs when the task
    /// observes its goal.
    #[getter]
    fn obs_dim(&self) -> usize {
        self.obs_dim
    }
    /// Each env's target signs for its current episode, shape `(num_envs, n_links)`
    /// (goal-conditioned tasks draw them at every reset).
    fn targets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut v = Vec::with_capacity(self.num_envs * self.n_links);
        for k in 0..self.num_envs {
            v.extend_from_slice(scene!(&self.batch, b => b.env_target(k))?);
        }
        Ok(PyArray1::from_vec(py, v)
            .reshape([self.num_envs, self.n_links])?
            .into_any())
    }
    #[getter]
    fn force_dim(&self) -> usize {
        self.force_dim
    }
    #[getter]
    fn planar(&self) -> bool {
        self.planar
    }
    #[getter]
    fn obs_dtype(&self) -> &'static str {
        if self.obs_f64 {
            "float64"
        } else {
            "float32"
        }
    }
    #[getter]
    fn autoreset_mode(&self) -> &'static str {
        self.mode.name()
    }
    #[getter]
    fn diagnostics_enabled(&self) -> bool {
        scene!(&self.batch, b => b.diagnostics_enabled())
    }
    /// Every configuration key's value, in canonical form, as a new dict.
    #[getter]
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.config.get().canonical.bind(py).copy()
    }

    /// The true parameters the envs share before randomisation (the model's, with
    /// `params` and `mismatch` applied), as a dict.
    fn true_params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        params_dict(py, scene!(&self.batch, b => b.true_params()))
    }
    /// Env `env`'s current true parameters (its own draw when randomised), as a dict.
    /// With joint damping or cart friction drawn per episode, the env's draws too.
    fn env_params<'py>(&self, py: Python<'py>, env: usize) -> PyResult<Bound<'py, PyDict>> {
        let d = params_dict(py, &scene!(&self.batch, b => b.env_params(env))?)?;
        if scene!(&self.batch, b => b.draws_rig()) {
            let rig = scene!(&self.batch, b => b.env_rig(env))?;
            d.set_item("joint_damping", rig.joint_damping)?;
            d.set_item("cart_viscous_friction", rig.cart_viscous_friction)?;
            d.set_item("cart_coulomb_friction", rig.cart_coulomb_friction)?;
        }
        Ok(d)
    }
    /// Every env's current true parameters as a dict of arrays with a leading
    /// `num_envs` axis (`cart_mass`, `gravity`: `(num_envs,)`; `link_masses`,
    /// `link_lengths`: `(num_envs, n_links)`; with rig effects drawn per episode also
    /// `joint_damping` `(num_envs, n_links)` and the cart frictions `(num_envs,)`).
    fn param_arrays<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        match scene!(&self.batch, b => b.per_env_params()) {
            Some(p) => param_arrays(py, p),
            None => param_arrays(
                py,
                &EnvParams::filled(scene!(&self.batch, b => b.true_params()), self.num_envs),
            ),
        }
    }
    /// The state episodes start from before noise.
    #[getter]
    fn base_state<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, scene!(&self.batch, b => b.base_state()))
    }

    /// Starts new episodes (in the envs where `mask` is true, all if `None`), env k
    /// reseeded with `seeds[k]` unless that is `None`; returns every env's observation.
    #[pyo3(signature = (seeds=None, mask=None))]
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seeds: Option<Vec<Option<u64>>>,
        mask: Option<PyReadonlyArray1<'py, bool>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mask = match &mask {
            Some(m) => Some(m.as_slice().map_err(|e| error(e.to_string()))?),
            None => None,
        };
        let shape = self.obs_shape(false);
        let seeds = seeds.as_deref();
        Ok(if self.obs_f64 {
            scene!(&mut self.batch, b => reset_into::<_, f64>(py, b, seeds, mask, &shape))?
                .into_any()
        } else {
            scene!(&mut self.batch, b => reset_into::<_, f32>(py, b, seeds, mask, &shape))?
                .into_any()
        })
    }

    /// `reset` for a batch of one: returns the observation of shape `(state_dim,)`.
    #[pyo3(signature = (seed=None))]
    fn reset_one<'py>(
        &mut self,
        py: Python<'py>,
        seed: Option<u64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.check_single()?;
        let shape = self.obs_shape(true);
        let seeds = [seed];
        Ok(if self.obs_f64 {
            scene!(&mut self.batch, b => reset_into::<_, f64>(py, b, Some(&seeds), None, &shape))?
                .into_any()
        } else {
            scene!(&mut self.batch, b => reset_into::<_, f32>(py, b, Some(&seeds), None, &shape))?
                .into_any()
        })
    }

    /// One step of every env; `actions` of shape `(num_envs, force_dim)`. Returns
    /// `(obs, rewards, terminated, truncated, n_ended)`.
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let expected = [self.num_envs, self.force_dim];
        let extracted = Actions::extract(actions)?;
        if extracted.shape().is_empty() {
            // A scalar cannot be split over the envs: a TypeError, as Gymnasium's and
            // SB3's vector envs raise when they index into it.
            return Err(type_error(format!(
                "actions = {}: expected an array of shape {}, not a scalar",
                actions.repr()?,
                shape_text(&expected)
            )));
        }
        check_shape("actions", extracted.shape(), &expected)?;
        let shape = self.obs_shape(false);
        if self.obs_f64 {
            let (o, r, te, tr, n) =
                scene!(&mut self.batch, b => step_into::<_, f64>(py, b, &extracted, &shape))?;
            (o, r, te, tr, n).into_pyobject(py)
        } else {
            let (o, r, te, tr, n) =
                scene!(&mut self.batch, b => step_into::<_, f32>(py, b, &extracted, &shape))?;
            (o, r, te, tr, n).into_pyobject(py)
        }
    }

    /// `step` for a batch of one: `action` of shape `(force_dim,)`; returns
    /// `(obs, reward, terminated, truncated, events)` with Python scalars.
    fn step_one<'py>(
        &mut self,
        py: Python<'py>,
        action: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        self.check_single()?;
        let actions = Actions::extract(action)?;
        check_shape("action", actions.shape(), &[self.force_dim])?;
        let shape = self.obs_shape(true);
        Ok(if self.obs_f64 {
            scene!(&mut self.batch, b => step_one_into::<_, f64>(py, b, &actions, &shape))?
        } else {
            scene!(&mut self.batch, b => step_one_into::<_, f32>(py, b, &actions, &shape))?
        })
    }

    /// Event bits of the last step or reset, shape `(num_envs,)` (see `EVENT_*`).
    fn events<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u8>> {
        PyArray1::from_slice(py, scene!(&self.batch, b => b.events()))
    }
    /// The episode-end info of the last step as arrays of shape `(num_envs,)`:
    /// `(ended, is_success, numerical_failure, out_of_track, fell, e_q, e_w)`, the last six
    /// false / zero where the episode did not end.
    fn episode_arrays<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let ends = EpisodeEnds::from_events(
            scene!(&self.batch, b => b.events()),
            scene!(&self.batch, b => b.errors()),
        );
        (
            PyArray1::from_vec(py, ends.ended),
            PyArray1::from_vec(py, ends.success),
            PyArray1::from_vec(py, ends.numerical_failure),
            PyArray1::from_vec(py, ends.out_of_track),
            PyArray1::from_vec(py, ends.fell),
            PyArray1::from_vec(py, ends.e_q),
            PyArray1::from_vec(py, ends.e_w),
        )
            .into_pyobject(py)
    }

    /// `(e_q, e_w)` per env after the last step (before any same-step reset), shape
    /// `(num_envs, 2)`.
    fn errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.num_envs;
        Ok(
            PyArray1::from_slice(py, scene!(&self.batch, b => b.errors()))
                .reshape([n, 2])?
                .into_any(),
        )
    }
    /// Same-step mode: observations of the episodes that ended on the last step (rows
    /// of other envs are stale), shape `(num_envs, state_dim)`.
    fn final_observations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let shape = self.obs_shape(false);
        let finals = scene!(&self.batch, b => b.final_states());
        Ok(if self.obs_f64 {
            PyArray1::from_slice(py, finals).reshape(shape)?.into_any()
        } else {
            let v: Vec<f32> = finals.iter().map(|&x| x as f32).collect();
            PyArray1::from_vec(py, v).reshape(shape)?.into_any()
        })
    }
    /// `DIAGNOSTICS` per env of the last step (zeros unless enabled), shape
    /// `(num_envs, 5)`.
    fn diagnostics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.num_envs;
        Ok(
            PyArray1::from_slice(py, scene!(&self.batch, b => b.diagnostics()))
                .reshape([n, DIAGNOSTICS.len()])?
                .into_any(),
        )
    }
    /// Every env's current observation (its state, or its last reading when `obs_noise`
    /// or an encoder is set), shape `(num_envs, obs_dim)`.
    fn observations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let shape = self.obs_shape(false);
        let n = self.num_envs * self.obs_dim;
        Ok(if self.obs_f64 {
            let mut v = vec![0.0f64; n];
            scene!(&self.batch, b => b.write_obs(&mut v))?;
            PyArray1::from_vec(py, v).reshape(shape)?.into_any()
        } else {
            let mut v = vec![0.0f32; n];
            scene!(&self.batch, b => b.write_obs(&mut v))?;
            PyArray1::from_vec(py, v).reshape(shape)?.into_any()
        })
    }
    /// A copy of every env's float64 state, shape `(num_envs, state_dim)`.
    fn states<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(
            PyArray1::from_slice(py, scene!(&self.batch, b => b.states()))
                .reshape(self.states_shape())?
                .into_any(),
        )
    }
    /// Steps taken in each env's current episode.
    fn step_counts<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u64>> {
        let v: Vec<u64> = (0..self.num_envs)
            .map(|k| scene!(&self.batch, b => b.step_count(k)))
            .collect();
        PyArray1::from_vec(py, v)
    }
    /// Which envs' episodes have ended without a reset since.
    fn ended<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        let v: Vec<bool> = (0..self.num_envs)
            .map(|k| scene!(&self.batch, b => b.has_ended(k)))
            .collect();
        PyArray1::from_vec(py, v)
    }
    /// Overwrites env `env`'s state (checked: length, finite, on the constraint manifold).
    fn set_state(&mut self, env: usize, state: Floats<'_>) -> PyResult<()> {
        let y = super::convert::vector("state", &state, self.state_dim)?;
        Ok(scene!(&mut self.batch, b => b.set_state(env, &y))?)
    }

    /// Everything that evolves (states, RNG streams, step counts, ended flags) as a dict
    /// of arrays, for `restore`.
    fn snapshot<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = scene!(&self.batch, b => b.snapshot());
        let n = self.num_envs;
        let d = PyDict::new(py);
        d.set_item(
            "states",
            PyArray1::from_vec(py, s.states).reshape(self.states_shape())?,
        )?;
        let rng: Vec<u8> = s.rng.iter().flatten().copied().collect();
        d.set_item("rng", PyArray1::from_vec(py, rng).reshape([n, RNG_BYTES])?)?;
        d.set_item("steps", PyArray1::from_vec(py, s.steps))?;
        d.set_item("ended", PyArray1::from_vec(py, s.ended))?;
        d.set_item("held", PyArray1::from_vec(py, s.held))?;
        d.set_item("caught", PyArray1::from_vec(py, s.caught))?;
        d.set_item("goal", PyArray1::from_vec(py, s.goal))?;
        d.set_item("action_delays", PyArray1::from_vec(py, s.action_delays))?;
        let rng_array = |rows: &[[u8; RNG_BYTES]]| {
            let flat: Vec<u8> = rows.iter().flatten().copied().collect();
            PyArray1::from_vec(py, flat).reshape([rows.len(), RNG_BYTES])
        };
        d.set_item("param_rng", rng_array(&s.param_rng)?)?;
        d.set_item("noise_rng", rng_array(&s.noise_rng)?)?;
        d.set_item("force_rng", rng_array(&s.force_rng)?)?;
        let p = &s.params;
        let params = PyDict::new(py);
        params.set_item("cart_mass", PyArray1::from_slice(py, &p.cart_mass))?;
        params.set_item("link_masses", PyArray1::from_slice(py, &p.link_masses))?;
        params.set_item("link_lengths", PyArray1::from_slice(py, &p.link_lengths))?;
        params.set_item("gravity", PyArray1::from_slice(py, &p.gravity))?;
        write_rig_arrays(py, p, &params, None)?;
        d.set_item("env_params", params)?;
        d.set_item("noisy_obs", PyArray1::from_vec(py, s.noisy_obs))?;
        d.set_item("action_queue", PyArray1::from_vec(py, s.action_queue))?;
        d.set_item("last_force", PyArray1::from_vec(py, s.last_force))?;
        Ok(d)
    }

    /// Continues from a `snapshot` of a batch with the same num_envs and state_dim.
    fn restore(&mut self, snapshot: &Bound<'_, PyDict>) -> PyResult<()> {
        let n = self.num_envs;
        let get = |key: &str| -> PyResult<Bound<'_, PyAny>> {
            snapshot
                .get_item(key)?
                .ok_or_else(|| error(format!("snapshot has no {key:?} entry")))
        };
        let states: PyReadonlyArray2<'_, f64> = get("states")?.extract()?;
        check_shape("snapshot states", states.shape(), &self.states_shape())?;
        let rng: PyReadonlyArray2<'_, u8> = get("rng")?.extract()?;
        check_shape("snapshot rng", rng.shape(), &[n, RNG_BYTES])?;
        let steps: PyReadonlyArray1<'_, u64> = get("steps")?.extract()?;
        let ended: PyReadonlyArray1<'_, bool> = get("ended")?.extract()?;
        let held: PyReadonlyArray1<'_, u32> = get("held")?.extract()?;
        // A snapshot taken before the fall's hold time existed flags a catch: one step.
        let caught_item = get("caught")?;
        let caught: Vec<u16> = match caught_item.extract::<PyReadonlyArray1<'_, u16>>() {
            Ok(counts) => counts.as_array().to_vec(),
            Err(_) => {
                let flags: PyReadonlyArray1<'_, bool> = caught_item.extract()?;
                flags.as_array().iter().map(|&f| u16::from(f)).collect()
            }
        };
        let goal: PyReadonlyArray1<'_, u16> = get("goal")?.extract()?;
        // A snapshot taken before per-episode delays existed has none: the fixed delay.
        let action_delays = match snapshot.get_item("action_delays")? {
            Some(value) => value
                .extract::<PyReadonlyArray1<'_, u32>>()?
                .as_array()
                .to_vec(),
            None => {
                let fixed = scene!(&self.batch, b => b.task().reality.action_delay);
                vec![fixed as u32; n]
            }
        };
        let rng_rows = |a: &PyReadonlyArray2<'_, u8>| -> Vec<[u8; RNG_BYTES]> {
            a.as_array()
                .rows()
                .into_iter()
                .map(|r| {
                    let mut b = [0u8; RNG_BYTES];
                    for (x, y) in b.iter_mut().zip(r.iter()) {
                        *x = *y;
                    }
                    b
                })
                .collect()
        };
        let floats = |value: Bound<'_, PyAny>| -> PyResult<Vec<f64>> {
            let a: PyReadonlyArray1<'_, f64> = value.extract()?;
            Ok(a.as_array().to_vec())
        };
        let param_rng: PyReadonlyArray2<'_, u8> = get("param_rng")?.extract()?;
        let noise_rng: PyReadonlyArray2<'_, u8> = get("noise_rng")?.extract()?;
        // A snapshot taken before force noise existed has no stream: right when it is off.
        let force_rng = match snapshot.get_item("force_rng")? {
            Some(value) => rng_rows(&value.extract()?),
            None => Vec::new(),
        };
        let env_params = get("env_params")?;
        let param = |key: &str| floats(env_params.get_item(key)?);
        let mut params = EnvParams::empty(self.n_links);
        params.cart_mass = param("cart_mass")?;
        params.link_masses = param("link_masses")?;
        params.link_lengths = param("link_lengths")?;
        params.gravity = param("gravity")?;
        // Rig effects drawn per env: present only in a snapshot of such a batch.
        if env_params.contains("cart_coulomb_friction")? {
            params.joint_damping = param("joint_damping")?;
            params.cart_viscous_friction = param("cart_viscous_friction")?;
            params.cart_coulomb_friction = param("cart_coulomb_friction")?;
        }
        let snap = Snapshot {
            states: states.as_array().iter().copied().collect(),
            rng: rng_rows(&rng),
            steps: steps.as_array().to_vec(),
            ended: ended.as_array().to_vec(),
            held: held.as_array().to_vec(),
            caught,
            goal: goal.as_array().to_vec(),
            action_delays,
            param_rng: rng_rows(&param_rng),
            noise_rng: rng_rows(&noise_rng),
            params,
            noisy_obs: floats(get("noisy_obs")?)?,
            action_queue: floats(get("action_queue")?)?,
            last_force: floats(get("last_force")?)?,
            force_rng,
        };
        Ok(scene!(&mut self.batch, b => b.restore(&snap))?)
    }

    fn __repr__(&self) -> String {
        format!(
            "EnvBatch(num_envs={}, state_dim={}, planar={}, autoreset_mode={:?})",
            self.num_envs,
            self.state_dim,
            if self.planar { "True" } else { "False" },
            self.mode.name()
        )
    }

    /// Steps the physics in `"f64"` (the default: every env bit-identical to a single
    /// env) or `"f32"` (the rk4 lane kernel in single precision: faster, within the
    /// accuracy published in docs/simd.md). Observations keep their dtype.
    fn set_precision(&mut self, precision: &str) -> PyResult<()> {
        Ok(scene!(&mut self.batch, b => b.set_precision(Precision::from_name(precision)?))?)
    }

    /// `"f64"` or `"f32"`: the number type of the physics (see `set_precision`).
    #[getter]
    fn precision(&self) -> &'static str {
        scene!(&self.batch, b => b.precision()).name()
    }
}

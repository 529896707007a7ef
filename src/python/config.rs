//! The configuration from Python: the core's key table and scenes as Python values
//! (`_core.CONFIG_KEYS`, `_core.SCENES`, ...) and the one conversion of a dict of
//! keys into the core's chain and task, checked once and handed back as one native
//! object ([`ResolvedConfig`]) that the envs' batches are built from. Every check is
//! the core's (or reads its accepted form from the key table); Python only brings
//! values into plain types.

use super::convert::{error, signs, type_error};
use super::model::{lqr_weights, matrix_to_numpy, state_space_tuple, ChainCart};
use super::reality::{reality_gap, write_task_keys, RealityArgs};
use crate::analysis::{controllability_with_rig, Linearization, LqrController};
use crate::any_chain::AnyChain;
use crate::env::{
    config_key, CheckedTask, ConfigKey, Destination, Ends, KeyKind, KeyValue, Scene, Start,
    TaskConfig, Transitions, Value, ANY, CONFIG_KEYS, KEY_NAMES, SCENES,
};
use crate::error::{quoted, InputError};
use crate::geometry::{Planar, Spatial};
use crate::integrate::StepOptions;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyMapping, PyString, PyTuple};
use std::collections::HashMap;

/// A configuration resolved, converted and checked once: the model, the task on it and
/// every key's value in canonical form. Envs build their batches from it.
#[pyclass(frozen, module = "chaincart_env._core", name = "ResolvedConfig")]
pub struct ResolvedConfig {
    /// The model (immutable, shared with whoever asks for it).
    pub model: Py<ChainCart>,
    /// The task on it, checked once: batches are built from it without checking again.
    pub checked: SceneTask,
    /// Observations as float64 (else float32).
    pub obs_f64: bool,
    /// Energies and residuals recorded every step.
    pub diagnostics: bool,
    /// Every key's value in canonical form (resolving it again gives the same config).
    pub canonical: Py<PyDict>,
}

/// A task checked on the planar or the spatial model.
#[derive(Clone)]
pub enum SceneTask {
    /// On the spatial model.
    Spatial(CheckedTask<Spatial>),
    /// On the planar model.
    Planar(CheckedTask<Planar>),
}

impl ResolvedConfig {
    /// The model's chain.
    pub fn chain(&self) -> &AnyChain {
        &self.model.get().chain
    }

    /// The task.
    pub fn task(&self) -> &TaskConfig {
        dispatch!(SceneTask, &self.checked, c => c.task())
    }

    /// A validated sign tuple (or equilibrium name) for this chain.
    fn equilibrium_signs(&self, s: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        let n = self.chain().n_links();
        let s = signs(s, n)?;
        crate::analysis::check_signs(&s, n)?;
        Ok(s)
    }
}

#[pymethods]
impl ResolvedConfig {
    /// Every configuration key's value, in canonical form, as a new dict.
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.canonical.bind(py).copy()
    }
    /// The model of the configuration's physical parameters (a `ChainCart`).
    #[getter]
    fn model(&self, py: Python<'_>) -> Py<ChainCart> {
        self.model.clone_ref(py)
    }
    /// Length of the observed state: `2 + 3n` planar, `4 + 6n` spatial.
    #[getter]
    fn state_dim(&self) -> usize {
        self.chain().state_dim()
    }
    /// Length of an action: 1 planar, 2 spatial.
    #[getter]
    fn force_dim(&self) -> usize {
        self.chain().force_dim()
    }
    /// The target's signs (for a goal-conditioned task, the first pair's).
    #[getter]
    fn target(&self) -> Vec<f64> {
        self.task().target.clone()
    }
    /// The (start, target) sign lists a goal-conditioned task draws from, or `None`.
    #[getter]
    fn pairs(&self) -> Option<Vec<(Vec<f64>, Vec<f64>)>> {
        self.task().transitions.as_ref().map(|t| {
            (0..t.len())
                .map(|k| (t.start(k).to_vec(), t.target(k).to_vec()))
                .collect()
        })
    }
    /// Length of an observation: `state_dim`, plus `n_links` target signs when the task
    /// observes its goal (`goal_observation`).
    #[getter]
    fn obs_dim(&self) -> usize {
        self.task().obs_dim(self.chain().state_dim())
    }
    /// The LQR gain at equilibrium `s` (`2 x (4 + 4n)`, in `z` coordinates) for the
    /// model with this configuration's real-rig effects (joint damping, cart friction,
    /// actuation): `u = -K z` is the command of the actuation, per cart axis (N, m/s^2
    /// or V). `Q`, `R` default to the paper's weights.
    #[pyo3(signature = (s, Q=None, R=None))]
    #[allow(non_snake_case)]
    fn lqr_gain<'py>(
        &self,
        py: Python<'py>,
        s: &Bound<'py, PyAny>,
        Q: Option<&Bound<'py, PyAny>>,
        R: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let s = self.equilibrium_signs(s)?;
        let weights = lqr_weights(&s, Q, R)?;
        let params = self.chain().params().clone();
        let rig = self.task().rig.clone();
        let controller = py.detach(|| LqrController::with_rig(&params, &s, &rig, &weights))?;
        Ok(matrix_to_numpy(py, controller.gain()))
    }
    /// Controllability at equilibrium `s` with this configuration's real-rig effects
    /// (paper Prop. 3, joint damping included): `(controllable, margin)`.
    fn controllability(&self, py: Python<'_>, s: &Bound<'_, PyAny>) -> PyResult<(bool, f64)> {
        let s = self.equilibrium_signs(s)?;
        let params = self.chain().params().clone();
        let rig = self.task().rig.clone();
        let c = py.detach(|| controllability_with_rig(&params, &s, &rig))?;
        Ok((c.controllable, c.margin))
    }
    /// The first-order linearisation `(A, B)` at equilibrium `s` with this
    /// configuration's real-rig effects, `B` per unit of the actuation's command
    /// (docs/physics.md, "Real-rig effects").
    fn linearize<'py>(
        &self,
        py: Python<'py>,
        s: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let s = self.equilibrium_signs(s)?;
        state_space_tuple(
            py,
            &Linearization::with_rig(self.chain().params(), &s, &self.task().rig)?,
        )
    }
    /// `model` (this configuration's model, or one with other physical parameters)
    /// with this configuration's real-rig effects: its `step`, `plan` and the plan's
    /// controllers follow the rig, their command the actuation's (N, m/s^2 or V). Its
    /// analysis methods (`linearize`, `lqr_gain`, `controllability`) stay the ideal
    /// chain's; this configuration's own methods count the rig.
    fn rig_model(&self, model: &ChainCart) -> PyResult<ChainCart> {
        let rig = self.task().rig.clone();
        Ok(ChainCart {
            chain: model.chain.clone().with_rig(rig)?,
        })
    }
    /// Pickled as its canonical values, resolved again when loaded.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let resolve = py
            .import("chaincart_env._core")?
            .getattr("resolve_config")?;
        let args = PyTuple::new(py, [self.canonical.bind(py).copy()?])?;
        PyTuple::new(py, [resolve, args.into_any()])
    }
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!(
            "ResolvedConfig({})",
            self.canonical.bind(py).repr()?
        ))
    }
}

/// A table value as a Python value.
fn key_value<'py>(py: Python<'py>, value: KeyValue) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        KeyValue::None => py.None().into_bound(py),
        KeyValue::Int(v) => v.into_pyobject(py)?.into_any(),
        KeyValue::Float(v) => v.into_pyobject(py)?.into_any(),
        KeyValue::Bool(v) => PyBool::new(py, v).to_owned().into_any(),
        KeyValue::Name(v) => PyString::new(py, v).into_any(),
        KeyValue::Floats(v) => PyTuple::new(py, v)?.into_any(),
        KeyValue::Relative(entries) => {
            let d = PyDict::new(py);
            for &(name, h) in entries {
                d.set_item(name, h)?;
            }
            d.into_any()
        }
    })
}

/// Every key's value in `scene`, as a dict in key order.
pub fn scene_values<'py>(py: Python<'py>, scene: &Scene) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for key in CONFIG_KEYS {
        let value = scene.value(key.name).unwrap_or(key.default);
        d.set_item(key.name, key_value(py, value)?)?;
    }
    Ok(d)
}

/// `(name, default, help, expected)` of every key, for `_core.CONFIG_KEYS`.
pub fn keys_table(py: Python<'_>) -> PyResult<Bound<'_, PyTuple>> {
    let rows = CONFIG_KEYS
        .iter()
        .map(|k| {
            PyTuple::new(
                py,
                [
                    PyString::new(py, k.name).into_any(),
                    key_value(py, k.default)?,
                    PyString::new(py, k.help).into_any(),
                    PyString::new(py, k.expected).into_any(),
                ],
            )
        })
        .collect::<PyResult<Vec<_>>>()?;
    PyTuple::new(py, rows)
}

/// `(name, default, help)` of the reality-gap keys, for `_core.REALITY_KEYS`.
pub fn reality_keys_table(py: Python<'_>) -> PyResult<Bound<'_, PyTuple>> {
    let rows = CONFIG_KEYS
        .iter()
        .filter(|k| k.kind == KeyKind::RealityGap)
        .map(|k| (k.name, key_value(py, k.default)?, k.help).into_pyobject(py))
        .collect::<PyResult<Vec<_>>>()?;
    PyTuple::new(py, rows)
}

/// Every scene's values, for `_core.SCENES` (scene name -> dict of every key).
pub fn scenes_table(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    for scene in SCENES {
        d.set_item(scene.name, scene_values(py, scene)?)?;
    }
    Ok(d)
}

/// Every scene's one-line summary, for `_core.SCENE_SUMMARIES`.
pub fn scene_summaries(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    for scene in SCENES {
        d.set_item(scene.name, scene.summary)?;
    }
    Ok(d)
}

/// The names of a named-numbers key mapped to its defaults (`_core.REWARD_WEIGHTS`).
pub fn named_defaults<'py>(py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    if let Some(ConfigKey {
        kind: KeyKind::NamedNumbers(names),
        default: KeyValue::Floats(values),
        ..
    }) = config_key(key)
    {
        for (name, value) in names.iter().zip(values.iter()) {
            d.set_item(name, value)?;
        }
    }
    Ok(d)
}

/// `"{name} = {repr}: expected {what}"`.
fn not_expected(name: &str, value: &Bound<'_, PyAny>, what: &str) -> String {
    let shown = value
        .repr()
        .map(|r| r.to_string())
        .unwrap_or_else(|_| "?".into());
    format!("{name} = {shown}: expected {what}")
}

/// The error of a value of the wrong type (an `InvalidTypeError`).
fn wrong_type(name: &str, value: &Bound<'_, PyAny>, what: &str) -> PyErr {
    type_error(not_expected(name, value, what))
}

/// The error of a value of the wrong form (an `InvalidInputError`).
fn wrong_value(name: &str, value: &Bound<'_, PyAny>, what: &str) -> PyErr {
    error(not_expected(name, value, what))
}

fn is_bool(value: &Bound<'_, PyAny>) -> bool {
    value.is_instance_of::<PyBool>()
}

/// A real number (not a bool).
fn number(name: &str, value: &Bound<'_, PyAny>) -> PyResult<f64> {
    match value.extract::<f64>() {
        Ok(x) if !is_bool(value) && !value.is_instance_of::<PyString>() => Ok(x),
        _ => Err(wrong_type(name, value, "a number")),
    }
}

/// An integer (not a bool); an integral float such as `2.0` counts.
fn integer(name: &str, value: &Bound<'_, PyAny>) -> PyResult<i64> {
    if !is_bool(value) {
        if let Ok(i) = value.extract::<i64>() {
            return Ok(i);
        }
        if let Ok(x) = number(name, value) {
            if x.fract() == 0.0 && x.abs() < 9.0e15 {
                return Ok(x as i64);
            }
        }
    }
    Err(wrong_type(name, value, "an integer"))
}

/// `action_delay`: a fixed delay `(d, None)`, or a range `(low, Some(high))` drawn per
/// episode (a range of one value is that fixed delay).
/// A key that takes one value or a range `(low, high)` (a tuple or list, not a
/// string): `(value, None)` or `(low, Some(high))`, each read by `read`; a sequence of
/// another length is a wrong value, an unreadable item a wrong type.
fn value_or_range<'py, V>(
    name: &str,
    value: &Bound<'py, PyAny>,
    expected: &str,
    read: impl Fn(&str, &Bound<'py, PyAny>) -> PyResult<V>,
) -> PyResult<(V, Option<V>)> {
    let bound =
        |item: &Bound<'py, PyAny>| read(name, item).map_err(|_| wrong_type(name, value, expected));
    let range = !value.is_instance_of::<PyString>()
        && (value.is_instance_of::<PyTuple>() || value.is_instance_of::<pyo3::types::PyList>());
    if !range {
        return Ok((bound(value)?, None));
    }
    let items: Vec<Bound<'py, PyAny>> = value.try_iter()?.collect::<PyResult<_>>()?;
    if items.len() != 2 {
        return Err(wrong_value(name, value, expected));
    }
    Ok((bound(&items[0])?, Some(bound(&items[1])?)))
}

fn action_delay(value: &Bound<'_, PyAny>) -> PyResult<(i64, Option<i64>)> {
    use crate::env::ACTION_DELAY_EXPECTED;
    let name = "action_delay";
    let (low, high) = value_or_range(name, value, ACTION_DELAY_EXPECTED, integer)?;
    if low < 0 || high.is_some_and(|h| h < low) {
        return Err(wrong_value(name, value, ACTION_DELAY_EXPECTED));
    }
    Ok((low, high.filter(|&h| h != low)))
}

/// `force_rate_limit`: a number (N/s) or a range (low, high) drawn per episode, as
/// `(low, Some(high))`; the core checks the values.
fn force_rate_limit(value: &Bound<'_, PyAny>) -> PyResult<(f64, Option<f64>)> {
    use crate::env::FORCE_RATE_LIMIT_EXPECTED;
    value_or_range("force_rate_limit", value, FORCE_RATE_LIMIT_EXPECTED, number)
}

fn flag(name: &str, value: &Bound<'_, PyAny>) -> PyResult<bool> {
    value
        .extract::<bool>()
        .map_err(|_| wrong_type(name, value, "True or False"))
}

/// The numbers of a sequence (not a string), each checked to be a number.
fn sequence(name: &str, value: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    if value.is_instance_of::<PyString>() {
        return Err(wrong_type(name, value, what));
    }
    let items = value
        .try_iter()
        .map_err(|_| wrong_type(name, value, what))?;
    items
        .enumerate()
        .map(|(i, item)| number(&format!("{name}[{i}]"), &item?))
        .collect()
}

fn float_tuple(py: Python<'_>, numbers: Vec<f64>) -> PyResult<Bound<'_, PyAny>> {
    Ok(PyTuple::new(py, numbers)?.into_any())
}

/// `link_masses`/`link_lengths`: a float, or a tuple of floats.
fn per_link<'py>(name: &str, value: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    if !is_bool(value) {
        if let Ok(x) = value.extract::<f64>() {
            return Ok(x.into_pyobject(value.py())?.into_any());
        }
    }
    let numbers = sequence(name, value, "a number or one number per link")?;
    float_tuple(value.py(), numbers)
}

/// `transitions`: a tuple of `(start, target)` pairs, each end a name or a tuple of
/// floats.
fn transition_pairs<'py>(
    key: &ConfigKey,
    value: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let py = value.py();
    if value.is_instance_of::<PyString>() {
        return Err(wrong_type(key.name, value, key.expected));
    }
    let items: Vec<Bound<'py, PyAny>> = value
        .extract()
        .map_err(|_| wrong_type(key.name, value, key.expected))?;
    let mut pairs = Vec::with_capacity(items.len());
    for item in &items {
        let ends: Vec<Bound<'py, PyAny>> = match item.extract() {
            Ok(ends) if !item.is_instance_of::<PyString>() => ends,
            _ => return Err(wrong_type(key.name, item, "a (start, target) pair")),
        };
        if ends.len() != 2 {
            return Err(wrong_value(key.name, item, "a (start, target) pair"));
        }
        let start = name_or_numbers("transitions start", &ends[0])?;
        let target = name_or_numbers("transitions target", &ends[1])?;
        pairs.push(PyTuple::new(py, [start, target])?);
    }
    Ok(PyTuple::new(py, pairs)?.into_any())
}

/// `target`/`start`: a name, or a tuple of floats.
fn name_or_numbers<'py>(name: &str, value: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    if value.is_instance_of::<PyString>() {
        return Ok(value.clone());
    }
    let numbers = sequence(name, value, "a name or a sequence of numbers")?;
    float_tuple(value.py(), numbers)
}

/// A name among `names` (the error lists them).
fn choice<'py>(
    key: &ConfigKey,
    names: &'static [&'static str],
    value: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let name: String = value
        .extract()
        .map_err(|_| wrong_value(key.name, value, key.expected))?;
    if names.contains(&name.as_str()) {
        return Ok(value.clone());
    }
    Err(InputError::UnknownName {
        kind: key.name,
        name,
        expected: names,
    }
    .into())
}

/// Named numbers: a mapping with some of `names` (the rest keep the key's defaults)
/// or a sequence of exactly as many numbers; a tuple of floats.
fn named_numbers<'py>(
    key: &ConfigKey,
    names: &'static [&'static str],
    value: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let mut numbers = match key.default {
        KeyValue::Floats(defaults) => defaults.to_vec(),
        _ => vec![0.0; names.len()],
    };
    if let Ok(mapping) = value.cast::<PyMapping>() {
        for item in mapping.items()?.iter() {
            let (k, v): (Bound<'_, PyAny>, Bound<'_, PyAny>) = item.extract()?;
            let index = k
                .extract::<String>()
                .ok()
                .and_then(|k| names.iter().position(|n| *n == k))
                .ok_or_else(|| {
                    error(format!(
                        "{} has unknown key {}: expected some of {}",
                        key.name,
                        k.repr().map(|r| r.to_string()).unwrap_or_default(),
                        quoted(names)
                    ))
                })?;
            numbers[index] = number(&format!("{}.{}", key.name, names[index]), &v)?;
        }
    } else {
        let given = sequence(key.name, value, key.expected)?;
        if given.len() != names.len() {
            return Err(wrong_type(key.name, value, key.expected));
        }
        numbers = given;
    }
    float_tuple(value.py(), numbers)
}

/// Exactly as many numbers as `names`, in a sequence; a tuple of floats.
fn numbers<'py>(
    key: &ConfigKey,
    names: &'static [&'static str],
    value: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let sized = value.len().is_ok_and(|len| len == names.len());
    if !sized || value.is_instance_of::<PyString>() || value.cast::<PyMapping>().is_ok() {
        return Err(wrong_value(key.name, value, key.expected));
    }
    float_tuple(value.py(), sequence(key.name, value, key.expected)?)
}

/// One key's value in canonical form: plain Python types, checked for type and form.
fn canonical<'py>(key: &ConfigKey, value: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let py = value.py();
    Ok(match key.kind {
        KeyKind::Scene => value.clone(),
        KeyKind::Integer => integer(key.name, value)?.into_pyobject(py)?.into_any(),
        KeyKind::Number => number(key.name, value)?.into_pyobject(py)?.into_any(),
        KeyKind::Flag => PyBool::new(py, flag(key.name, value)?)
            .to_owned()
            .into_any(),
        KeyKind::PerLink => per_link(key.name, value)?,
        KeyKind::Choice(names) => choice(key, names, value)?,
        KeyKind::Equilibrium | KeyKind::Start => name_or_numbers(key.name, value)?,
        KeyKind::NamedNumbers(names) => named_numbers(key, names, value)?,
        KeyKind::Numbers(names) => numbers(key, names, value)?,
        KeyKind::RealityGap if key.name == "action_delay" => match action_delay(value)? {
            (fixed, None) => fixed.into_pyobject(py)?.into_any(),
            (low, Some(high)) => (low, high).into_pyobject(py)?.into_any(),
        },
        KeyKind::RealityGap => value.clone(),
        KeyKind::Transitions => transition_pairs(key, value)?,
    })
}

/// The scene named in `config` (default: the default scene) with `config`'s values on
/// top (`None` values are unset), every value in canonical form, in key order.
fn merged<'py>(config: &Bound<'py, PyDict>) -> PyResult<Bound<'py, PyDict>> {
    let py = config.py();
    for k in config.keys() {
        let name: String = k.extract()?;
        if config_key(&name).is_none() {
            return Err(InputError::UnknownName {
                kind: "config key",
                name,
                expected: KEY_NAMES.as_slice(),
            }
            .into());
        }
    }
    let scene = match config.get_item("scene")?.filter(|s| !s.is_none()) {
        Some(s) => {
            let name: String = s
                .extract()
                .map_err(|_| wrong_value("scene", &s, "a scene name"))?;
            Scene::named(&name)?
        }
        None => Scene::named(crate::env::DEFAULT_SCENE)?,
    };
    let values = scene_values(py, scene)?;
    for (k, v) in config.iter() {
        if !v.is_none() {
            values.set_item(k, v)?;
        }
    }
    let out = PyDict::new(py);
    for key in CONFIG_KEYS {
        let value = values.get_item(key.name)?.expect("every key has a value");
        let value = if value.is_none() {
            value
        } else {
            canonical(key, &value)?
        };
        out.set_item(key.name, value)?;
    }
    Ok(out)
}

fn get<'py>(values: &Bound<'py, PyDict>, name: &str) -> Bound<'py, PyAny> {
    values
        .get_item(name)
        .ok()
        .flatten()
        .expect("merged values hold every key")
}

/// The model of canonical values.
fn model(values: &Bound<'_, PyDict>) -> PyResult<ChainCart> {
    let extract_f64 = |name: &str| get(values, name).extract::<f64>();
    ChainCart::from_params(
        get(values, "n_links").extract()?,
        extract_f64("cart_mass")?,
        &get(values, "link_masses"),
        &get(values, "link_lengths"),
        extract_f64("gravity")?,
        get(values, "planar").extract()?,
    )
}

/// Where episodes start: a name, a sign tuple (length `n`) or a full state.
fn start(value: &Bound<'_, PyAny>, n: usize, state_dim: usize) -> PyResult<Start> {
    if let Ok(name) = value.cast::<PyString>() {
        return Ok(Start::from_name(name.to_str()?, n)?);
    }
    let v: Vec<f64> = value.extract()?;
    if v.len() == n {
        Ok(Start::Equilibrium(v))
    } else if v.len() == state_dim {
        Ok(Start::State(v))
    } else {
        Err(error(format!(
            "start has length {}, expected {n} (a sign tuple) or {state_dim} (a full state)",
            v.len()
        )))
    }
}

/// Whether `value` is the name `any`.
fn is_any(value: &Bound<'_, PyAny>) -> bool {
    value.extract::<String>().is_ok_and(|s| s == ANY)
}

/// The pairs a goal-conditioned task draws from: the `transitions` list, or the pairs
/// `start` and `target` allow when either is `any`; `None` for a fixed task.
fn transitions(
    values: &Bound<'_, PyDict>,
    target: &Bound<'_, PyAny>,
    start_value: &Bound<'_, PyAny>,
    chain: &AnyChain,
) -> PyResult<Option<Transitions>> {
    let n = chain.n_links();
    let list = get(values, "transitions");
    if !list.is_none() {
        let mut pairs = Vec::new();
        for pair in list.try_iter()? {
            let pair = pair?;
            pairs.push((signs(&pair.get_item(0)?, n)?, signs(&pair.get_item(1)?, n)?));
        }
        return Ok(Some(Transitions::from_pairs(n, &pairs)?));
    }
    if !is_any(target) && !is_any(start_value) {
        return Ok(None);
    }
    let target_signs = (!is_any(target)).then(|| signs(target, n)).transpose()?;
    let target_end = target_signs.as_deref().map_or(Ends::Any, Ends::One);
    let at_target = start_value.extract::<String>().is_ok_and(|s| s == "target");
    let start_signs = match () {
        _ if is_any(start_value) || at_target => None,
        _ => match start(start_value, n, chain.state_dim())? {
            Start::Equilibrium(s) => Some(s),
            _ => {
                return Err(error(format!(
                    "start = {}: expected an equilibrium (a name or a sign tuple), \"target\" or \"any\" when the target is \"any\"",
                    start_value.repr()?
                )))
            }
        },
    };
    let start_end = start_signs.as_deref().map_or(Ends::Any, Ends::One);
    Ok(Some(Transitions::between(
        n, start_end, target_end, at_target,
    )?))
}

/// A task field's canonical value as the core's plain [`Value`] (`None`: off).
fn plain_value(key: &ConfigKey, value: &Bound<'_, PyAny>) -> PyResult<Value> {
    if value.is_none() {
        return Ok(Value::Off);
    }
    Ok(match key.kind {
        KeyKind::Integer => Value::Integer(integer(key.name, value)?),
        KeyKind::Number => Value::Number(number(key.name, value)?),
        KeyKind::Flag => Value::Flag(flag(key.name, value)?),
        KeyKind::Choice(_) => Value::Name(value.extract()?),
        KeyKind::PerLink => match value.extract::<f64>() {
            Ok(x) => Value::Number(x),
            Err(_) => Value::Numbers(value.extract()?),
        },
        KeyKind::NamedNumbers(_) | KeyKind::Numbers(_) => Value::Numbers(value.extract()?),
        other => {
            return Err(error(format!(
                "{}: a key of kind {other:?} is resolved with its group, not as a task field",
                key.name
            )))
        }
    })
}

/// The task of canonical values on `chain`: the ends and the reality gap resolved
/// together, every other task key applied by the key table.
fn task(values: &Bound<'_, PyDict>, chain: &AnyChain) -> PyResult<TaskConfig> {
    let n = chain.n_links();
    let (target, start_value) = (get(values, "target"), get(values, "start"));
    let transitions = transitions(values, &target, &start_value, chain)?;
    let target = match &transitions {
        Some(t) => t.target(0).to_vec(),
        None => signs(&target, n)?,
    };
    let mut task = TaskConfig::new(target, 0.0, StepOptions::default());
    task.start = match &transitions {
        Some(t) => Start::Equilibrium(t.start(0).to_vec()),
        None => start(&start_value, n, chain.state_dim())?,
    };
    task.transitions = transitions;
    let plain = CONFIG_KEYS
        .iter()
        .filter(|key| matches!(key.goes_to, Destination::Task(_)))
        .map(|key| Ok((key.name, plain_value(key, &get(values, key.name))?)))
        .collect::<PyResult<HashMap<_, _>>>()?;
    task.apply_keys(|key| plain.get(key.name).cloned())?;
    let optional = |name: &str| Some(get(values, name)).filter(|v| !v.is_none());
    task.reality = reality_gap(RealityArgs {
        randomize: optional("randomize").as_ref(),
        params: optional("params").as_ref(),
        mismatch: optional("mismatch").as_ref(),
        obs_noise: optional("obs_noise").as_ref(),
        action_delay: action_delay(&get(values, "action_delay"))?,
        force_rate_limit: optional("force_rate_limit")
            .map(|v| force_rate_limit(&v))
            .transpose()?,
        force_noise: optional("force_noise").as_ref(),
    })?;
    Ok(task)
}

/// Resolves a dict of keys (any subset, `scene` among them) into the model, the task
/// and the canonical values, and checks the task on the model (every check a batch
/// makes, without building one).
pub fn resolve(config: &Bound<'_, PyDict>) -> PyResult<ResolvedConfig> {
    let py = config.py();
    let values = merged(config)?;
    let model = model(&values)?;
    let task = task(&values, &model.chain)?;
    write_task_keys(py, &task.reality, &values)?;
    let checked = match &model.chain {
        AnyChain::Spatial(c) => SceneTask::Spatial(CheckedTask::new(c.clone(), task)?),
        AnyChain::Planar(c) => SceneTask::Planar(CheckedTask::new(c.clone(), task)?),
    };
    Ok(ResolvedConfig {
        obs_f64: get(&values, "obs_dtype").extract::<String>()? == "float64",
        diagnostics: get(&values, "diagnostics").extract()?,
        model: Py::new(py, model)?,
        checked,
        canonical: values.unbind(),
    })
}

/// Resolves and checks a configuration: `config` is a dict of keys (any subset;
/// `scene` names the scene whose values fill the rest, `None` values are unset).
/// Returns the resolved configuration (its `values()` are every key's value in
/// canonical form), or raises naming the bad value.
#[pyfunction]
pub fn resolve_config(config: &Bound<'_, PyDict>) -> PyResult<ResolvedConfig> {
    resolve(config)
}

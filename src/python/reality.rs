//! Conversion of the reality-gap keywords (`randomize`, `params`, `mismatch`,
//! `obs_noise`, `action_delay`, `force_rate_limit`, `force_noise`) between Python
//! values and [`RealityGap`]; every check is the core's.

use super::convert::{error, type_error};
use super::model::ChainCart;
use crate::env::{
    Distribution, EnvParams, ForceNoise, Param, ParamRandomization, ParamValues, Randomization,
    RealityGap, RigParam, RANDOMIZE_NAMES,
};
use crate::error::InputError;
use crate::params::ChainParams;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The raw keyword values as given to `EnvBatch`.
pub struct RealityArgs<'a, 'py> {
    pub randomize: Option<&'a Bound<'py, PyAny>>,
    pub params: Option<&'a Bound<'py, PyAny>>,
    pub mismatch: Option<&'a Bound<'py, PyAny>>,
    pub obs_noise: Option<&'a Bound<'py, PyAny>>,
    /// The fixed delay (or a range's low end) and a range's high end.
    pub action_delay: (i64, Option<i64>),
    /// The fixed limit (or a range's low end) and a range's high end.
    pub force_rate_limit: Option<(f64, Option<f64>)>,
    pub force_noise: Option<&'a Bound<'py, PyAny>>,
}

/// Numbers from a number or a sequence of numbers.
fn numbers(name: &str, value: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    if let Ok(x) = value.extract::<f64>() {
        return Ok(vec![x]);
    }
    value.extract::<Vec<f64>>().map_err(|_| {
        error(format!(
            "{name} = {value}: expected a number or a sequence of numbers"
        ))
    })
}

/// The entries of a dict keyword by key (`None` or an empty dict: none); `names` are
/// the keys it takes, for the message when it is not a dict.
fn dict_entries<'py>(
    kind: &'static str,
    names: &[&str],
    value: Option<&Bound<'py, PyAny>>,
) -> PyResult<Vec<(String, Bound<'py, PyAny>)>> {
    let Some(value) = value.filter(|v| !v.is_none()) else {
        return Ok(Vec::new());
    };
    let dict = value.cast::<PyDict>().map_err(|_| {
        error(format!(
            "{kind} = {value}: expected a dict whose keys are some of {}",
            crate::error::quoted(names)
        ))
    })?;
    let mut out = Vec::new();
    for (k, v) in dict.iter() {
        let key: String = k
            .extract()
            .map_err(|_| error(format!("{kind} has key {k}: expected a parameter name")))?;
        out.push((key, v));
    }
    Ok(out)
}

/// The entries of `params=`/`mismatch=`, each key a physical parameter.
fn entries<'py>(
    kind: &'static str,
    value: Option<&Bound<'py, PyAny>>,
) -> PyResult<Vec<(Param, Bound<'py, PyAny>)>> {
    let what = if kind == "params" {
        "params key"
    } else {
        "mismatch key"
    };
    dict_entries(kind, &Param::NAMES, value)?
        .into_iter()
        .map(|(key, v)| Ok((Param::from_name(what, &key)?, v)))
        .collect()
}

/// `params=`/`mismatch=`: a dict of numbers or per-link lists (or, for `params`, a
/// `ChainCart` whose parameters are all taken).
fn param_values(kind: &'static str, value: Option<&Bound<'_, PyAny>>) -> PyResult<ParamValues> {
    if let Some(model) = value.and_then(|v| v.cast::<ChainCart>().ok()) {
        let p = model.get().chain.params().clone();
        return Ok(ParamValues {
            cart_mass: Some(p.cart_mass()),
            link_masses: Some(p.masses().to_vec()),
            link_lengths: Some(p.lengths().to_vec()),
            gravity: Some(p.gravity()),
        });
    }
    let mut out = ParamValues::default();
    for (p, v) in entries(kind, value)? {
        let name = format!("{kind}[{:?}]", p.name());
        let values = numbers(&name, &v)?;
        if !p.is_per_link() && values.len() != 1 {
            return Err(error(format!("{name} = {v}: expected one number")));
        }
        out.set(p, values);
    }
    Ok(out)
}

/// `[low, high]` of a richer randomisation form (a number `h` is `[1-h, 1+h]` for
/// `"scale"` only).
fn bounds(name: &str, form: &str, value: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
    if form == "scale" {
        if let Ok(h) = value.extract::<f64>() {
            return Ok((1.0 - h, 1.0 + h));
        }
    }
    let v: Vec<f64> = value.extract().map_err(|_| {
        error(format!(
            "{name}[{form:?}] = {value}: expected [low, high]{}",
            if form == "scale" {
                " or a relative half-width"
            } else {
                ""
            }
        ))
    })?;
    match v[..] {
        [low, high] => Ok((low, high)),
        _ => Err(error(format!(
            "{name}[{form:?}] has {} numbers, expected 2 ([low, high])",
            v.len()
        ))),
    }
}

/// One parameter's randomisation: a relative half-width or a dict form.
fn param_randomization(name: &str, value: &Bound<'_, PyAny>) -> PyResult<ParamRandomization> {
    if let Ok(h) = value.extract::<f64>() {
        return Ok(ParamRandomization {
            distribution: Distribution::relative(h),
            per_link: true,
        });
    }
    let dict = value.cast::<PyDict>().map_err(|_| {
        error(format!(
            "{name} = {value}: expected a relative half-width or a dict with one of \
             \"scale\", \"log_scale\", \"range\", \"log_range\" (and optionally \"per_link\")"
        ))
    })?;
    let mut distribution = None;
    let mut per_link = true;
    for (k, v) in dict.iter() {
        let key: String = k.extract()?;
        let make = |lo, hi| match key.as_str() {
            "scale" => Distribution::Scale { low: lo, high: hi },
            "log_scale" => Distribution::LogScale { low: lo, high: hi },
            "range" => Distribution::Range { low: lo, high: hi },
            _ => Distribution::LogRange { low: lo, high: hi },
        };
        match key.as_str() {
            "per_link" => per_link = v.extract()?,
            "scale" | "log_scale" | "range" | "log_range" if distribution.is_none() => {
                let (lo, hi) = bounds(name, &key, &v)?;
                distribution = Some(make(lo, hi));
            }
            "scale" | "log_scale" | "range" | "log_range" => {
                return Err(error(format!(
                    "{name} = {value}: expected only one distribution"
                )))
            }
            other => {
                return Err(error(format!(
                    "{name} has unknown key {other:?}: expected one of \"scale\", \
                     \"log_scale\", \"range\", \"log_range\", \"per_link\""
                )))
            }
        }
    }
    let distribution =
        distribution.ok_or_else(|| error(format!("{name} = {value}: no distribution given")))?;
    Ok(ParamRandomization {
        distribution,
        per_link,
    })
}

/// `randomize=`: a dict from physical parameters and rig effects to their draws.
fn randomization(value: Option<&Bound<'_, PyAny>>) -> PyResult<Randomization> {
    let mut out = Randomization::default();
    for (key, v) in dict_entries("randomize", &RANDOMIZE_NAMES, value)? {
        let name = format!("randomize[{key:?}]");
        let draw = Some(param_randomization(&name, &v)?);
        match RigParam::from_name(&key) {
            Some(rig) => out.set_rig(rig, draw),
            None => match Param::ALL.into_iter().find(|p| p.name() == key) {
                Some(p) => out.set(p, draw),
                None => {
                    return Err(InputError::UnknownName {
                        kind: "randomize key",
                        name: key,
                        expected: &RANDOMIZE_NAMES,
                    }
                    .into())
                }
            },
        }
    }
    Ok(out)
}

/// `force_noise=`: `None` (off) or a dict with some of `"multiplicative"`,
/// `"additive"` mapped to numbers (ranges are checked by the core).
fn force_noise(value: Option<&Bound<'_, PyAny>>) -> PyResult<ForceNoise> {
    let mut out = ForceNoise::default();
    let Some(value) = value.filter(|v| !v.is_none()) else {
        return Ok(out);
    };
    let keys = crate::error::quoted(&ForceNoise::NAMES);
    let Ok(dict) = value.cast::<PyDict>() else {
        return Err(type_error(format!(
            "force_noise = {}: expected None or a dict with some of {keys}, each {}",
            value.repr()?,
            ForceNoise::EXPECTED
        )));
    };
    for (k, v) in dict.iter() {
        let key = k.extract::<String>().ok();
        let slot = match key.as_deref() {
            Some("multiplicative") => &mut out.multiplicative,
            Some("additive") => &mut out.additive,
            _ => {
                return Err(error(format!(
                    "force_noise has unknown key {}: expected some of {keys}",
                    k.repr()?
                )))
            }
        };
        let Ok(number) = v.extract::<f64>() else {
            return Err(type_error(format!(
                "force_noise[{}] = {}: expected {}",
                k.repr()?,
                v.repr()?,
                ForceNoise::EXPECTED
            )));
        };
        *slot = number;
    }
    Ok(out)
}

/// The reality gap of the keywords (checked by the core when the batch is built).
pub fn reality_gap(args: RealityArgs<'_, '_>) -> PyResult<RealityGap> {
    let obs_noise = match args.obs_noise.filter(|v| !v.is_none()) {
        Some(v) => numbers("obs_noise", v)?,
        None => Vec::new(),
    };
    Ok(RealityGap {
        params: param_values("params", args.params)?,
        mismatch: param_values("mismatch", args.mismatch)?,
        randomize: randomization(args.randomize)?,
        obs_noise,
        action_delay: RealityGap::delay_from(args.action_delay.0)?,
        action_delay_high: args
            .action_delay
            .1
            .map(RealityGap::delay_from)
            .transpose()?,
        force_rate_limit: args.force_rate_limit.map_or(f64::INFINITY, |(low, _)| low),
        force_rate_limit_high: args.force_rate_limit.and_then(|(_, high)| high),
        force_noise: force_noise(args.force_noise)?,
    })
}

fn distribution_dict<'py>(py: Python<'py>, r: ParamRandomization) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let (form, (low, high)) = match r.distribution {
        Distribution::Scale { .. } => ("scale", r.distribution.bounds()),
        Distribution::LogScale { .. } => ("log_scale", r.distribution.bounds()),
        Distribution::Range { .. } => ("range", r.distribution.bounds()),
        Distribution::LogRange { .. } => ("log_range", r.distribution.bounds()),
    };
    d.set_item(form, [low, high])?;
    d.set_item("per_link", r.per_link)?;
    Ok(d)
}

fn values_dict<'py>(py: Python<'py>, v: &ParamValues) -> PyResult<Option<Bound<'py, PyDict>>> {
    if v.is_empty() {
        return Ok(None);
    }
    let d = PyDict::new(py);
    if let Some(x) = v.cart_mass {
        d.set_item("cart_mass", x)?;
    }
    if let Some(x) = &v.link_masses {
        d.set_item("link_masses", x.clone())?;
    }
    if let Some(x) = &v.link_lengths {
        d.set_item("link_lengths", x.clone())?;
    }
    if let Some(x) = v.gravity {
        d.set_item("gravity", x)?;
    }
    Ok(Some(d))
}

/// Writes the reality-gap keywords, in a canonical form that builds the same batch,
/// into `d` (the batch's `task` dict).
pub fn write_task_keys(py: Python<'_>, r: &RealityGap, d: &Bound<'_, PyDict>) -> PyResult<()> {
    let randomize = if r.randomize.is_off() {
        None
    } else {
        let rd = PyDict::new(py);
        for p in Param::ALL {
            if let Some(pr) = r.randomize.get(p) {
                rd.set_item(p.name(), distribution_dict(py, pr)?)?;
            }
        }
        for p in RigParam::ALL {
            if let Some(pr) = r.randomize.get_rig(p) {
                rd.set_item(p.name(), distribution_dict(py, pr)?)?;
            }
        }
        Some(rd)
    };
    d.set_item("randomize", randomize)?;
    d.set_item("params", values_dict(py, &r.params)?)?;
    d.set_item("mismatch", values_dict(py, &r.mismatch)?)?;
    d.set_item(
        "obs_noise",
        (!r.obs_noise.is_empty()).then(|| r.obs_noise.clone()),
    )?;
    match r.action_delay_high {
        Some(high) => d.set_item("action_delay", (r.action_delay, high))?,
        None => d.set_item("action_delay", r.action_delay)?,
    }
    match r.force_rate_limit_high {
        Some(high) => d.set_item("force_rate_limit", (r.force_rate_limit, high))?,
        None => d.set_item(
            "force_rate_limit",
            r.has_rate_limit().then_some(r.force_rate_limit),
        )?,
    }
    d.set_item("force_noise", force_noise_dict(py, &r.force_noise)?)?;
    Ok(())
}

/// The force noise's non-zero standard deviations as a dict (`None` when off).
fn force_noise_dict<'py>(
    py: Python<'py>,
    noise: &ForceNoise,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    if !noise.is_on() {
        return Ok(None);
    }
    let d = PyDict::new(py);
    let values = [noise.multiplicative, noise.additive];
    for (name, value) in ForceNoise::NAMES.iter().zip(values) {
        if value > 0.0 {
            d.set_item(name, value)?;
        }
    }
    Ok(Some(d))
}

/// One parameter set as a dict of plain values.
pub fn params_dict<'py>(py: Python<'py>, p: &ChainParams) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("cart_mass", p.cart_mass())?;
    d.set_item("link_masses", p.masses().to_vec())?;
    d.set_item("link_lengths", p.lengths().to_vec())?;
    d.set_item("gravity", p.gravity())?;
    Ok(d)
}

/// Per-env parameters as a dict of arrays with a leading `num_envs` axis.
pub fn param_arrays<'py>(py: Python<'py>, p: &EnvParams) -> PyResult<Bound<'py, PyDict>> {
    let (num_envs, n) = (p.num_envs(), p.n_links());
    let d = PyDict::new(py);
    d.set_item("cart_mass", PyArray1::from_slice(py, &p.cart_mass))?;
    d.set_item(
        "link_masses",
        PyArray1::from_slice(py, &p.link_masses).reshape([num_envs, n])?,
    )?;
    d.set_item(
        "link_lengths",
        PyArray1::from_slice(py, &p.link_lengths).reshape([num_envs, n])?,
    )?;
    d.set_item("gravity", PyArray1::from_slice(py, &p.gravity))?;
    write_rig_arrays(py, p, &d, Some([num_envs, n]))?;
    Ok(d)
}

/// Writes the envs' own rig effects, where they draw them, into `d`: the joint damping
/// shaped `damping_shape` (else flat, as snapshots keep it) and the cart frictions.
pub fn write_rig_arrays(
    py: Python<'_>,
    p: &EnvParams,
    d: &Bound<'_, PyDict>,
    damping_shape: Option<[usize; 2]>,
) -> PyResult<()> {
    if !p.has_rig() {
        return Ok(());
    }
    let damping = PyArray1::from_slice(py, &p.joint_damping);
    match damping_shape {
        Some(shape) => d.set_item("joint_damping", damping.reshape(shape)?)?,
        None => d.set_item("joint_damping", damping)?,
    }
    d.set_item(
        "cart_viscous_friction",
        PyArray1::from_slice(py, &p.cart_viscous_friction),
    )?;
    d.set_item(
        "cart_coulomb_friction",
        PyArray1::from_slice(py, &p.cart_coulomb_friction),
    )
}

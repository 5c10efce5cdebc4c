//! Bindings of `subsurf_core::mc` (used by python/subsurf/mc.py): `mc_run` traces a photon
//! range into an exact state, `mc_finish` turns a state into totals and histograms,
//! `mc_merge_states` appends states in range order; plus validators, limits and bin measures.
//!
//! Ctrl-C ([`crate::wait::interruptible`]): a KeyboardInterrupt — from a signal or from
//! `progress(done, total)`, during the run, on `progress`'s final call, or pending when a short
//! run ends — stops the run and is answered by the state of the photons committed so far with
//! `interrupted = True` (always a prefix of whole chunks); any other exception from `progress`
//! propagates.

use crate::errors::{f64_arg, threads_arg, to_py, u64_arg, IntoPyResult};
use crate::medium::{stack_from_py, LayerTuple};
use crate::wait::interruptible;
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::time::Instant;
use subsurf_core::mc::config::{CHUNK_PHOTONS, MAX_THREADS, PHOTONS_ALLOWED, SEED_ALLOWED};
use subsurf_core::mc::tally::histogram::AxisKind;
use subsurf_core::mc::tally::totals::{Total, Totals, TOTAL_NAMES};
use subsurf_core::mc::tally::{Channel, HistogramOut, TallyConfig, TallyInput, TallySet, TallyValue};
use subsurf_core::mc::{cost, extend, fingerprint, finish, FlatState, RunConfig, Source, TallyState};
use subsurf_core::medium::Stack;
use subsurf_core::Error;

/// A source as Python passes it: ("pencil", theta, phi) or ("diffuse", 0, 0).
fn source_from_py(kind: &str, theta: f64, phi: f64) -> subsurf_core::Result<Source> {
    let s = match kind {
        "pencil" => Source::Pencil { theta, phi },
        "diffuse" => Source::Diffuse,
        other => return Err(Error::Invalid(format!("source: unknown kind {other:?} (pencil or diffuse)"))),
    };
    s.validate()?;
    Ok(s)
}

/// Validate a source; raises ParameterError naming the field.
#[pyfunction]
fn mc_validate_source(kind: &str, theta: f64, phi: f64) -> PyResult<()> {
    source_from_py(kind, theta, phi).py().map(|_| ())
}

/// Validate the run parameters photons, seed and threads; raises ParameterError naming the field.
#[pyfunction]
#[pyo3(signature = (photons, seed, threads=None))]
fn mc_validate_run(
    photons: &Bound<'_, PyAny>,
    seed: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<()> {
    let threads = threads.map(threads_arg).transpose()?;
    let cfg = RunConfig {
        photons: u64_arg(photons, "photons", PHOTONS_ALLOWED)?,
        seed: u64_arg(seed, "seed", SEED_ALLOWED)?,
        threads,
        source: Source::default(),
        isa: None,
    };
    cfg.validate().py()
}

/// The `subsurf.Tallies.to_dict()` of Python as a validated core [`TallyConfig`]: every field
/// of [`TallyConfig::fields`] read by its name and kind (a missing one takes its default, as in
/// states saved before the field existed); numbers through the one argument mapping.
fn tally_config_from_py(d: &Bound<'_, PyDict>) -> PyResult<TallyConfig> {
    let mut inputs = Vec::new();
    for (name, value) in TallyConfig::default().fields() {
        let Some(v) = d.get_item(name)? else { continue };
        let field = format!("tallies.{name}");
        let input = match value {
            TallyValue::Count(_) | TallyValue::Width(_) => TallyInput::Number(f64_arg(&v, &field)?),
            TallyValue::Order(_) if v.is_none() => TallyInput::Optional(None),
            TallyValue::Order(_) => TallyInput::Optional(Some(f64_arg(&v, &field)?)),
            TallyValue::Pair(_) if v.is_none() => TallyInput::Pair(None),
            TallyValue::Pair(_) => {
                let (a, b): (Bound<'_, PyAny>, Bound<'_, PyAny>) = v
                    .extract()
                    .map_err(|_| to_py(Error::Invalid(format!("{field}: must be None or a pair of integers"))))?;
                TallyInput::Pair(Some((f64_arg(&a, &format!("{field}[0]"))?, f64_arg(&b, &format!("{field}[1]"))?)))
            }
            TallyValue::Flag(_) => TallyInput::Flag(
                v.extract().map_err(|_| to_py(Error::Invalid(format!("{field}: must be True or False"))))?,
            ),
        };
        inputs.push((name, input));
    }
    TallyConfig::from_inputs(inputs).py()
}

/// The fields of `subsurf.Tallies` as the core defines them: (name, kind, default) in order;
/// kinds "count", "length", "pair", "order", "bool".
fn tally_fields(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let out = PyList::empty(py);
    for (name, v) in TallyConfig::default().fields() {
        let default = match v {
            TallyValue::Count(n) => n.into_pyobject(py)?.into_any(),
            TallyValue::Width(w) => w.into_pyobject(py)?.into_any(),
            TallyValue::Pair(p) => p.into_pyobject(py)?.into_any(),
            TallyValue::Order(k) => k.into_pyobject(py)?.into_any(),
            TallyValue::Flag(b) => b.into_pyobject(py)?.to_owned().into_any(),
        };
        out.append((name, v.kind(), default))?;
    }
    Ok(out)
}

/// Validate a `subsurf.Tallies.to_dict()`; raises ParameterError naming the field.
#[pyfunction]
fn mc_validate_tallies(tallies: &Bound<'_, PyDict>) -> PyResult<()> {
    tally_config_from_py(tallies).map(|_| ())
}

/// Everything a run is a function of, converted and validated.
struct Setup {
    stack: Stack,
    cfg: RunConfig,
    tallies: Option<TallyConfig>,
    layout: Vec<Channel>,
    fingerprint: u64,
}

#[allow(clippy::too_many_arguments)]
fn setup(
    layers: &[LayerTuple],
    n_above: f64,
    n_below: f64,
    photons: Option<&Bound<'_, PyAny>>,
    seed: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
    source: &(String, f64, f64),
    tallies: Option<&Bound<'_, PyDict>>,
) -> PyResult<Setup> {
    let stack = stack_from_py(layers, n_above, n_below).py()?;
    let threads = threads.map(threads_arg).transpose()?;
    let cfg = RunConfig {
        photons: photons.map_or(Ok(1), |p| u64_arg(p, "photons", PHOTONS_ALLOWED))?,
        seed: u64_arg(seed, "seed", SEED_ALLOWED)?,
        threads,
        source: source_from_py(&source.0, source.1, source.2).py()?,
        isa: None,
    };
    cfg.validate().py()?;
    let tallies = tallies.map(tally_config_from_py).transpose()?;
    let mut layout = Totals::layout(stack.layers.len());
    if let Some(t) = &tallies {
        layout.extend(TallySet::layout(t).py()?);
    }
    let fingerprint = fingerprint(&stack, &cfg.source, cfg.seed, tallies.as_ref());
    Ok(Setup { stack, cfg, tallies, layout, fingerprint })
}

/// A flat state dict (see `_core.pyi`) as a core state.
fn state_from_py(d: &Bound<'_, PyDict>) -> PyResult<TallyState> {
    let item = |k: &str| -> PyResult<Bound<'_, PyAny>> {
        d.get_item(k)?.ok_or_else(|| to_py(Error::Invalid(format!("state: missing field {k}"))))
    };
    let u64s = |k: &str| -> PyResult<Vec<u64>> {
        let a: PyReadonlyArray1<'_, u64> =
            item(k)?.extract().map_err(|_| to_py(Error::Invalid(format!("state.{k}: expected a uint64 array"))))?;
        Ok(a.as_array().to_vec())
    };
    let f64s = |k: &str| -> PyResult<Vec<f64>> {
        let a: PyReadonlyArray1<'_, f64> =
            item(k)?.extract().map_err(|_| to_py(Error::Invalid(format!("state.{k}: expected a float64 array"))))?;
        Ok(a.as_array().to_vec())
    };
    let f = FlatState {
        scheme: item("scheme")?.extract()?,
        start: item("start")?.extract()?,
        end: item("end")?.extract()?,
        events: item("events")?.extract()?,
        fingerprint: item("fingerprint")?.extract()?,
        names: item("names")?.extract()?,
        lengths: item("lengths")?.extract()?,
        extremes: item("extremes")?.extract()?,
        s1: u64s("s1")?,
        s2: u64s("s2")?,
        min: f64s("min")?,
        max: f64s("max")?,
    };
    TallyState::from_flat(&f).py()
}

/// A core state as a flat dict of plain values and numpy arrays.
fn state_to_py<'py>(py: Python<'py>, s: &TallyState) -> PyResult<Bound<'py, PyDict>> {
    let f = s.to_flat();
    let d = PyDict::new(py);
    d.set_item("scheme", f.scheme)?;
    d.set_item("start", f.start)?;
    d.set_item("end", f.end)?;
    d.set_item("events", f.events)?;
    d.set_item("fingerprint", f.fingerprint)?;
    d.set_item("names", f.names)?;
    d.set_item("lengths", f.lengths)?;
    d.set_item("extremes", f.extremes)?;
    d.set_item("s1", PyArray1::from_vec(py, f.s1))?;
    d.set_item("s2", PyArray1::from_vec(py, f.s2))?;
    d.set_item("min", PyArray1::from_vec(py, f.min))?;
    d.set_item("max", PyArray1::from_vec(py, f.max))?;
    Ok(d)
}

/// Finished histograms as a list of dicts (name, values, stderr, shape, edges, axes,
/// edge_units, measures, overflow, units, description); arrays are flat numpy arrays (C order).
fn histograms_to_py<'py>(py: Python<'py>, hs: Vec<HistogramOut>) -> PyResult<Bound<'py, PyList>> {
    let out = PyList::empty(py);
    for h in hs {
        let d = PyDict::new(py);
        d.set_item("name", h.name)?;
        d.set_item("values", PyArray1::from_vec(py, h.values))?;
        d.set_item("stderr", PyArray1::from_vec(py, h.stderr))?;
        d.set_item("shape", h.shape)?;
        let arrays = |vs: Vec<Vec<f64>>| -> PyResult<Bound<'py, PyList>> {
            let l = PyList::empty(py);
            for v in vs {
                l.append(PyArray1::from_vec(py, v))?;
            }
            Ok(l)
        };
        d.set_item("edges", arrays(h.edges)?)?;
        d.set_item("measures", arrays(h.measures)?)?;
        d.set_item("overflow", h.overflow)?;
        d.set_item("axes", h.axes)?;
        d.set_item("edge_units", h.edge_units)?;
        d.set_item("units", h.units)?;
        d.set_item("description", h.description)?;
        out.append(d)?;
    }
    Ok(out)
}

/// Trace photons [start, photons) of the run (`start` = the end of `state` when a state to
/// continue is given) and return {"state": flat state, "interrupted": bool, "elapsed_s": float}.
#[pyfunction]
#[pyo3(signature = (layers, n_above, n_below, photons, seed, threads, source, progress=None, tallies=None, state=None, start=None))]
#[allow(clippy::too_many_arguments)]
fn mc_run<'py>(
    py: Python<'py>,
    layers: Vec<LayerTuple>,
    n_above: f64,
    n_below: f64,
    photons: Bound<'py, PyAny>,
    seed: Bound<'py, PyAny>,
    threads: Option<Bound<'py, PyAny>>,
    source: (String, f64, f64),
    progress: Option<Py<PyAny>>,
    tallies: Option<Bound<'py, PyDict>>,
    state: Option<Bound<'py, PyDict>>,
    start: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let su = setup(&layers, n_above, n_below, Some(&photons), &seed, threads.as_ref(), &source, tallies.as_ref())?;
    // refuse before anything of the tallies' size is allocated
    subsurf_core::mc::run::check_memory(&su.layout, su.cfg.thread_count(), None).py()?;
    cost::check(&su.stack).py()?;
    let mut st = match &state {
        Some(d) => {
            let s = state_from_py(d)?;
            s.check_compatible(su.fingerprint, &su.layout).py()?;
            s
        }
        None => {
            let start = match &start {
                Some(s) => u64_arg(s, "start", "an integer in [0, photons], a multiple of 4096")?,
                None => 0,
            };
            if start > su.cfg.photons {
                return Err(to_py(Error::param_int("start", start, "an integer in [0, photons], a multiple of 4096")));
            }
            TallyState::new(su.layout.clone(), su.fingerprint, start).py()?
        }
    };
    let total = su.cfg.photons - st.end;
    let t0 = Instant::now();
    let proto = su.tallies.as_ref().map(|t| TallySet::new(t, &su.stack)).transpose().py()?;
    let (stack, cfg, nl) = (su.stack.clone(), su.cfg, su.stack.layers.len());
    let (out, stop) = interruptible(py, progress.as_ref(), total, move |cancel, done| {
        // Two monomorphisations: a run without histograms pays nothing for them.
        let out = match proto {
            None => extend(&stack, &cfg, &mut st, || Totals::new(nl), cancel, done),
            Some(p) => extend(&stack, &cfg, &mut st, || (Totals::new(nl), p.clone()), cancel, done),
        };
        out.map(|_| st)
    })?;
    let st = out.py()?;
    let d = PyDict::new(py);
    d.set_item("state", state_to_py(py, &st)?)?;
    d.set_item("interrupted", stop.is_some())?;
    d.set_item("elapsed_s", t0.elapsed().as_secs_f64())?;
    Ok(d)
}

/// Check, without tracing or finishing anything, that `state` belongs to the run described by
/// the arguments (same stack, source, seed and tallies): what `mc_run` checks before it resumes.
#[pyfunction]
#[pyo3(signature = (layers, n_above, n_below, seed, source, state, tallies=None))]
#[allow(clippy::too_many_arguments)]
fn mc_check_state(
    layers: Vec<LayerTuple>,
    n_above: f64,
    n_below: f64,
    seed: Bound<'_, PyAny>,
    source: (String, f64, f64),
    state: Bound<'_, PyDict>,
    tallies: Option<Bound<'_, PyDict>>,
) -> PyResult<()> {
    let su = setup(&layers, n_above, n_below, None, &seed, None, &source, tallies.as_ref())?;
    state_from_py(&state)?.check_compatible(su.fingerprint, &su.layout).py()
}

/// Totals (with `*_stderr`), `absorbed_per_layer` (+ stderr), `photons`, `events` and
/// `histograms` (see [`histograms_to_py`]) of a state of the run described by the arguments.
#[pyfunction]
#[pyo3(signature = (layers, n_above, n_below, seed, source, state, tallies=None))]
#[allow(clippy::too_many_arguments)]
fn mc_finish<'py>(
    py: Python<'py>,
    layers: Vec<LayerTuple>,
    n_above: f64,
    n_below: f64,
    seed: Bound<'py, PyAny>,
    source: (String, f64, f64),
    state: Bound<'py, PyDict>,
    tallies: Option<Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let su = setup(&layers, n_above, n_below, None, &seed, None, &source, tallies.as_ref())?;
    let st = state_from_py(&state)?;
    st.check_compatible(su.fingerprint, &su.layout).py()?;
    let nl = su.stack.layers.len();
    let (t, hists) = match &su.tallies {
        None => (finish(&st, || Totals::new(nl)), Vec::new()),
        Some(c) => {
            let proto = TallySet::new(c, &su.stack).py()?;
            let (t, set) = finish(&st, || (Totals::new(nl), proto.clone()));
            let n = st.photons();
            (t, py.detach(|| set.finalize(n)))
        }
    };
    let d = PyDict::new(py);
    for (q, name) in Total::ALL.into_iter().zip(TOTAL_NAMES) {
        let (m, se) = t.get(q);
        d.set_item(name, m)?;
        d.set_item(format!("{name}_stderr"), se)?;
    }
    let per_layer = t.absorbed_per_layer();
    d.set_item("absorbed_per_layer", per_layer.iter().map(|x| x.0).collect::<Vec<f64>>())?;
    d.set_item("absorbed_per_layer_stderr", per_layer.iter().map(|x| x.1).collect::<Vec<f64>>())?;
    d.set_item("photons", st.photons())?;
    d.set_item("events", st.events)?;
    d.set_item("histograms", histograms_to_py(py, hists)?)?;
    Ok(d)
}

/// Append states of consecutive photon ranges (given in range order) into one.
#[pyfunction]
fn mc_merge_states<'py>(py: Python<'py>, states: Vec<Bound<'py, PyDict>>) -> PyResult<Bound<'py, PyDict>> {
    let mut it = states.iter();
    let first = it.next().ok_or_else(|| to_py(Error::Invalid("states: give at least one state".into())))?;
    let mut acc = state_from_py(first)?;
    for s in it {
        acc.append(&state_from_py(s)?).py()?;
    }
    state_to_py(py, &acc)
}

/// Estimated scattering events per photon history of a stack; raises ParameterError when the
/// histories would be endless or too long (see `subsurf_core::mc::cost`).
#[pyfunction]
fn mc_expected_events(layers: Vec<LayerTuple>, n_above: f64, n_below: f64) -> PyResult<f64> {
    cost::check(&stack_from_py(&layers, n_above, n_below).py()?).py()
}

/// The exact per-bin measures of an axis of `kind` ("r", "z", "t", "theta", "theta_projected",
/// "cos_theta", "phi", "order", "order_one") with these bin edges.
#[pyfunction]
fn mc_axis_measures<'py>(
    py: Python<'py>,
    kind: &str,
    edges: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let k = AxisKind::from_name(kind).py()?;
    Ok(PyArray1::from_vec(py, k.measures(&edges.as_array().to_vec()).py()?))
}

/// Name of the instruction set the Monte Carlo lane kernel uses on this machine
/// (`"avx512"`, `"avx2"`, `"sse"`, `"neon"` or `"scalar"`): the best one, or the one the
/// environment variable `SUBSURF_ISA` forces (read at each run; an unknown name or one this
/// CPU cannot run is a `ValueError`).
#[pyfunction]
fn mc_isa() -> PyResult<&'static str> {
    Ok(subsurf_core::mc::lanes::Isa::selected().py()?.name())
}

/// Names of every instruction set this machine can run the lane kernel on, best first.
#[pyfunction]
fn mc_isas() -> Vec<&'static str> {
    subsurf_core::mc::lanes::Isa::available().iter().map(|i| i.name()).collect()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(mc_isa, m)?)?;
    m.add_function(wrap_pyfunction!(mc_isas, m)?)?;
    m.add_function(wrap_pyfunction!(mc_run, m)?)?;
    m.add_function(wrap_pyfunction!(mc_finish, m)?)?;
    m.add_function(wrap_pyfunction!(mc_check_state, m)?)?;
    m.add_function(wrap_pyfunction!(mc_merge_states, m)?)?;
    m.add_function(wrap_pyfunction!(mc_validate_source, m)?)?;
    m.add_function(wrap_pyfunction!(mc_validate_run, m)?)?;
    m.add_function(wrap_pyfunction!(mc_validate_tallies, m)?)?;
    m.add_function(wrap_pyfunction!(mc_expected_events, m)?)?;
    m.add_function(wrap_pyfunction!(mc_axis_measures, m)?)?;
    m.add("MC_CHUNK_PHOTONS", CHUNK_PHOTONS)?;
    m.add("MC_MAX_THREADS", MAX_THREADS)?;
    m.add("MC_MAX_BINS", subsurf_core::mc::tally::config::MAX_BINS)?;
    m.add("MC_MAX_ORDER", subsurf_core::mc::tally::config::MAX_ORDER)?;
    m.add("MC_MAX_PENCIL_THETA", subsurf_core::mc::source::MAX_PENCIL_THETA)?;
    m.add("MC_MAX_EVENTS_PER_PHOTON", cost::MAX_EVENTS_PER_PHOTON)?;
    m.add("MC_STATE_SCHEME", subsurf_core::mc::state::SCHEME)?;
    m.add("MC_TALLY_FIELDS", tally_fields(m.py())?)?;
    Ok(())
}

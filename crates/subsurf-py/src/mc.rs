//! Bindings of `subsurf_core::mc`: `mc_simulate` (used by python/subsurf/mc.py) and
//! `mc_validate_source`.
//!
//! Ctrl-C: the run executes on a background thread (`std::thread`) while this thread waits with
//! the GIL released, waking every 50 ms to re-attach, call `check_signals()` and the optional
//! `progress(done, total)` callable. A KeyboardInterrupt (from a signal or from `progress`) sets
//! the cancel flag; the run then returns its completed chunks and the result is marked partial.

use crate::errors::IntoPyResult;
use crate::medium::{stack_from_py, LayerTuple};
use numpy::PyArray1;
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};
use subsurf_core::mc::tally::totals::{Total, Totals};
use subsurf_core::mc::tally::{HistogramOut, TallyConfig, TallySet};
use subsurf_core::mc::{run, RunConfig, RunOutput, Source};

/// How often the waiting thread re-attaches to check signals and report progress.
const POLL: Duration = Duration::from_millis(50);

/// A source as Python passes it: ("pencil", theta, phi) or ("diffuse", 0, 0).
fn source_from_py(kind: &str, theta: f64, phi: f64) -> subsurf_core::Result<Source> {
    let s = match kind {
        "pencil" => Source::Pencil { theta, phi },
        "diffuse" => Source::Diffuse,
        other => {
            return Err(subsurf_core::Error::Invalid(format!("source: unknown kind {other:?} (pencil or diffuse)")))
        }
    };
    s.validate()?;
    Ok(s)
}

/// Validate a source; raises ParameterError naming the field.
#[pyfunction]
fn mc_validate_source(kind: &str, theta: f64, phi: f64) -> PyResult<()> {
    source_from_py(kind, theta, phi).py().map(|_| ())
}

/// The `subsurf.Tallies.to_dict()` of Python as a core [`TallyConfig`] (validated).
fn tally_config_from_py(d: &Bound<'_, PyDict>) -> PyResult<TallyConfig> {
    macro_rules! get {
        ($k:literal) => {
            d.get_item($k)?
                .ok_or_else(|| {
                    crate::errors::to_py(subsurf_core::Error::Invalid(format!("tallies: missing field {}", $k)))
                })?
                .extract()?
        };
    }
    let cfg = TallyConfig {
        nr: get!("nr"),
        dr: get!("dr"),
        nz: get!("nz"),
        dz: get!("dz"),
        na: get!("na"),
        nt: get!("nt"),
        dt: get!("dt"),
        brdf: get!("brdf"),
        max_order: get!("max_order"),
        spatial: get!("spatial"),
        angular: get!("angular"),
        errors: get!("errors"),
    };
    cfg.validate().py()?;
    Ok(cfg)
}

/// Finished histograms as a list of dicts (name, values, stderr, shape, edges, axes,
/// edge_units, units, description); `values`/`stderr` are flat numpy arrays (C order).
fn histograms_to_py<'py>(py: Python<'py>, hs: Vec<HistogramOut>) -> PyResult<Bound<'py, PyList>> {
    let out = PyList::empty(py);
    for h in hs {
        let d = PyDict::new(py);
        d.set_item("name", h.name)?;
        d.set_item("values", PyArray1::from_vec(py, h.values))?;
        d.set_item("stderr", PyArray1::from_vec(py, h.stderr))?;
        d.set_item("shape", h.shape)?;
        let edges = PyList::empty(py);
        for e in h.edges {
            edges.append(PyArray1::from_vec(py, e))?;
        }
        d.set_item("edges", edges)?;
        d.set_item("axes", h.axes)?;
        d.set_item("edge_units", h.edge_units)?;
        d.set_item("units", h.units)?;
        d.set_item("description", h.description)?;
        out.append(d)?;
    }
    Ok(out)
}

/// Trace `photons` packets; returns a dict of totals (with `*_stderr`), `absorbed_per_layer`
/// (+ stderr), `photons`, `events`, `elapsed_s`, `partial`, and `histograms` (a list, see
/// [`histograms_to_py`]; empty unless `tallies`, a `subsurf.Tallies.to_dict()`, is given).
#[pyfunction]
#[pyo3(signature = (layers, n_above, n_below, photons, seed, threads, source, progress=None, tallies=None))]
#[allow(clippy::too_many_arguments)]
fn mc_simulate<'py>(
    py: Python<'py>,
    layers: Vec<LayerTuple>,
    n_above: f64,
    n_below: f64,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
    source: (String, f64, f64),
    progress: Option<Py<PyAny>>,
    tallies: Option<Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stack = stack_from_py(&layers, n_above, n_below).py()?;
    let source = source_from_py(&source.0, source.1, source.2).py()?;
    let cfg = RunConfig { photons, seed, threads, source, isa: None };
    cfg.validate().py()?;
    let nl = stack.layers.len();
    let proto = match &tallies {
        Some(d) => Some(TallySet::new(&tally_config_from_py(d)?, &stack).py()?),
        None => None,
    };
    let cancel = Arc::new(AtomicBool::new(false));
    let done = Arc::new(AtomicU64::new(0));
    let (tx, mut rx) = mpsc::channel::<()>();
    let t0 = Instant::now();
    let handle = {
        let (cancel, done) = (cancel.clone(), done.clone());
        std::thread::spawn(move || {
            // Two monomorphisations: a run without histograms pays nothing for them.
            let out = match proto {
                None => run(&stack, &cfg, || Totals::new(nl), &cancel, &done).map(|o| (o, None)),
                Some(p) => run(&stack, &cfg, || (Totals::new(nl), p.clone()), &cancel, &done).map(|o| {
                    let RunOutput { tally: (t, set), photons, events, cancelled } = o;
                    (RunOutput { tally: t, photons, events, cancelled }, Some(set))
                }),
            };
            let _ = tx.send(());
            out
        })
    };
    let mut interrupt: Option<PyErr> = None;
    loop {
        let (finished, back) = py.detach(move || {
            let r = rx.recv_timeout(POLL);
            (!matches!(r, Err(mpsc::RecvTimeoutError::Timeout)), rx)
        });
        rx = back;
        if finished {
            break;
        }
        let mut check = py.check_signals();
        if check.is_ok() {
            if let Some(cb) = &progress {
                check = cb.call1(py, (done.load(Ordering::Relaxed), photons)).map(|_| ());
            }
        }
        if let Err(e) = check {
            cancel.store(true, Ordering::Relaxed);
            interrupt = Some(e);
            break;
        }
    }
    let joined = py.detach(move || handle.join());
    let elapsed = t0.elapsed().as_secs_f64();
    let (out, set) =
        joined.map_err(|_| PyRuntimeError::new_err("subsurf: the Monte Carlo worker thread panicked"))?.py()?;
    // A KeyboardInterrupt ends the run early and is answered by a partial result (if every
    // photon was already traced, the result is simply complete); any other error propagates.
    if let Some(e) = interrupt {
        if !e.is_instance_of::<PyKeyboardInterrupt>(py) {
            return Err(e);
        }
    } else {
        if let Some(cb) = &progress {
            cb.call1(py, (out.photons, photons))?;
        }
    }

    let t = &out.tally;
    let d = PyDict::new(py);
    for (name, q) in [
        ("specular_reflectance", Total::Specular),
        ("diffuse_reflectance", Total::Diffuse),
        ("transmittance", Total::Transmittance),
        ("unscattered_transmittance", Total::Unscattered),
        ("absorbed", Total::Absorbed),
    ] {
        let (m, se) = t.get(q);
        d.set_item(name, m)?;
        d.set_item(format!("{name}_stderr"), se)?;
    }
    let per_layer = t.absorbed_per_layer();
    d.set_item("absorbed_per_layer", per_layer.iter().map(|x| x.0).collect::<Vec<f64>>())?;
    d.set_item("absorbed_per_layer_stderr", per_layer.iter().map(|x| x.1).collect::<Vec<f64>>())?;
    d.set_item("photons", out.photons)?;
    d.set_item("events", out.events)?;
    d.set_item("elapsed_s", elapsed)?;
    d.set_item("partial", out.cancelled)?;
    let hists = match set {
        Some(s) => py.detach(|| s.finalize(out.photons)),
        None => Vec::new(),
    };
    d.set_item("histograms", histograms_to_py(py, hists)?)?;
    Ok(d)
}

/// Name of the instruction set the Monte Carlo lane kernel uses on this machine
/// (`"avx512"`, `"avx2"`, `"neon"` or `"scalar"`).
#[pyfunction]
fn mc_isa() -> &'static str {
    subsurf_core::mc::lanes::Isa::detect().name()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(mc_isa, m)?)?;
    m.add_function(wrap_pyfunction!(mc_simulate, m)?)?;
    m.add_function(wrap_pyfunction!(mc_validate_source, m)?)?;
    Ok(())
}

//! Bindings of `subsurf_core::bssrdf::adaptive`: the `AdaptiveTable` class (built here without
//! the GIL and interruptibly, or assembled from the nodes python/subsurf/bssrdf.py read from its
//! HDF5 cache) and its queries.

use crate::bssrdf::{data_from_py, data_to_py, PyProfile};
use crate::errors::{to_py, IntoPyResult};
use crate::medium::{stack_from_py, LayerTuple};
use crate::wait::{interrupted, interruptible};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;
use subsurf_core::bssrdf::adaptive::{thickness_nodes, AdaptiveSettings, AdaptiveTable, SlabData};
use subsurf_core::medium::Stack;
use subsurf_core::Error;

type StackTuple = (Vec<LayerTuple>, f64, f64);

fn stacks(s: &[StackTuple]) -> PyResult<Vec<Stack>> {
    s.iter()
        .enumerate()
        .map(|(k, t)| stack_from_py(&t.0, t.1, t.2).map_err(|e| e.within(&format!("stacks[{k}]."))).py())
        .collect()
}

/// The adaptive model's finite-slab tables (see `subsurf.bssrdf.AdaptiveTable`).
#[pyclass(name = "AdaptiveTable", module = "subsurf._core", frozen)]
pub struct PyAdaptiveTable {
    pub inner: Arc<AdaptiveTable>,
}

fn item<'py>(n: &Bound<'py, PyDict>, k: &str) -> PyResult<Bound<'py, PyAny>> {
    n.get_item(k)?.ok_or_else(|| to_py(Error::Invalid(format!("adaptive table node: missing {k}"))))
}

#[pymethods]
impl PyAdaptiveTable {
    /// Trace every node (interruptible; `progress(done, total)` counts photons).
    #[staticmethod]
    #[pyo3(signature = (stacks_in, photons, seed, threads=None, max_rel_err=0.2, progress=None))]
    fn build(
        py: Python<'_>,
        stacks_in: Vec<StackTuple>,
        photons: u64,
        seed: u64,
        threads: Option<usize>,
        max_rel_err: f64,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Self> {
        let st = stacks(&stacks_in)?;
        let s = AdaptiveSettings { photons, seed, threads, max_rel_err };
        let total = AdaptiveTable::photons(&st, &s);
        let (out, stop) = interruptible(py, progress.as_ref(), total, move |c, d| AdaptiveTable::build(&st, &s, c, d))?;
        match (stop, out.py()?) {
            (None, Some(t)) => Ok(PyAdaptiveTable { inner: Arc::new(t) }),
            _ => Err(interrupted("the adaptive table")),
        }
    }

    /// Assemble from the stacks, one list of node dicts per channel ({d, top, bottom}) and the
    /// settings it was built with.
    #[staticmethod]
    fn assemble(
        stacks_in: Vec<StackTuple>,
        nodes: Vec<Vec<Bound<'_, PyDict>>>,
        photons: u64,
        seed: u64,
        max_rel_err: f64,
    ) -> PyResult<Self> {
        let st = stacks(&stacks_in)?;
        let mut data = vec![];
        for ch in &nodes {
            let mut v = vec![];
            for n in ch {
                let top = data_from_py(item(n, "top")?.cast::<PyDict>()?)?;
                let bottom = data_from_py(item(n, "bottom")?.cast::<PyDict>()?)?;
                v.push(SlabData { d: item(n, "d")?.extract()?, top, bottom });
            }
            data.push(v);
        }
        let s = AdaptiveSettings { photons, seed, threads: None, max_rel_err };
        Ok(PyAdaptiveTable { inner: Arc::new(AdaptiveTable::assemble(&st, data, s).py()?) })
    }

    /// The nodes: per channel, a list of {d, top, bottom} dicts.
    fn nodes<'py>(&self, py: Python<'py>) -> PyResult<Vec<Vec<Bound<'py, PyDict>>>> {
        self.inner
            .data()
            .iter()
            .map(|ch| {
                ch.iter()
                    .map(|n| {
                        let o = PyDict::new(py);
                        o.set_item("d", n.d)?;
                        o.set_item("top", data_to_py(py, &n.top)?)?;
                        o.set_item("bottom", data_to_py(py, &n.bottom)?)?;
                        Ok(o)
                    })
                    .collect()
            })
            .collect()
    }

    /// (R, T) totals per unit entering power of `channel` at thickness `d` (mm).
    fn totals(&self, channel: usize, d: f64) -> PyResult<(f64, f64)> {
        self.check(channel, d)?;
        Ok(self.inner.totals(channel, d))
    }

    /// The reflection (`which` = "R") or transmission ("T") profile of `channel` at thickness `d`.
    fn profile(&self, channel: usize, d: f64, which: &str) -> PyResult<PyProfile> {
        self.check(channel, d)?;
        let at = self.inner.local(channel, d);
        let p: Arc<dyn subsurf_core::bssrdf::RadialProfile> = match which {
            "R" => Arc::new(self.inner.reflection(channel, at)),
            "T" => Arc::new(self.inner.transmission(channel, at)),
            w => return Err(to_py(Error::Invalid(format!("which = {w:?}: must be \"R\" or \"T\"")))),
        };
        Ok(PyProfile::new(p, "adaptive"))
    }
}

impl PyAdaptiveTable {
    fn check(&self, channel: usize, d: f64) -> PyResult<()> {
        if channel >= self.inner.channels() {
            return Err(to_py(Error::param("channel", channel as f64, "a channel index of the table")));
        }
        if !(d > 0.0) {
            return Err(to_py(Error::param("d", d, "a thickness > 0 (mm) or inf")));
        }
        Ok(())
    }
}

/// The thickness nodes (mm) of a stack's adaptive table (∞ not listed).
#[pyfunction]
fn bssrdf_adaptive_nodes(stack: StackTuple) -> PyResult<Vec<f64>> {
    thickness_nodes(&stack_from_py(&stack.0, stack.1, stack.2).py()?).py()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyAdaptiveTable>()?;
    m.add_function(wrap_pyfunction!(bssrdf_adaptive_nodes, m)?)?;
    Ok(())
}

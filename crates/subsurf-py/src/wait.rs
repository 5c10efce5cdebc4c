//! Long core computations that Ctrl-C can stop: [`interruptible`] runs the work on a background
//! thread while this thread waits with the GIL released, waking every [`POLL`] to re-attach, call
//! `check_signals()` and the optional `progress(done, total)` callable.
//!
//! A KeyboardInterrupt — from a signal or from `progress`, during the work, on `progress`'s final
//! call, or pending when a short computation ends — sets the work's cancel flag and is answered
//! by returning it (not raising it) with whatever the work returned; any other exception from `progress`
//! also cancels the work and propagates once the work has stopped. Used by every long entry point
//! of the binding (`mc_run`, the BSSRDF profile, table points, slab points, render passes).

use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError};
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

/// How often the waiting thread re-attaches to check signals and report progress.
pub const POLL: Duration = Duration::from_millis(50);

/// Run `work(cancel, done)` (it polls `cancel` and counts finished items in `done`) and wait for
/// it interruptibly; returns its value and the KeyboardInterrupt that stopped it, if one did.
pub fn interruptible<T, W>(
    py: Python<'_>,
    progress: Option<&Py<PyAny>>,
    total: u64,
    work: W,
) -> PyResult<(T, Option<PyErr>)>
where
    T: Send + 'static,
    W: FnOnce(&AtomicBool, &AtomicU64) -> T + Send + 'static,
{
    let cancel = Arc::new(AtomicBool::new(false));
    let done = Arc::new(AtomicU64::new(0));
    let (tx, mut rx) = mpsc::channel::<()>();
    let handle = {
        let (cancel, done) = (cancel.clone(), done.clone());
        std::thread::spawn(move || {
            let out = work(&cancel, &done);
            let _ = tx.send(());
            out
        })
    };
    let report = |py: Python<'_>| -> PyResult<()> {
        py.check_signals()?;
        match progress {
            Some(cb) => cb.call1(py, (done.load(Ordering::Relaxed), total)).map(|_| ()),
            None => Ok(()),
        }
    };
    let mut stop: Option<PyErr> = None;
    loop {
        let (finished, back) = py.detach(move || {
            let r = rx.recv_timeout(POLL);
            (!matches!(r, Err(mpsc::RecvTimeoutError::Timeout)), rx)
        });
        rx = back;
        if finished {
            break;
        }
        if let Err(e) = report(py) {
            cancel.store(true, Ordering::Relaxed);
            stop = Some(e);
            break;
        }
    }
    let joined = py.detach(move || handle.join());
    let out = joined.map_err(|_| PyRuntimeError::new_err("subsurf: the Monte Carlo worker thread panicked"))?;
    // the final call, and a Ctrl-C that arrived during work shorter than one poll
    let stop = match stop {
        Some(e) => Some(e),
        None => report(py).err(),
    };
    match stop {
        Some(e) if !e.is_instance_of::<PyKeyboardInterrupt>(py) => Err(e),
        stop => Ok((out, stop)),
    }
}

/// The KeyboardInterrupt raised by entry points that have nothing partial to return.
pub fn interrupted(what: &str) -> PyErr {
    PyKeyboardInterrupt::new_err(format!("{what} was interrupted"))
}

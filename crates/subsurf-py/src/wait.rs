//! Long core computations that Ctrl-C can stop: [`interruptible`] runs the work on a background
//! thread while this thread waits with the GIL released, waking every [`POLL`] to re-attach, call
//! `check_signals()` and the optional `progress(done, total)` callable.
//!
//! A KeyboardInterrupt — from a signal or from `progress`, during the work, on `progress`'s final
//! call, or pending when a short computation ends — sets the work's cancel flag and is answered
//! by returning it (not raising it) with whatever the work returned; any other exception from `progress`
//! also cancels the work and propagates once the work has stopped. Used by every long entry point
//! of the binding (`mc_run`, the BSSRDF profile, table points, slab points, the render set-up and
//! passes).

use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError};
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;
use subsurf_core::render::Control;

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
    interruptible_ctl(py, progress, total, move |c: &Control| work(&c.cancel, &c.done))
}

/// [`interruptible`] for work that learns its size as it goes: it may add to `ctl.total`
/// (which starts at `total`); `progress` is called with `(done, total)` as they stand.
pub fn interruptible_ctl<T, W>(
    py: Python<'_>,
    progress: Option<&Py<PyAny>>,
    total: u64,
    work: W,
) -> PyResult<(T, Option<PyErr>)>
where
    T: Send + 'static,
    W: FnOnce(&Control) -> T + Send + 'static,
{
    let ctl = Arc::new(Control::default());
    ctl.total.store(total, Ordering::Relaxed);
    let (tx, mut rx) = mpsc::channel::<()>();
    let handle = {
        let ctl = ctl.clone();
        std::thread::spawn(move || {
            let out = work(&ctl);
            let _ = tx.send(());
            out
        })
    };
    let report = |py: Python<'_>| -> PyResult<()> {
        py.check_signals()?;
        match progress {
            Some(cb) => {
                let (d, t) = (ctl.done.load(Ordering::Relaxed), ctl.total.load(Ordering::Relaxed));
                cb.call1(py, (d, t)).map(|_| ())
            }
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
            ctl.cancel.store(true, Ordering::Relaxed);
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

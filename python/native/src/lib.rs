//! `negotiator_native`: env-server's `/ws/batch` sessions in the Python
//! process ([`negotiator::InProcessBatch`]), for `negotiator_gym`'s
//! `NativeBatchVecEnv`. The messages and answers are `/ws/batch`'s own
//! JSON text, so the Python side is the same client without the socket.

use pyo3::prelude::*;
use std::sync::Mutex;

/// The sessions of one `/ws/batch` connection, held in this process.
#[pyclass(name = "Batch")]
struct Batch {
    // Python may hand the object to any thread; one message at a time.
    inner: Mutex<Option<negotiator::InProcessBatch>>,
}

#[pymethods]
impl Batch {
    #[new]
    fn new() -> Self {
        Batch { inner: Mutex::new(Some(negotiator::InProcessBatch::new())) }
    }

    /// One `/ws/batch` message (JSON text) and its answer; None once
    /// closed (`{"type": "close"}`).
    fn message(&self, py: Python<'_>, text: &str) -> PyResult<Option<String>> {
        // The sessions step without the interpreter's lock.
        py.detach(|| {
            let mut guard = self.inner.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
            let Some(inner) = guard.as_mut() else {
                return Err(pyo3::exceptions::PyRuntimeError::new_err("the batch is closed"));
            };
            let answer = inner.message(text);
            if answer.is_none() {
                *guard = None;
            }
            Ok(answer)
        })
    }
}

/// `GET /metadata`'s document (JSON text).
#[pyfunction]
fn metadata() -> String {
    negotiator::InProcessBatch::metadata()
}

#[pymodule]
fn negotiator_native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Batch>()?;
    m.add_function(wrap_pyfunction!(metadata, m)?)?;
    Ok(())
}

//! `groundscope._core`: the Rust side of the Python package. Environments seed-exact with
//! minigrid 3.2.0 ([`env`], [`vec`]); a Python callable as a policy ([`policy`]) evaluated
//! and recorded with the core's metrics and recorders ([`eval`]); a training run, the core's
//! [`groundscope::run::Run`] ([`train`]); the Python side (python/groundscope/) wraps them in
//! gymnasium's `Env` and `VectorEnv` and registers them.
#![allow(
    clippy::needless_pass_by_value,
    reason = "PyO3 extracts every argument of a Python-facing function by value"
)]

mod env;
mod eval;
mod policy;
mod train;
mod vec;

use pyo3::prelude::*;

/// The extension module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<env::Env>()?;
    m.add_class::<vec::VecEnv>()?;
    m.add_function(wrap_pyfunction!(env::level_ids, m)?)?;
    m.add_function(wrap_pyfunction!(eval::evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(eval::record, m)?)?;
    m.add_function(wrap_pyfunction!(train::train, m)?)?;
    m.add(
        "MINIGRID_VERSION",
        groundscope::env::snapshot::MINIGRID_VERSION,
    )?;
    Ok(())
}

//! Scaling.
use std::path::Path;
/// Runs the scaling benchmark.
pub fn run(_n: &[usize], _t: f64, _r: usize, _csv: &Path) -> Result<(), String> {
    Err("not yet".into())
}

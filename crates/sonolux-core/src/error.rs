//! Typed errors of the engine. The core never panics on user input: every check of what a
//! caller hands in returns one of these, and the binding maps each kind to a Python exception.

use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum CoreError {
    /// An input array or value is malformed (wrong length, NaN, index out of range).
    #[error("{what}: {problem}")]
    InvalidInput { what: String, problem: String },
    /// The geometry cannot be used (no triangles left after dropping degenerate ones, ...).
    #[error("geometry: {0}")]
    Geometry(String),
}

impl CoreError {
    pub fn invalid(what: impl Into<String>, problem: impl Into<String>) -> Self {
        CoreError::InvalidInput { what: what.into(), problem: problem.into() }
    }
}

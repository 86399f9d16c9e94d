//! The error type of talus. Every message names where the bad value came from.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum TalusError {
    /// Bad input: a case file, particle file or mesh. The message names file, key or line, and value.
    #[error("{0}")]
    Input(String),
    /// A run that went wrong (NaN, a particle leaving the domain). Names the particle.
    #[error("{0}")]
    Run(String),
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: std::io::Error,
    },
}

impl TalusError {
    pub fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        TalusError::Io { context: context.into(), source }
    }
}

pub type Result<T> = std::result::Result<T, TalusError>;

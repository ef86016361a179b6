//! The command line's pieces: one file per command (its arguments and its
//! body), the option groups several commands share ([`options`]), their
//! value parsers ([`parse`]), the setup every rendering command does
//! ([`setup`], [`lights`]) and the output files ([`output`]). Part of the
//! binary, not of the library's API.

pub mod bench;
pub mod charts;
pub mod compare;
pub mod experiment;
pub mod info;
pub mod lights;
pub mod options;
pub mod output;
pub mod parse;
pub mod render;
pub mod setup;
#[cfg(feature = "viewer")]
pub mod view;
#[cfg(any(not(feature = "viewer"), test))]
pub mod view_missing;

/// Why a command failed: the user's input (exit status 2) or anything else (1).
pub enum Failure {
    Input(anyhow::Error),
    Other(anyhow::Error),
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(e: E) -> Self {
        Failure::Other(e.into())
    }
}

impl Failure {
    /// The exit status: 2 for bad input, 1 otherwise.
    pub fn exit_status(&self) -> u8 {
        match self {
            Failure::Input(_) => 2,
            Failure::Other(_) => 1,
        }
    }

    /// The error, whatever its cause.
    pub fn into_error(self) -> anyhow::Error {
        match self {
            Failure::Input(e) | Failure::Other(e) => e,
        }
    }
}

/// Marks an error as the user's input's fault (exit status 2).
pub fn input<T, E: Into<anyhow::Error>>(r: Result<T, E>) -> Result<T, Failure> {
    r.map_err(|e| Failure::Input(e.into()))
}

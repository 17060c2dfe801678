//! The codec's one error type, sorted by who is at fault.

use std::io;

/// Everything that can go wrong in reading, encoding or decoding.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing failed in the operating system.
    #[error("{0}")]
    Io(#[from] io::Error),
    /// A mesh file is malformed (line numbers are 1-based).
    #[error("{0}")]
    MeshFile(String),
    /// The mesh itself is not acceptable (NaN, indices out of range, small faces).
    #[error("{0}")]
    InvalidMesh(String),
    /// The values do not fit the codec's integer range in the mode asked for.
    #[error("{0}")]
    Range(String),
    /// The container is damaged, cut off or not a container.
    #[error(transparent)]
    Container(#[from] subwave_container::Error),
    /// A decoded stream contradicts itself (corruption the checksums did not catch, or a
    /// non-conforming encoder).
    #[error("corrupt {section} data: {what}")]
    CorruptStream {
        /// Which section.
        section: &'static str,
        /// What is wrong.
        what: String,
    },
    /// The container uses a feature this build does not have.
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// The caller asked for something impossible.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}

impl Error {
    pub(crate) fn corrupt(section: &'static str, what: impl Into<String>) -> Self {
        Error::CorruptStream {
            section,
            what: what.into(),
        }
    }
}

/// Short for `Result<T, subwave_codec::Error>`.
pub type Result<T> = std::result::Result<T, Error>;

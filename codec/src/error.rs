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
    /// A level's section (LEVL) contradicts itself: which level (1 = the first above the
    /// base mesh) and where its section starts in the container.
    #[error("corrupt LEVL data in level {level} (section at byte {offset}): {what}")]
    CorruptLevel {
        /// The level, 1-based.
        level: u8,
        /// The byte offset of the level's section in the container.
        offset: u64,
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

    /// This error, if it is a LEVL stream's corruption, as one in level `level`'s
    /// section (starting at byte `offset` of the container).
    pub(crate) fn in_level(self, level: usize, offset: u64) -> Self {
        match self {
            Error::CorruptStream {
                section: "LEVL",
                what,
            } => Error::CorruptLevel {
                level: level.min(u8::MAX as usize) as u8,
                offset,
                what,
            },
            e => e,
        }
    }
}

/// Short for `Result<T, subwave_codec::Error>`.
pub type Result<T> = std::result::Result<T, Error>;

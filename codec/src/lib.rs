//! subwave's codec: the integer mesh model, mesh file I/O, quantisation, entropy coding
//! and the container's sections. Most users want the facade crate `subwave`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// Numeric kernels index several arrays (axes, positions, weights) in lockstep.
#![allow(clippy::needless_range_loop)]

/// Declares the stages: private to the crate, public with the `internals` feature (for
/// the fuzz harness, the benches and the tests that reach inside, as ruzstd's
/// `fuzz_exports`; not a stable API).
macro_rules! stages {
    ($($(#[$doc:meta])* $name:ident;)*) => {$(
        $(#[$doc])*
        #[cfg(feature = "internals")]
        pub mod $name;
        $(#[$doc])*
        #[cfg(not(feature = "internals"))]
        mod $name;
    )*};
}

stages! {
    /// Adaptive models and the ANS coder (SPEC.md 4).
    entropy;
    /// The integer mesh.
    mesh;
    /// Exact and grid quantisation (SPEC.md 3).
    quant;
    /// One module per container section (SPEC.md 5-10).
    sections;
    /// Coarse adjacency, refinement and hierarchy recovery (SPEC.md 6.2, 8).
    topology;
    /// The wavelet transforms, one folder per family (SPEC.md 9).
    transform;
}
pub mod error;
pub mod io;

pub use error::{Error, Result};
pub use mesh::{Attribute, Domain, Mesh, ValueType, MAX_ATTRIBUTES, MAX_COORD, NO_ENTRY};
pub use quant::{integerize, Decimal, FloatWidth, Quantization, RawCoords, MAX_DECIMALS};
pub use sections::head::{Header, Source, Transform};
pub use subwave_container::{Limits, FORMAT_VERSION};
pub use topology::Family;
pub use transform::polar::DiscTransform;
pub use transform::Wavelet;

mod decoder;
mod encoder;
mod info;

pub use decoder::{decode, DecodeOptions, Decoded};
pub use encoder::{
    encode, encode_file, EncodeOptions, Encoded, Progress, Stage, TransformChoice, DEFAULT_EFFORT,
    MAX_EFFORT,
};
pub use info::{fit_rules, inspect, AttributeInfo, Info, SectionInfo};

//! subwave's codec: the integer mesh model, mesh file I/O, quantisation, entropy coding
//! and the container's sections. Most users want the facade crate `subwave`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// Numeric kernels index several arrays (axes, positions, weights) in lockstep.
#![allow(clippy::needless_range_loop)]

pub mod entropy;
pub mod error;
pub mod io;
pub mod mesh;
pub mod quant;
pub mod sections;
pub mod topology;
pub mod transform;

pub use error::{Error, Result};
pub use mesh::{Mesh, MAX_COORD};
pub use quant::{FloatWidth, Quantization, RawCoords};
pub use sections::head::{Family, Header, Source, Transform};
pub use sections::vmap::ValueMap;
pub use subwave_container::{Limits, FORMAT_VERSION};
pub use transform::polar::DiscTransform;
pub use transform::Wavelet;

mod decoder;
mod encoder;
mod info;

pub use decoder::{decode, DecodeOptions, Decoded};
pub use encoder::{encode, EncodeOptions, Encoded, TransformChoice};
pub use info::{inspect, Info, SectionInfo};

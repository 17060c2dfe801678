//! The container's sections (SPEC.md 2.4), one module per kind, named as SPEC.md names
//! them: each holds its payload's wire format, both ways.

pub(crate) mod attr;
pub mod base;
pub(crate) mod chan;
pub mod cidx;
pub mod fbit;
pub mod head;
pub mod levl;
pub mod ordr;
pub mod nrml;
pub(crate) mod tmpl;
pub mod vmap;

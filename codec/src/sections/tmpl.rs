//! The TMPL section (SPEC.md 11): the input file's template (`io::template`), whose
//! markers the decoded mesh fills in to give the file back byte for byte; its bytes
//! compressed with zstd, a well-kept general-purpose compressor, as they are neither
//! positions nor connectivity.

use subwave_container::{ByteReader, ByteWriter};

use crate::error::{Error, Result};

/// zstd's level for templates: its strongest without the long-distance window.
const LEVEL: i32 = 19;

/// The TMPL payload of a template: its length, then one zstd frame with its checksum.
pub(crate) fn encode(template: &[u8]) -> Result<Vec<u8>> {
    let mut w = ByteWriter::new();
    w.varint(template.len() as u64);
    // With zstd's content checksum: damage the CRC of the section cannot see (a
    // non-conforming encoder) is an error, not other bytes.
    let mut c = zstd::bulk::Compressor::new(LEVEL)?;
    c.include_checksum(true)?;
    let z = c.compress(template)?;
    w.out.extend_from_slice(&z);
    Ok(w.out)
}

/// The template of a TMPL payload (at byte `offset` of the container), refused before
/// any allocation when it declares more than `limit` bytes.
pub(crate) fn decode(payload: &[u8], offset: u64, limit: u64) -> Result<Vec<u8>> {
    let mut r = ByteReader::new(payload, offset);
    let len = r.varint("template length")?;
    if len > limit {
        return Err(subwave_container::Error::Limit {
            what: "file template bytes for a container this size (see Limits::max_expansion)",
            requested: len,
            limit,
        }
        .into());
    }
    let start = payload.len() - r.remaining();
    let bad = |what: String| Error::corrupt("TMPL", what);
    // One-shot decompression writes into a buffer of the declared length and no more.
    let out = zstd::bulk::Decompressor::new()?
        .decompress(&payload[start..], len as usize)
        .map_err(|e| bad(format!("the compressed template does not decompress: {e}")))?;
    if out.len() as u64 != len {
        return Err(bad(format!(
            "the template is {} bytes, its length says {len}",
            out.len()
        )));
    }
    Ok(out)
}

//! The subwave container: magic, format version, typed sections with lengths and
//! checksums, and the limits that keep a hostile file from costing more than it should.
//!
//! This crate knows bytes, not meshes: a tool can list and verify a container with it
//! without decoding any geometry. The layout is normative in `SPEC.md` section 2.
//!
//! ```
//! use subwave_container::{ContainerWriter, Container, SectionKind, Limits};
//! let mut w = ContainerWriter::new();
//! w.section(SectionKind::HEADER, b"hello");
//! let bytes = w.finish();
//! let c = Container::parse(&bytes, &Limits::default()).unwrap();
//! assert!(c.complete);
//! assert_eq!(c.sections[0].payload, b"hello");
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod bytes;
mod limits;

pub use bytes::{ByteReader, ByteWriter};
pub use limits::Limits;

use std::fmt;

/// The eight bytes every container starts with (SPEC.md 2.1). The high first byte and
/// the CR LF / SUB / LF tail catch 7-bit transfers and newline translation, as PNG's do.
pub const MAGIC: [u8; 8] = [0x89, b'S', b'W', b'V', b'\r', b'\n', 0x1a, b'\n'];

/// The format version this crate writes and the only one it reads: before the first
/// release the format has one version at a time (SPEC.md 1), and a container of any other
/// version is refused with an error that names it.
pub const FORMAT_VERSION: u16 = 62;

/// Bytes before the first section: magic, version, reserved.
pub const PREAMBLE_LEN: usize = 12;

/// Longest varint of a compact section's length (lengths are below 2^32).
const MAX_LENGTH_BYTES: usize = 5;

/// Bytes a section of `payload_len` bytes adds around its payload (SPEC.md 2.2): one kind
/// byte, the length's varint bytes and the CRC.
pub fn section_overhead(payload_len: usize) -> usize {
    let mut n = 1;
    let mut v = payload_len >> 7;
    while v > 0 {
        n += 1;
        v >>= 7;
    }
    1 + n + 4
}

/// Errors from reading a container. Sorted by who is at fault.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The bytes are not a subwave container at all.
    #[error("not a subwave container (wrong magic bytes)")]
    BadMagic,
    /// The container was written by a newer version of the format.
    #[error("format version {found} is newer than this build reads (format {supported}); upgrade subwave")]
    NewerVersion {
        /// The version in the file.
        found: u16,
        /// The version this build reads.
        supported: u16,
    },
    /// The container was written in an older development format. Before the first
    /// release only the current format is read: re-encode the mesh with this build.
    #[error("format version {found} is an older development format; this build reads format {supported} only: compress the mesh again with this build")]
    OlderVersion {
        /// The version in the file.
        found: u16,
        /// The version this build reads.
        supported: u16,
    },
    /// The container is damaged or was not produced by a conforming encoder.
    #[error("corrupt container at byte {offset}: {what}")]
    Malformed {
        /// Byte offset in the container where the problem was found.
        offset: u64,
        /// What is wrong.
        what: String,
    },
    /// A section's checksum does not match its bytes.
    #[error("corrupt container: checksum mismatch in section {kind} at byte {offset}")]
    Checksum {
        /// The section's kind, as written.
        kind: SectionKind,
        /// Byte offset of the section's start.
        offset: u64,
    },
    /// The container ends before it is complete.
    #[error("truncated container: {what}")]
    Truncated {
        /// What was expected when the bytes ran out.
        what: String,
    },
    /// A declared size is larger than the limits allow.
    #[error("limit exceeded: {what} = {requested} is more than the limit {limit}")]
    Limit {
        /// Which quantity.
        what: &'static str,
        /// The value the input asked for.
        requested: u64,
        /// The limit in force.
        limit: u64,
    },
}

impl Error {
    /// Shorthand for [`Error::Malformed`].
    pub fn malformed(offset: u64, what: impl Into<String>) -> Self {
        Error::Malformed {
            offset,
            what: what.into(),
        }
    }
}

/// A section's kind: its four-letter name in SPEC.md (2.2), written as one byte.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct SectionKind(pub [u8; 4]);

impl SectionKind {
    /// Counts, family, transform and quantisation.
    pub const HEADER: SectionKind = SectionKind(*b"HEAD");
    /// The base mesh: connectivity and positions.
    pub const BASE: SectionKind = SectionKind(*b"BASE");
    /// Per-axis value maps.
    pub const VALUE_MAP: SectionKind = SectionKind(*b"VMAP");
    /// One refinement level's coefficients.
    pub const LEVEL: SectionKind = SectionKind(*b"LEVL");
    /// The permutation back to the input's vertex order.
    pub const ORDER: SectionKind = SectionKind(*b"ORDR");
    /// Binary float positions below their grid.
    pub const FLOAT_BITS: SectionKind = SectionKind(*b"FBIT");
    /// The input file's own bytes around the coded values.
    pub const TEMPLATE: SectionKind = SectionKind(*b"TMPL");
    /// The file's per-corner index channels (an OBJ's `vt` and `vn` numbers).
    pub const CORNER_INDICES: SectionKind = SectionKind(*b"CIDX");
    /// The file's normal components, predicted from the geometry.
    pub const NORMALS: SectionKind = SectionKind(*b"NRML");
    /// One vertex attribute of the file coded as the positions of a mesh of its own: a
    /// nested container.
    pub const ATTRIBUTE: SectionKind = SectionKind(*b"ATTR");
    /// One named attribute channel of the mesh (a nested container of its values).
    pub const CHANNEL: SectionKind = SectionKind(*b"CHAN");
    /// Marks the end of a complete container.
    pub const END: SectionKind = SectionKind(*b"SEND");

    /// Every kind, with its one-byte code in the stream (SPEC.md 2.2).
    const CODES: [(SectionKind, u8); 12] = [
        (SectionKind::HEADER, b'H'),
        (SectionKind::VALUE_MAP, b'V'),
        (SectionKind::BASE, b'B'),
        (SectionKind::LEVEL, b'L'),
        (SectionKind::FLOAT_BITS, b'F'),
        (SectionKind::ORDER, b'O'),
        (SectionKind::TEMPLATE, b'T'),
        (SectionKind::CORNER_INDICES, b'C'),
        (SectionKind::NORMALS, b'N'),
        (SectionKind::ATTRIBUTE, b'A'),
        (SectionKind::CHANNEL, b'K'),
        (SectionKind::END, b'E'),
    ];

    /// The one-byte code of a known kind, or `None`.
    pub fn code(self) -> Option<u8> {
        Self::CODES
            .iter()
            .find(|(k, _)| *k == self)
            .map(|&(_, c)| c)
    }

    /// The kind of a one-byte code, or `None` if no kind has it.
    pub fn from_code(code: u8) -> Option<SectionKind> {
        Self::CODES
            .iter()
            .find(|(_, c)| *c == code)
            .map(|&(k, _)| k)
    }
}

impl fmt::Display for SectionKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for &b in &self.0 {
            if b.is_ascii_graphic() {
                write!(f, "{}", b as char)?;
            } else {
                write!(f, "\\x{b:02x}")?;
            }
        }
        Ok(())
    }
}

impl fmt::Debug for SectionKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "SectionKind({self})")
    }
}

/// One section as found in a container.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Section<'a> {
    /// The kind code.
    pub kind: SectionKind,
    /// Byte offset of the section's first byte (its kind code) in the container.
    pub offset: u64,
    /// The payload, checksum verified.
    pub payload: &'a [u8],
    /// Bytes of framing around the payload: kind, length and CRC.
    pub overhead: usize,
}

impl Section<'_> {
    /// Bytes the section occupies in the container, overhead included.
    pub fn total_len(&self) -> usize {
        self.payload.len() + self.overhead
    }
}

/// A parsed container: its version and the sections whose checksums verified.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Container<'a> {
    /// The format version in the preamble.
    pub version: u16,
    /// Every whole section, in file order, up to and including the end marker.
    pub sections: Vec<Section<'a>>,
    /// Whether the end marker was found. A container read with
    /// [`Container::parse_prefix`] may stop early.
    pub complete: bool,
}

impl<'a> Container<'a> {
    /// Parses a complete container: every section must be whole, checksums must match,
    /// and the end marker must be the last thing in the bytes.
    pub fn parse(bytes: &'a [u8], limits: &Limits) -> Result<Self, Error> {
        let c = Self::parse_inner(bytes, limits, false)?;
        if !c.complete {
            return Err(Error::Truncated {
                what: format!("no end marker after {} bytes", bytes.len()),
            });
        }
        Ok(c)
    }

    /// Parses as much of a possibly cut-off container as is whole. A section cut off in
    /// the middle ends the list without error (so a decoder can use the levels before
    /// it); a checksum mismatch in a whole section is still an error.
    pub fn parse_prefix(bytes: &'a [u8], limits: &Limits) -> Result<Self, Error> {
        Self::parse_inner(bytes, limits, true)
    }

    fn parse_inner(bytes: &'a [u8], limits: &Limits, lenient: bool) -> Result<Self, Error> {
        if bytes.len() < MAGIC.len() {
            if MAGIC.starts_with(bytes) && !bytes.is_empty() {
                return Err(Error::Truncated {
                    what: format!("only {} bytes, not even the magic", bytes.len()),
                });
            }
            return Err(Error::BadMagic);
        }
        if bytes[..MAGIC.len()] != MAGIC {
            return Err(Error::BadMagic);
        }
        if bytes.len() < PREAMBLE_LEN {
            return Err(Error::Truncated {
                what: "the preamble (version) is cut off".into(),
            });
        }
        let version = u16::from_le_bytes([bytes[8], bytes[9]]);
        if version > FORMAT_VERSION {
            return Err(Error::NewerVersion {
                found: version,
                supported: FORMAT_VERSION,
            });
        }
        if version < FORMAT_VERSION {
            if version == 0 {
                return Err(Error::malformed(8, "format version 0 does not exist"));
            }
            return Err(Error::OlderVersion {
                found: version,
                supported: FORMAT_VERSION,
            });
        }
        let reserved = u16::from_le_bytes([bytes[10], bytes[11]]);
        if reserved != 0 {
            return Err(Error::malformed(
                10,
                format!("reserved preamble field is {reserved:#06x}, must be 0"),
            ));
        }
        let mut sections = Vec::new();
        let mut pos = PREAMBLE_LEN;
        let mut complete = false;
        while pos < bytes.len() {
            if sections.len() >= limits.max_sections {
                return Err(Error::Limit {
                    what: "sections",
                    requested: sections.len() as u64 + 1,
                    limit: limits.max_sections as u64,
                });
            }
            let rest = &bytes[pos..];
            let Some((kind, len, head)) = frame(rest, pos)? else {
                if lenient {
                    break;
                }
                return Err(Error::Truncated {
                    what: format!("section header at byte {pos} is cut off"),
                });
            };
            if len > limits.max_section_bytes {
                return Err(Error::Limit {
                    what: "section length",
                    requested: len,
                    limit: limits.max_section_bytes,
                });
            }
            // len < 2^32, so this cannot overflow u64.
            let needed = len + head as u64 + 4;
            if needed > rest.len() as u64 {
                if lenient {
                    break;
                }
                return Err(Error::Truncated {
                    what: format!(
                        "section {kind} at byte {pos} declares {len} payload bytes, only {} remain",
                        rest.len().saturating_sub(head + 4)
                    ),
                });
            }
            let len = len as usize;
            let payload = &rest[head..head + len];
            let c = head + len;
            let crc_stored = u32::from_le_bytes([rest[c], rest[c + 1], rest[c + 2], rest[c + 3]]);
            if section_crc(&rest[..c]) != crc_stored {
                return Err(Error::Checksum {
                    kind,
                    offset: pos as u64,
                });
            }
            sections.push(Section {
                kind,
                offset: pos as u64,
                payload,
                overhead: head + 4,
            });
            pos += needed as usize;
            if kind == SectionKind::END {
                if !payload.is_empty() {
                    return Err(Error::malformed(
                        pos as u64,
                        "end marker section must be empty",
                    ));
                }
                complete = true;
                break;
            }
        }
        if complete && pos != bytes.len() {
            return Err(Error::malformed(
                pos as u64,
                format!("{} bytes after the end marker", bytes.len() - pos),
            ));
        }
        Ok(Container {
            version,
            sections,
            complete,
        })
    }
}

/// A section's kind, payload length and header length: one kind byte and a canonical
/// varint length below 2^32 (SPEC.md 2.2); `Ok(None)` if the header is cut off, an error
/// if it is malformed (`pos`: the section's offset).
fn frame(rest: &[u8], pos: usize) -> Result<Option<(SectionKind, u64, usize)>, Error> {
    let Some(&code) = rest.first() else {
        return Ok(None);
    };
    let kind = SectionKind::from_code(code).ok_or_else(|| {
        Error::malformed(pos as u64, format!("unknown section kind byte {code:#04x}"))
    })?;
    let mut len = 0u64;
    for i in 0..MAX_LENGTH_BYTES {
        let Some(&b) = rest.get(1 + i) else {
            return Ok(None);
        };
        len |= ((b & 0x7f) as u64) << (7 * i);
        if b & 0x80 == 0 {
            if i > 0 && b == 0 {
                return Err(Error::malformed(
                    pos as u64 + 1,
                    format!("section {kind}: overlong length varint"),
                ));
            }
            if len > u32::MAX as u64 {
                return Err(Error::malformed(
                    pos as u64 + 1,
                    format!("section {kind}: length {len} is 4 GiB or more"),
                ));
            }
            return Ok(Some((kind, len, 2 + i)));
        }
    }
    Err(Error::malformed(
        pos as u64 + 1,
        format!("section {kind}: length varint longer than {MAX_LENGTH_BYTES} bytes"),
    ))
}

/// A section's checksum (SPEC.md 2.2): CRC-32 of the format version (two bytes,
/// little-endian), then the section's kind byte, length and payload, so that no bit flip
/// in the preamble's version can pass for another version.
pub fn section_crc(section: &[u8]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(&FORMAT_VERSION.to_le_bytes());
    h.update(section);
    h.finalize()
}

/// Writes a container: preamble, then sections in the order given, then the end marker.
#[derive(Debug, Clone)]
pub struct ContainerWriter {
    out: Vec<u8>,
}

impl Default for ContainerWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl ContainerWriter {
    /// Starts a container with the preamble of [`FORMAT_VERSION`].
    pub fn new() -> Self {
        let mut out = Vec::with_capacity(1024);
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        ContainerWriter { out }
    }

    /// Appends one section.
    ///
    /// # Panics
    /// If the payload is 4 GiB or more (no encoder output comes near that; the codec
    /// checks its inputs against [`Limits`] first), or the kind is not one of
    /// [`SectionKind`]'s constants.
    pub fn section(&mut self, kind: SectionKind, payload: &[u8]) {
        let len = u32::try_from(payload.len()).expect("section payload under 4 GiB");
        let start = self.out.len();
        let code = kind.code().expect("a known section kind");
        self.out.push(code);
        let mut length = ByteWriter::new();
        length.varint(len as u64);
        self.out.extend_from_slice(&length.out);
        self.out.extend_from_slice(payload);
        let crc = section_crc(&self.out[start..]);
        self.out.extend_from_slice(&crc.to_le_bytes());
    }

    /// Appends the end marker and returns the bytes.
    pub fn finish(mut self) -> Vec<u8> {
        self.section(SectionKind::END, &[]);
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<u8> {
        let mut w = ContainerWriter::new();
        w.section(SectionKind::HEADER, &[1, 2, 3]);
        w.section(SectionKind::BASE, &[9; 40]);
        w.finish()
    }

    #[test]
    fn round_trip() {
        let b = sample();
        let c = Container::parse(&b, &Limits::default()).unwrap();
        assert_eq!(c.version, FORMAT_VERSION);
        assert_eq!(c.sections.len(), 3);
        assert_eq!(c.sections[1].payload, &[9; 40][..]);
        assert_eq!(c.sections[2].kind, SectionKind::END);
    }

    #[test]
    fn every_bit_flip_is_an_error() {
        let b = sample();
        for i in 0..b.len() * 8 {
            let mut x = b.clone();
            x[i / 8] ^= 1 << (i % 8);
            assert!(
                Container::parse(&x, &Limits::default()).is_err(),
                "flip of bit {i} went unnoticed"
            );
        }
    }

    #[test]
    fn every_truncation_is_an_error() {
        let b = sample();
        for n in 0..b.len() {
            assert!(Container::parse(&b[..n], &Limits::default()).is_err());
        }
    }

    #[test]
    fn prefix_keeps_whole_sections() {
        let b = sample();
        let cut = PREAMBLE_LEN + section_overhead(3) + 3 + 5;
        let c = Container::parse_prefix(&b[..cut], &Limits::default()).unwrap();
        assert!(!c.complete);
        assert_eq!(c.sections.len(), 1);
    }

    #[test]
    fn specific_errors() {
        let b = sample();
        let mut x = b.clone();
        x[0] = b'P';
        assert_eq!(
            Container::parse(&x, &Limits::default()),
            Err(Error::BadMagic)
        );
        let mut x = b.clone();
        x[8..10].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
        assert!(matches!(
            Container::parse(&x, &Limits::default()),
            Err(Error::NewerVersion { found, .. }) if found == FORMAT_VERSION + 1
        ));
        // A section declaring 2^32 - 1 payload bytes.
        let mut x = b[..PREAMBLE_LEN].to_vec();
        x.extend_from_slice(&[b'B', 0xff, 0xff, 0xff, 0xff, 0x0f, 1, 2, 3]);
        let limits = Limits {
            max_section_bytes: 1 << 20,
            ..Limits::default()
        };
        assert!(matches!(
            Container::parse(&x, &limits),
            Err(Error::Limit {
                what: "section length",
                ..
            })
        ));
        let mut x = b.clone();
        x.push(0);
        assert!(matches!(
            Container::parse(&x, &Limits::default()),
            Err(Error::Malformed { .. })
        ));
    }

    #[test]
    fn other_versions_are_refused_by_name() {
        for version in [1, 18, FORMAT_VERSION - 1] {
            let mut older = sample();
            older[8..10].copy_from_slice(&version.to_le_bytes());
            let e = Container::parse(&older, &Limits::default()).unwrap_err();
            assert_eq!(
                e,
                Error::OlderVersion {
                    found: version,
                    supported: FORMAT_VERSION
                }
            );
            assert!(e
                .to_string()
                .contains(&format!("format version {version} ")));
        }
        let mut zero = sample();
        zero[8..10].copy_from_slice(&0u16.to_le_bytes());
        assert!(matches!(
            Container::parse(&zero, &Limits::default()),
            Err(Error::Malformed { offset: 8, .. })
        ));
    }

    #[test]
    fn compact_sections_take_their_overhead() {
        for n in [0usize, 1, 127, 128, 16_383, 16_384, 2_097_152] {
            let mut w = ContainerWriter::new();
            w.section(SectionKind::LEVEL, &vec![3; n]);
            let b = w.finish();
            let c = Container::parse(&b, &Limits::default()).unwrap();
            let s = &c.sections[0];
            assert_eq!(s.payload.len(), n);
            assert_eq!(s.total_len(), n + section_overhead(n));
            assert_eq!(b.len(), PREAMBLE_LEN + s.total_len() + 6, "{n}");
        }
        assert_eq!(section_overhead(127), 6);
        assert_eq!(section_overhead(128), 7);
    }

    #[test]
    fn malformed_compact_headers() {
        let pre = &sample()[..PREAMBLE_LEN];
        let parse = |tail: &[u8]| {
            let mut b = pre.to_vec();
            b.extend_from_slice(tail);
            Container::parse(&b, &Limits::default()).map(|c| c.sections.len())
        };
        let malformed = |r: Result<usize, Error>, what: &str| match r {
            Err(Error::Malformed { what: w, .. }) => assert!(w.contains(what), "{w}"),
            other => panic!("{what}: {other:?}"),
        };
        malformed(parse(&[b'X', 0, 0, 0, 0, 0]), "unknown section kind");
        malformed(parse(&[b'h', 0, 0, 0, 0, 0]), "unknown section kind");
        malformed(parse(&[b'L', 0x80, 0x00, 0, 0, 0, 0]), "overlong");
        malformed(parse(&[b'L', 0x80, 0x80, 0x80, 0x80, 0x10, 0]), "4 GiB");
        malformed(
            parse(&[b'L', 0x80, 0x80, 0x80, 0x80, 0x80, 0]),
            "longer than",
        );
        // Cut off inside the length: truncated, and a prefix ends before it.
        assert!(matches!(parse(&[b'L', 0x80]), Err(Error::Truncated { .. })));
        let mut b = pre.to_vec();
        b.extend_from_slice(&[b'L', 0x80]);
        let c = Container::parse_prefix(&b, &Limits::default()).unwrap();
        assert!(c.sections.is_empty() && !c.complete);
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_sections_round_trip(payloads in proptest::collection::vec(proptest::collection::vec(0u8..=255, 0..200), 0..8)) {
            let mut w = ContainerWriter::new();
            for p in &payloads {
                w.section(SectionKind::LEVEL, p);
            }
            let b = w.finish();
            let c = Container::parse(&b, &Limits::default()).unwrap();
            proptest::prop_assert_eq!(c.sections.len(), payloads.len() + 1);
            for (s, p) in c.sections.iter().zip(&payloads) {
                proptest::prop_assert_eq!(s.payload, &p[..]);
            }
        }

        #[test]
        fn arbitrary_bytes_never_panic(data in proptest::collection::vec(0u8..=255, 0..300)) {
            let _ = Container::parse(&data, &Limits::default());
            let mut with_magic = sample()[..PREAMBLE_LEN].to_vec();
            with_magic.extend_from_slice(&data);
            let _ = Container::parse(&with_magic, &Limits::default());
            let _ = Container::parse_prefix(&with_magic, &Limits::default());
        }
    }
}

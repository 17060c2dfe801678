//! subwave's codec: the integer mesh model, mesh file I/O, quantisation, entropy coding
//! and the container's sections. Most users want the facade crate `subwave`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// Numeric kernels index several arrays (axes, positions, weights) in lockstep.
#![allow(clippy::needless_range_loop)]

pub mod coder;
pub mod error;
pub mod flat;
pub mod header;
pub mod io;
pub mod mesh;
pub mod order;
pub mod quant;

pub use error::{Error, Result};
pub use header::{Family, Header, Source, Transform};
pub use mesh::{Mesh, MAX_COORD};
pub use quant::{FloatWidth, Quantization, RawCoords};
pub use subwave_container::{Limits, FORMAT_VERSION};

use subwave_container::{Container, ContainerWriter, SectionKind};

/// How to encode.
#[derive(Debug, Clone)]
pub struct EncodeOptions {
    /// Store the permutation back to the input's vertex order (ORDR section).
    pub keep_order: bool,
    /// The format the mesh was read from, recorded so decoding can default to it.
    pub source: Source,
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            keep_order: false,
            source: Source::Unknown,
        }
    }
}

/// One section's place in a container.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SectionInfo {
    /// Its kind code, as text (`HEAD`, `BASE`, ...).
    pub kind: String,
    /// Bytes it occupies, overhead included.
    pub bytes: usize,
}

/// The result of [`encode`].
#[derive(Debug, Clone)]
pub struct Encoded {
    /// The container.
    pub bytes: Vec<u8>,
    /// `order[i]` is the input index of decoded vertex `i` (when the container has no
    /// ORDR section; with one, decoding restores the input order itself).
    pub order: Vec<u32>,
    /// The header written.
    pub header: Header,
    /// Sections written, in order.
    pub sections: Vec<SectionInfo>,
}

/// Encodes an integer mesh whose values map to the file's through `q`.
pub fn encode(mesh: &Mesh, q: &Quantization, opts: &EncodeOptions) -> Result<Encoded> {
    mesh.validate()?;
    let order = flat::canonical_order(mesh);
    let canon = flat::permute(mesh, &order);
    let header = Header {
        vertices: mesh.vertex_count() as u64,
        faces: mesh.face_count() as u64,
        corners: mesh.corner_count() as u64,
        base_vertices: mesh.vertex_count() as u64,
        base_faces: mesh.face_count() as u64,
        base_corners: mesh.corner_count() as u64,
        levels: 0,
        family: Family::None,
        transform: Transform::None,
        quantization: *q,
        source: opts.source,
        has_order: opts.keep_order,
    };
    let mut w = ContainerWriter::new();
    let mut sections = Vec::new();
    let mut put = |w: &mut ContainerWriter, kind: SectionKind, payload: &[u8]| {
        if payload.len() >= u32::MAX as usize {
            return Err(Error::Range(format!(
                "section {kind} would be {} bytes, over the format's 4 GiB",
                payload.len()
            )));
        }
        w.section(kind, payload);
        sections.push(SectionInfo {
            kind: kind.to_string(),
            bytes: payload.len() + subwave_container::SECTION_OVERHEAD,
        });
        Ok(())
    };
    put(&mut w, SectionKind::HEADER, &header.write())?;
    put(&mut w, SectionKind::BASE, &flat::encode(&canon))?;
    if opts.keep_order {
        put(&mut w, SectionKind::ORDER, &order::encode(&order))?;
    }
    let bytes = w.finish();
    sections.push(SectionInfo {
        kind: SectionKind::END.to_string(),
        bytes: subwave_container::SECTION_OVERHEAD,
    });
    Ok(Encoded {
        bytes,
        order,
        header,
        sections,
    })
}

/// How to decode.
#[derive(Debug, Clone, Default)]
pub struct DecodeOptions {
    /// Bounds on what the container may ask for.
    pub limits: Limits,
    /// Decode only up to this level (0 = the base mesh). The container may then be cut
    /// off anywhere after that level's section.
    pub max_level: Option<u8>,
}

/// The result of [`decode`].
#[derive(Debug, Clone)]
pub struct Decoded {
    /// The mesh, in the input's vertex order when the container has an ORDR section and
    /// the finest level was decoded, in canonical order otherwise.
    pub mesh: Mesh,
    /// How integers map to values.
    pub quantization: Quantization,
    /// The container's header.
    pub header: Header,
    /// The level decoded (0 = base mesh).
    pub level: u8,
    /// Whether the vertices are in the input's order.
    pub input_order: bool,
}

/// A parsed header and section table, without decoding any geometry.
#[derive(Debug, Clone)]
pub struct Info {
    /// Format version of the container.
    pub version: u16,
    /// The header.
    pub header: Header,
    /// Sections, in order.
    pub sections: Vec<SectionInfo>,
    /// Total bytes.
    pub bytes: usize,
}

fn expect_kind(c: &Container<'_>, i: usize, kind: SectionKind, what: &str) -> Result<()> {
    match c.sections.get(i) {
        Some(s) if s.kind == kind => Ok(()),
        Some(s) => Err(subwave_container::Error::malformed(
            s.offset,
            format!("expected the {what} section ({kind}), found {}", s.kind),
        )
        .into()),
        None => Err(subwave_container::Error::Truncated {
            what: format!("the {what} section ({kind}) is missing"),
        }
        .into()),
    }
}

/// Reads the header and section table (SPEC.md 2, 5), checking every checksum.
pub fn inspect(bytes: &[u8], limits: &Limits) -> Result<Info> {
    let c = Container::parse(bytes, limits)?;
    let header = layout(&c, limits, true)?;
    Ok(Info {
        version: c.version,
        header,
        sections: c
            .sections
            .iter()
            .map(|s| SectionInfo {
                kind: s.kind.to_string(),
                bytes: s.total_len(),
            })
            .collect(),
        bytes: bytes.len(),
    })
}

/// Checks the section sequence (SPEC.md 2.4) and returns the header. With `whole`, the
/// container must hold every section; otherwise a prefix is fine.
fn layout(c: &Container<'_>, limits: &Limits, whole: bool) -> Result<Header> {
    expect_kind(c, 0, SectionKind::HEADER, "header")?;
    let h = Header::read(c.sections[0].payload, c.sections[0].offset + 8, limits)?;
    let mut expected = vec![(SectionKind::BASE, "base mesh")];
    expected.extend((0..h.levels).map(|_| (SectionKind::LEVEL, "level")));
    if h.has_order {
        expected.push((SectionKind::ORDER, "vertex order"));
    }
    expected.push((SectionKind::END, "end marker"));
    for (i, &(kind, what)) in expected.iter().enumerate() {
        if !whole && i + 1 >= c.sections.len() {
            break;
        }
        expect_kind(c, i + 1, kind, what)?;
    }
    if c.sections.len() > expected.len() + 1 {
        let s = &c.sections[expected.len() + 1];
        return Err(
            subwave_container::Error::malformed(s.offset, "section after the end marker").into(),
        );
    }
    Ok(h)
}

/// Decodes a container (SPEC.md 2-7).
pub fn decode(bytes: &[u8], opts: &DecodeOptions) -> Result<Decoded> {
    let limits = &opts.limits;
    let c = if opts.max_level.is_some() {
        Container::parse_prefix(bytes, limits)?
    } else {
        Container::parse(bytes, limits)?
    };
    let h = layout(&c, limits, opts.max_level.is_none())?;
    let level = opts.max_level.map_or(h.levels, |k| k.min(h.levels));
    // Sections needed: header, base, `level` levels.
    let needed = 2 + level as usize;
    if c.sections.len() < needed {
        return Err(subwave_container::Error::Truncated {
            what: format!(
                "level {level} needs {needed} sections, the file holds {} whole ones",
                c.sections.len()
            ),
        }
        .into());
    }
    let base = flat::decode(
        c.sections[1].payload,
        h.base_vertices,
        h.base_faces,
        h.base_corners,
    )?;
    let mut mesh = base;
    let mut input_order = false;
    if h.has_order && level == h.levels {
        if let Some(s) = c.sections.get(2 + h.levels as usize) {
            let order = order::decode(s.payload, mesh.vertex_count())?;
            mesh = unpermute(&mesh, &order);
            input_order = true;
        }
    }
    Ok(Decoded {
        mesh,
        quantization: h.quantization,
        header: h,
        level,
        input_order,
    })
}

/// Undoes [`flat::permute`]: `order[new] = old`.
fn unpermute(mesh: &Mesh, order: &[u32]) -> Mesh {
    let mut positions = vec![[0i64; 3]; order.len()];
    for (new, &old) in order.iter().enumerate() {
        positions[old as usize] = mesh.positions[new];
    }
    Mesh {
        positions,
        face_starts: mesh.face_starts.clone(),
        faces: mesh.faces.iter().map(|&v| order[v as usize]).collect(),
    }
}

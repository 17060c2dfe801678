//! # subwave
//!
//! A lossless integer geometry codec for polygon meshes, aimed at meshes with
//! subdivision connectivity. Mesh file in, small container out, and back, value for
//! value.
//!
//! ```
//! let obj = b"v 0.0 0.0 0.0\nv 1.0 0.0 0.0\nv 1.0 1.0 0.0\nv 0.0 1.0 0.5\nf 1 2 3 4\n";
//! let input = subwave::load(obj, None).unwrap();          // exact: the file's own decimals
//! let enc = subwave::encode_to_vec(&input.mesh, &input.quantization,
//!     &subwave::EncodeOptions { keep_order: true, ..Default::default() }).unwrap();
//! let dec = subwave::decode_slice(&enc.bytes).unwrap();
//! assert_eq!(dec.mesh, input.mesh);                        // every integer, in input order
//! let mut out = Vec::new();
//! subwave::write_mesh(&mut out, &dec.mesh, &dec.quantization, subwave::Format::Obj).unwrap();
//! assert_eq!(out, obj);                                    // and the same text
//! ```
//!
//! The container layout and every arithmetic rule are specified in `SPEC.md`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
/// The README's examples, run as doctests.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

use std::collections::BTreeSet;

use subwave_codec::Domain as ChannelDomain;

pub mod json;

pub use subwave_codec::io::{
    read_mesh, write_mesh, writes_attribute, Format, RawAttribute, RawMesh,
};
pub use subwave_codec::{
    decode, encode, encode_file, fit_rules, inspect, integerize, Attribute, AttributeInfo, Decimal,
    DecodeOptions, Decoded, DiscTransform, Domain, EncodeOptions, Encoded, Error, Family,
    FloatWidth, Header, Info, Limits, Mesh, Progress, Quantization, RawCoords, Result, SectionInfo,
    Source, Stage, Transform, TransformChoice, ValueType, Wavelet, DEFAULT_EFFORT, FORMAT_VERSION,
    MAX_ATTRIBUTES, MAX_COORD, MAX_DECIMALS, MAX_EFFORT, NO_ENTRY,
};

/// A mesh file read and turned into integers.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The integer mesh, in the file's vertex and face order.
    pub mesh: Mesh,
    /// How its integers map back to the file's values.
    pub quantization: Quantization,
    /// The format that was read.
    pub format: Format,
    /// What the file had that its [`Mesh`] does not carry (neither positions, faces
    /// nor an attribute channel): kept only by [`encode_file`]'s template.
    pub dropped: BTreeSet<String>,
}

impl Loaded {
    /// The [`Source`] to record for this file's format.
    pub fn source(&self) -> Source {
        match self.format {
            Format::Obj => Source::Obj,
            Format::PlyAscii => Source::PlyAscii,
            Format::PlyBinary | Format::PlyBinaryBigEndian => Source::PlyBinary,
            Format::Off => Source::Off,
            Format::StlAscii => Source::StlAscii,
            Format::StlBinary => Source::StlBinary,
        }
    }
}

/// Reads a mesh file (OBJ, PLY, OFF or STL, sniffed from its bytes) and turns its positions
/// into integers: exactly when `bits` is `None` (decimal text on its grid, binary floats
/// and text beyond any decimal grid as the floats they are, bit for bit), on Draco's
/// `bits`-bit grid otherwise.
pub fn load(bytes: &[u8], bits: Option<u8>) -> Result<Loaded> {
    let raw = read_mesh(bytes)?;
    let (positions, quantization, floats) = subwave_codec::integerize(&raw.coords, bits)?;
    let mut mesh = raw.topology;
    mesh.positions = positions;
    mesh.floats = floats;
    let mut dropped = raw.dropped;
    for a in &raw.attributes {
        match a.integerize() {
            Ok(a) if mesh.attributes.len() < subwave_codec::MAX_ATTRIBUTES => {
                mesh.attributes.push(a)
            }
            Ok(_) => {
                dropped.insert(format!(
                    "attribute '{}': more than {} channels",
                    a.name,
                    subwave_codec::MAX_ATTRIBUTES
                ));
            }
            Err(e) => {
                dropped.insert(format!("attribute '{}': {e}", a.name));
            }
        }
    }
    mesh.validate()?;
    Ok(Loaded {
        mesh,
        quantization,
        format: raw.format,
        dropped,
    })
}

/// Encodes a mesh into a new container.
pub fn encode_to_vec(mesh: &Mesh, q: &Quantization, opts: &EncodeOptions) -> Result<Encoded> {
    encode(mesh, q, opts)
}

/// Decodes a whole container with the default [`Limits`].
pub fn decode_slice(bytes: &[u8]) -> Result<Decoded> {
    decode(bytes, &DecodeOptions::default())
}

/// The format to write when the output's name does not say: the input's own format.
pub fn default_output_format(source: Source) -> Format {
    match source {
        Source::PlyAscii => Format::PlyAscii,
        Source::PlyBinary => Format::PlyBinary,
        Source::Off => Format::Off,
        Source::StlAscii => Format::StlAscii,
        Source::StlBinary => Format::StlBinary,
        Source::Obj | Source::Unknown => Format::Obj,
    }
}

/// Checks that `decoded` is `original` with its vertices renumbered by `order`
/// (`order[i]` = the original index of decoded vertex `i`): every position equal, and
/// the same faces (each with the same cyclic order and orientation) in any face order,
/// and every attribute channel's values at each vertex, face and face corner equal (a
/// channel of names by its names). Returns a description of the first difference.
pub fn compare_up_to_order(
    original: &Mesh,
    decoded: &Mesh,
    order: &[u32],
) -> std::result::Result<(), String> {
    if decoded.vertex_count() != original.vertex_count() || order.len() != decoded.vertex_count() {
        return Err(format!(
            "{} vertices decoded, {} expected",
            decoded.vertex_count(),
            original.vertex_count()
        ));
    }
    if decoded.face_count() != original.face_count() {
        return Err(format!(
            "{} faces decoded, {} expected",
            decoded.face_count(),
            original.face_count()
        ));
    }
    if decoded.floats.len() != original.floats.len() {
        return Err(format!(
            "{} float values decoded, {} expected",
            decoded.floats.len(),
            original.floats.len()
        ));
    }
    for (i, &o) in order.iter().enumerate() {
        let want = original
            .positions
            .get(o as usize)
            .ok_or_else(|| format!("order names vertex {o}, out of range"))?;
        if let (Some(d), Some(w)) = (decoded.floats.get(i), original.floats.get(o as usize)) {
            if d != w {
                return Err(format!(
                    "vertex {} decoded with float bits {d:x?}, expected {w:x?}",
                    o + 1
                ));
            }
        }
        if decoded.positions[i] != *want {
            return Err(format!(
                "vertex {} decoded as {:?}, expected {:?}",
                o + 1,
                decoded.positions[i],
                want
            ));
        }
    }
    if !original.attributes.is_empty() || !decoded.attributes.is_empty() {
        return compare_channels(original, decoded, order);
    }
    // The smallest rotation: a face with a repeated corner has several starting at its
    // smallest vertex.
    let canon = |face: &[u32]| smallest_rotation(face);
    let mut a: Vec<Vec<u32>> = original.iter_faces().map(canon).collect();
    let mut b: Vec<Vec<u32>> = decoded
        .iter_faces()
        .map(|f| canon(&f.iter().map(|&v| order[v as usize]).collect::<Vec<_>>()))
        .collect();
    a.sort_unstable();
    b.sort_unstable();
    if let Some(i) = (0..a.len()).find(|&i| a[i] != b[i]) {
        return Err(format!(
            "faces differ: expected {:?}, decoded {:?}",
            a[i], b[i]
        ));
    }
    Ok(())
}

/// The smallest of a face's rotations (of its corners, or of what stands at them).
fn smallest_rotation<T: Ord + Clone>(face: &[T]) -> Vec<T> {
    (0..face.len())
        .map(|k| {
            face[k..]
                .iter()
                .chain(&face[..k])
                .cloned()
                .collect::<Vec<T>>()
        })
        .min()
        .unwrap_or_default()
}

/// [`compare_up_to_order`]'s faces and channels, for meshes with channels: each face as
/// its corners (the original vertex, then every channel's values there) from its
/// smallest rotation, and its per-face values, compared as sorted lists.
fn compare_channels(
    original: &Mesh,
    decoded: &Mesh,
    order: &[u32],
) -> std::result::Result<(), String> {
    if original.attributes.len() != decoded.attributes.len() {
        return Err(format!(
            "{} attribute channels decoded, {} expected",
            decoded.attributes.len(),
            original.attributes.len()
        ));
    }
    for (a, b) in original.attributes.iter().zip(&decoded.attributes) {
        if (&a.name, a.domain, a.width, a.value_type) != (&b.name, b.domain, b.width, b.value_type)
        {
            return Err(format!("channel '{}' decoded as '{}'", a.name, b.name));
        }
    }
    // An entry as numbers: its values and float bits, or its name.
    fn entry(a: &subwave_codec::Attribute, e: usize, out: &mut Vec<String>) {
        if !a.labels.is_empty() {
            let v = a.values[e][0];
            out.push(format!("{:?}", a.label(v)));
            return;
        }
        for k in 0..a.width as usize {
            out.push(format!("{:x}", a.value_f64(e, k).to_bits()));
        }
    }
    // A vertex's, face's or record's values: its entry, or its list's.
    // (`lists`: a list channel's records, [`subwave_codec::Attribute::list`].)
    type Lists = [std::ops::Range<usize>];
    fn record(a: &subwave_codec::Attribute, lists: &Lists, r: usize, out: &mut Vec<String>) {
        if !a.is_list() {
            return entry(a, r, out);
        }
        if let Some(items) = lists.get(r) {
            out.push(items.len().to_string());
            items.clone().for_each(|e| entry(a, e, out));
        }
    }
    let lists = |m: &Mesh| -> Vec<Vec<std::ops::Range<usize>>> {
        m.attributes.iter().map(|a| a.list().collect()).collect()
    };
    let (lists_a, lists_b) = (lists(original), lists(decoded));
    // Per-vertex values at every vertex (those no face uses too).
    for (k, (a, b)) in original
        .attributes
        .iter()
        .zip(&decoded.attributes)
        .enumerate()
    {
        if a.domain != ChannelDomain::Vertex {
            continue;
        }
        for (i, &o) in order.iter().enumerate() {
            let (mut x, mut y) = (Vec::new(), Vec::new());
            record(a, &lists_a[k], o as usize, &mut x);
            record(b, &lists_b[k], i, &mut y);
            if x != y {
                return Err(format!(
                    "'{}' of vertex {} decoded as {y:?}, expected {x:?}",
                    a.name,
                    o + 1
                ));
            }
        }
    }
    // Per-file entries in their order, vertex numbers as the vertices are numbered.
    for (a, b) in original.attributes.iter().zip(&decoded.attributes) {
        if a.domain != ChannelDomain::File {
            continue;
        }
        let mut a = a.clone();
        a.values = a.renumbered(order);
        let (mut x, mut y) = (
            vec![format!("{:?}", a.indices)],
            vec![format!("{:?}", b.indices)],
        );
        (0..a.entry_count()).for_each(|e| entry(&a, e, &mut x));
        (0..b.entry_count()).for_each(|e| entry(b, e, &mut y));
        if x != y {
            return Err(format!("'{}' decoded with other entries", a.name));
        }
    }
    let faces = |m: &Mesh, vertex: &dyn Fn(u32) -> u32| -> Vec<Vec<Vec<String>>> {
        let ranges = lists(m);
        let mut all: Vec<Vec<Vec<String>>> = (0..m.face_count())
            .map(|f| {
                let s = m.face_starts[f] as usize;
                let face = m.face(f);
                let corners: Vec<Vec<String>> = face
                    .iter()
                    .enumerate()
                    .map(|(j, &v)| {
                        let mut c = vec![vertex(v).to_string()];
                        for (a, l) in m.attributes.iter().zip(&ranges) {
                            match a.domain {
                                ChannelDomain::Vertex => record(a, l, v as usize, &mut c),
                                ChannelDomain::Corner => match a.indices[s + j] {
                                    subwave_codec::NO_ENTRY => c.push("none".into()),
                                    e => entry(a, e as usize, &mut c),
                                },
                                ChannelDomain::Face | ChannelDomain::File => {}
                            }
                        }
                        c
                    })
                    .collect();
                let mut best = smallest_rotation(&corners);
                let mut own = Vec::new();
                for (a, l) in m.attributes.iter().zip(&ranges) {
                    if a.domain != ChannelDomain::Face {
                        continue;
                    }
                    record(a, l, f, &mut own);
                }
                best.push(own);
                best
            })
            .collect();
        all.sort_unstable();
        all
    };
    let a = faces(original, &|v| v);
    let b = faces(decoded, &|v| order[v as usize]);
    match (0..a.len()).find(|&i| a[i] != b[i]) {
        Some(i) => Err(format!(
            "faces or their channels differ: expected {:?}, decoded {:?}",
            a[i], b[i]
        )),
        None => Ok(()),
    }
}

/// Decodes into `out`, reusing its buffers (whatever they held is replaced).
pub fn decode_into(bytes: &[u8], opts: &DecodeOptions, out: &mut Mesh) -> Result<Decoded> {
    let d = decode(bytes, opts)?;
    out.positions.clear();
    out.positions.extend_from_slice(&d.mesh.positions);
    out.faces.clear();
    out.faces.extend_from_slice(&d.mesh.faces);
    out.face_starts.clear();
    out.face_starts.extend_from_slice(&d.mesh.face_starts);
    out.floats.clear();
    out.floats.extend_from_slice(&d.mesh.floats);
    out.attributes.clone_from(&d.mesh.attributes);
    Ok(d)
}

#[cfg(feature = "internals")]
#[doc(hidden)]
pub mod fuzz_harness;

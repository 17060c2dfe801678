//! The encoder: options, the container it writes, and the order it keeps (SPEC.md 2, 7).
//! Which hierarchy and transform codes smallest is the search's ([`search`]).

mod fitting;
mod search;

pub(crate) use fitting::*;
pub(crate) use search::*;

use std::collections::HashMap;

use crate::error::{Error, Result};
use crate::info::{section_info, SectionInfo};
use crate::io::template::{Attribute, Channels};
use crate::io::{self, Format};
use crate::mesh::{Mesh, NO_ENTRY};
use crate::quant::Quantization;
use crate::sections::attr;
use crate::sections::cidx;
use crate::sections::head::{Header, Source, Transform};
use crate::sections::nrml;
use crate::sections::vmap::ValueMap;
use crate::sections::{base, chan, fbit, levl, ordr, tmpl};
use crate::topology::{self, Canonical, Family, Level, Topo};
use crate::transform::level::{LevelTransform, Scheme};
use crate::transform::polar::DiscTransform;
use crate::transform::{fit, Wavelet};
use subwave_container::{ContainerWriter, SectionKind};

/// Which transform to use on a hierarchy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TransformChoice {
    /// Try every transform and keep the smallest container.
    #[default]
    Auto,
    /// This one.
    Fixed(Wavelet),
    /// The subdivision fit (SPEC.md 9.10) on a Catmull-Clark hierarchy.
    Fit,
}

/// How to encode.
#[derive(Debug, Clone)]
pub struct EncodeOptions {
    /// Store the input's vertex and face order (ORDR section).
    pub keep_order: bool,
    /// The format the mesh was read from, recorded so decoding can default to it.
    pub source: Source,
    /// The transform for subdivision levels.
    pub transform: TransformChoice,
    /// Most refinement levels to look for (0: code the mesh flat).
    pub max_levels: u8,
    /// Polar hierarchies: the transform of the poles' discs (SPEC.md 9.9); `None` tries
    /// each with the best Catmull-Clark transform and keeps the smallest.
    pub disc: Option<DiscTransform>,
    /// Per-axis value maps (SPEC.md 3.1): `None` tries the sparse axes' map beside no
    /// map and keeps the smaller container, `Some(true)` maps every axis, `Some(false)`
    /// none.
    pub value_map: Option<bool>,
    /// How many threads the encoder may use (0 counts as 1): `auto` then codes its
    /// candidate families and transforms at once. The container is the same for every
    /// count; each thread holds a coding's working memory.
    pub threads: usize,
    /// How hard the encoder searches, 1..=[`MAX_EFFORT`] (default [`DEFAULT_EFFORT`]; 0
    /// counts as 1, more as the most). At the most it codes every candidate hierarchy
    /// (a mesh and its dual), ranks every other transform of each family and codes the
    /// best of them in every level mode, ranks the polar discs' transforms, and tries
    /// the best coding again without the rotated modes; each lower effort leaves out
    /// one more search: 8 the retry without rotated modes, 7 the candidates but the
    /// preferred one, 6 codes only the transform of a short list whose details take
    /// the fewest bits (an estimate, no coding) and chooses a large level's mode on a
    /// sample of its details, 5 a shorter list, 4 no list, 3 no disc ranking, 2 no
    /// rotated level modes, 1 no subdivision fit. The container is
    /// the same for a given effort whatever the thread count, and every effort decodes
    /// the same way (it is the encoder's choice only).
    pub effort: u8,
    /// Where the encoder reports what it is doing (nothing by default).
    pub progress: Progress,
}

/// The most search effort: today's exhaustive `auto`.
pub const MAX_EFFORT: u8 = 9;

/// The default search effort: on `../shared/corpus` its median container is effort 9's,
/// about 1.5 x faster (`benches/RESULTS.md` has sizes and times per effort).
pub const DEFAULT_EFFORT: u8 = 6;

/// What the encoder tries at an effort ([`EncodeOptions::effort`]); each effort below the
/// most leaves out one more search, the one that gains least for its time on the shared
/// corpus (benches/RESULTS.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Effort {
    /// The subdivision fit where the finest level looks like one (`auto`): from 2.
    pub fit: bool,
    /// Levels try the rotated modes (SPEC.md 10.5): from 3.
    pub rotated: bool,
    /// A polar hierarchy's disc transforms are ranked (`auto`): from 4.
    pub discs: bool,
    /// Which of the family's other transforms `auto` ranks: none below 5,
    /// [`Effort::SHORTER_LIST`] at 5, [`Effort::SHORT_LIST`] at 6, every one (`None`)
    /// from 7.
    pub rank: Option<&'static [Wavelet]>,
    /// The family's first and listed transforms are ranked by their details' bits
    /// ([`search::detail_bits`], no coding) and the fewest coded alone, rather than
    /// ranked by coding them: at 5 and 6.
    pub estimated: bool,
    /// Every candidate hierarchy of a family is coded (a mesh and its dual; else the
    /// one recovery prefers): from 8.
    pub candidates: bool,
    /// The best coding is tried again without the rotated modes: at 9.
    pub unrotated: bool,
    /// A large level's mode is chosen by coding a sample of its details in each open
    /// mode, not all of them: below 7.
    pub sampled: bool,
    /// A mesh with a value map's candidate is coded as ranks or as values, as their
    /// estimates say, not both (`map_by_estimate`): below 7.
    pub map_estimated: bool,
}

/// How a coding chooses each level's mode (the encoder's choice, not part of the
/// format).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct ModeSearch {
    /// The rotated modes are tried (SPEC.md 10.5).
    pub rotated: bool,
    /// A large level's mode is chosen on a sample of its details.
    pub sampled: bool,
}

impl ModeSearch {
    /// Every mode, each coded whole.
    #[cfg(test)]
    pub(crate) const ALL: ModeSearch = ModeSearch {
        rotated: true,
        sampled: false,
    };
}

impl Effort {
    /// The transforms ranked at effort 6 beside each family's first: the Catmull-Clark
    /// ones that win most often (interp6, interp4, lazy). None of the sqrt(2) family:
    /// the details' bits do not see sqrt2-lazy's phases, and on the shared corpus ir2w
    /// never codes smaller (0.8 % to 48 % larger).
    pub(crate) const SHORT_LIST: &'static [Wavelet] =
        &[Wavelet::Interp6, Wavelet::Interp4, Wavelet::Lazy];
    /// The transforms ranked at effort 5.
    pub(crate) const SHORTER_LIST: &'static [Wavelet] = &[Wavelet::Interp6];

    pub(crate) fn of(effort: u8) -> Effort {
        let e = effort.clamp(1, MAX_EFFORT);
        Effort {
            fit: e >= 2,
            rotated: e >= 3,
            discs: e >= 4,
            rank: match e {
                0..=4 => Some(&[]),
                5 => Some(Self::SHORTER_LIST),
                6 => Some(Self::SHORT_LIST),
                _ => None,
            },
            estimated: (5..=6).contains(&e),
            candidates: e >= 8,
            unrotated: e >= 9,
            sampled: e <= 6,
            map_estimated: e <= 6,
        }
    }

    /// How its codings choose level modes.
    pub(crate) fn modes(self) -> ModeSearch {
        ModeSearch {
            rotated: self.rotated,
            sampled: self.sampled,
        }
    }
}

/// What the encoder is doing, as reported to a [`Progress`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Looking for the subdivision hierarchy (or hierarchies) in the mesh.
    Recovering,
    /// Coding a hierarchy's `level` (1-based) of `levels` with `transform`; `auto` codes
    /// several candidates, each through its levels.
    Level {
        /// The transform's name.
        transform: &'static str,
        /// The level being coded, from the coarsest (1).
        level: usize,
        /// The hierarchy's levels.
        levels: usize,
    },
    /// Coding the mesh without a hierarchy.
    Flat,
    /// Writing the container.
    Container,
}

/// A callback for the encoder's [`Stage`]s (from any of its threads); the default
/// reports nowhere.
#[derive(Clone, Default)]
pub struct Progress(Option<std::sync::Arc<dyn Fn(Stage) + Send + Sync>>);

impl Progress {
    /// Reports each stage to `f`.
    pub fn new(f: impl Fn(Stage) + Send + Sync + 'static) -> Self {
        Progress(Some(std::sync::Arc::new(f)))
    }

    pub(crate) fn report(&self, stage: Stage) {
        if let Some(f) = &self.0 {
            f(stage);
        }
    }
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() {
            "Progress(callback)"
        } else {
            "Progress(none)"
        })
    }
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            keep_order: false,
            source: Source::Unknown,
            transform: TransformChoice::Auto,
            max_levels: 16,
            disc: None,
            value_map: None,
            threads: 1,
            effort: DEFAULT_EFFORT,
            progress: Progress::default(),
        }
    }
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

/// Section payloads before they are wrapped in a container.
pub(crate) struct Payloads {
    pub(crate) header: Header,
    pub(crate) base: Vec<u8>,
    pub(crate) levels: Vec<Vec<u8>>,
    /// The ORDR section, when the input order is kept: it depends on the coded order,
    /// so candidates are compared with it.
    pub(crate) order: Option<Vec<u8>>,
}

impl Payloads {
    /// Bytes of the BASE and LEVL payloads: what the codings of one hierarchy differ by.
    fn coded(&self) -> usize {
        self.base.len() + self.levels.iter().map(Vec::len).sum::<usize>()
    }

    /// Bytes of the payloads that differ between codings: the header too (a fit's
    /// crease lists stand in it).
    fn size(&self) -> usize {
        self.coded() + self.order.as_ref().map_or(0, Vec::len) + self.header.write().len()
    }

    /// Each LEVL payload's mode byte, its flags included (SPEC.md 10.1):
    /// the plan of a coding in the same modes.
    fn modes(&self) -> Vec<u8> {
        self.levels
            .iter()
            .filter_map(|l| l.first().copied())
            .collect()
    }
}

/// The ORDR payload (SPEC.md 7): the coded vertex order (`vertices[coded] = input`),
/// face order and corner rotations, of the canonical faces `fine`.
pub(crate) fn order_section(
    vertices: &[u32],
    faces: Vec<u32>,
    rotations: Vec<u32>,
    canonical: ordr::Faces<'_>,
) -> Vec<u8> {
    let o = ordr::InputOrder {
        vertices: vertices.to_vec(),
        faces,
        rotations,
    };
    ordr::encode(&o, canonical)
}

/// The ORDR payload of a hierarchy coding `mesh`: its canonical order back to the
/// input's.
pub(crate) fn hierarchy_order(mesh: &Mesh, canon: &Canonical) -> Result<Vec<u8>> {
    let fine = canon.fine();
    let (faces, rotations) = face_order(mesh, &fine, &canon.order)?;
    let base = canon.levels.first().map(|l| &l.coarse);
    let canonical = ordr::Faces {
        nv: fine.nv,
        starts: &fine.starts,
        idx: &fine.idx,
        hierarchy: base
            .filter(|_| {
                matches!(
                    canon.family,
                    topology::Family::Cc | topology::Family::Sqrt2 | topology::Family::Polar
                )
            })
            .map(|b| ordr::Hierarchy {
                nv: b.nv,
                starts: &b.starts,
                idx: &b.idx,
                levels: canon.levels.len() as u32,
                family: canon.family,
                poles: &canon.poles,
            }),
    };
    Ok(order_section(&canon.order, faces, rotations, canonical))
}

pub(crate) fn flat_header(mesh: &Mesh, q: &Quantization, opts: &EncodeOptions) -> Header {
    Header {
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
        has_value_map: false,
        has_float_bits: !mesh.floats.is_empty(),
        has_template: false,
        has_corner_indices: false,
        has_normals: false,
        poles: Vec::new(),
        creases: Vec::new(),
        crease_sharpness: Vec::new(),
        vertex_creases: Vec::new(),
        vertex_sharpness: Vec::new(),
        seams: Vec::new(),
        disc: DiscTransform::None,
    }
}

/// Matches canonical faces to the input's: position and first corner (SPEC.md 7).
pub(crate) fn face_order(mesh: &Mesh, fine: &Topo, vorder: &[u32]) -> Result<(Vec<u32>, Vec<u32>)> {
    let mut by_edge: HashMap<(u32, u32), (u32, u32)> = HashMap::with_capacity(mesh.corner_count());
    for (j, face) in mesh.iter_faces().enumerate() {
        let k = face.len();
        for r in 0..k {
            by_edge.insert((face[r], face[(r + 1) % k]), (j as u32, r as u32));
        }
    }
    let mut perm = Vec::with_capacity(fine.nf());
    let mut rot = Vec::with_capacity(fine.nf());
    for c in 0..fine.nf() {
        let f = fine.face(c);
        let key = (vorder[f[0] as usize], vorder[f[1] as usize]);
        let &(j, r) = by_edge
            .get(&key)
            .ok_or_else(|| Error::InvalidMesh("hierarchy does not match the input faces".into()))?;
        perm.push(j);
        rot.push(r);
    }
    Ok((perm, rot))
}

/// The mesh's positions in a hierarchy's canonical order, per axis.
pub(crate) fn canonical_positions(mesh: &Mesh, canon: &Canonical) -> [Vec<i64>; 3] {
    // One pass over the order (each position read once, not once per axis).
    let mut x: [Vec<i64>; 3] = std::array::from_fn(|_| Vec::with_capacity(canon.order.len()));
    for &o in &canon.order {
        let p = mesh.positions[o as usize];
        for (xk, v) in x.iter_mut().zip(p) {
            xk.push(v);
        }
    }
    x
}

/// Encodes an integer mesh whose values map to the file's through `q`: as a
/// Catmull-Clark, sqrt(2) or polar hierarchy when one is found, else flat; with the
/// value map of `opts.value_map` (SPEC.md 3.1) when it makes the container smaller.
///
/// The mesh's attribute channels ([`Mesh::attributes`]) follow it in CHAN sections
/// (SPEC.md 11.4), each in the decoded mesh's order.
pub fn encode(mesh: &Mesh, q: &Quantization, opts: &EncodeOptions) -> Result<Encoded> {
    if mesh.attributes.is_empty() {
        return encode_inner(mesh, q, opts, None);
    }
    mesh.validate()?;
    let enc = encode_inner(&mesh.without_attributes(), q, opts, None)?;
    with_channels(enc, mesh, opts)
}

/// `enc`, the container of `mesh`'s positions and faces, with a CHAN section per
/// attribute channel of `mesh` (SPEC.md 11.4): each channel put in the order the
/// container decodes to (the input's with an ORDR section, else canonical) and coded as
/// a nested container with its order kept.
fn with_channels(mut enc: Encoded, mesh: &Mesh, opts: &EncodeOptions) -> Result<Encoded> {
    use crate::mesh::Domain;
    // The decoded mesh, for channels that follow its vertices, faces or corners: a
    // file's own records (an OBJ's comments, a PLY's other elements) need only the
    // vertex order, which the header tells (an ORDR section keeps the input's).
    let on_mesh = mesh.attributes.iter().any(|a| a.domain != Domain::File);
    let dec = match on_mesh {
        true => Some(crate::decoder::decode(
            &enc.bytes,
            &crate::DecodeOptions::default(),
        )?),
        false => None,
    };
    let none = Mesh::new();
    let out = dec.as_ref().map_or(&none, |d| &d.mesh);
    // Decoded vertex i is input vertex i with an ORDR section.
    let identity = enc.header.has_order;
    debug_assert!(dec.as_ref().is_none_or(|d| d.input_order == identity));
    let vertex_of = |i: usize| if identity { i } else { enc.order[i] as usize };
    // Each decoded face's input face and the rotation between them (for channels on
    // faces or corners).
    let on_faces = mesh
        .attributes
        .iter()
        .any(|a| matches!(a.domain, Domain::Face | Domain::Corner));
    let faces = match (on_faces, identity) {
        (false, _) => Vec::new(),
        (true, true) => (0..out.face_count()).map(|f| (f, 0)).collect(),
        (true, false) => match_faces(mesh, out, &enc.order)?,
    };
    let mut chans = Vec::with_capacity(mesh.attributes.len());
    let o = nested_options(opts);
    for a in &mesh.attributes {
        if a.is_list() {
            // Each decoded vertex's, face's or record's list, in turn.
            let lists: Vec<std::ops::Range<usize>> = a.list().collect();
            let records: Vec<usize> = match a.domain {
                crate::mesh::Domain::Vertex => (0..out.vertex_count()).map(vertex_of).collect(),
                crate::mesh::Domain::Face => faces.iter().map(|&(g, _)| g).collect(),
                _ => (0..lists.len()).collect(),
            };
            let values = match (a.domain, identity) {
                (crate::mesh::Domain::File, false) => a.renumbered(&enc.order),
                _ => a.values.clone(),
            };
            let mut m = Mesh::new();
            let mut counts = Vec::with_capacity(records.len());
            for &r in &records {
                counts.push(a.indices[r]);
                m.positions.extend(&values[lists[r].clone()]);
                if !a.floats.is_empty() {
                    m.floats.extend(&a.floats[lists[r].clone()]);
                }
            }
            let nested = encode_inner(&m, &a.quantization, &o, None)?;
            let head = chan::Head {
                name: a.name.clone(),
                domain: a.domain,
                value_type: a.value_type,
                width: 1,
                pad: 0,
                coding: chan::LISTS,
                labels: Vec::new(),
            };
            chans.push(chan::encode(
                &head,
                &chan::encode_lists(&counts, &nested.bytes),
            ));
            continue;
        }
        let mut m = Mesh::new();
        let has_none = a.domain == crate::mesh::Domain::Corner && a.indices.contains(&NO_ENTRY);
        let pick = |e: usize, m: &mut Mesh| {
            m.positions.push(a.values[e]);
            if let Some(f) = a.floats.get(e) {
                m.floats.push(*f);
            }
        };
        match a.domain {
            crate::mesh::Domain::Vertex => {
                (0..out.vertex_count()).for_each(|i| pick(vertex_of(i), &mut m));
                m.face_starts = out.face_starts.clone();
                m.faces = out.faces.clone();
            }
            crate::mesh::Domain::Face => faces.iter().for_each(|&(g, _)| pick(g, &mut m)),
            crate::mesh::Domain::File => {
                // Vertex numbers in a file's other records follow the vertices.
                m.positions = match identity {
                    true => a.values.clone(),
                    false => a.renumbered(&enc.order),
                };
                m.floats = a.floats.clone();
            }
            crate::mesh::Domain::Corner => {
                m.positions = a.values.clone();
                m.floats = a.floats.clone();
                // Corners without an entry use one more, the last (coding 4).
                let none = a.values.len() as u32;
                if has_none {
                    m.positions.push([0; 3]);
                    if !m.floats.is_empty() {
                        m.floats.push([0; 3]);
                    }
                }
                let entry = |c: usize| match a.indices[c] {
                    NO_ENTRY => none,
                    e => e,
                };
                m.faces.reserve(a.indices.len());
                for &f in &faces {
                    m.faces.extend(input_corners(mesh, f).map(entry));
                }
                m.face_starts = out.face_starts.clone();
                // In canonical order the table's order is the encoder's to choose:
                // entries numbered as the decoded corners first use them (then those no
                // corner uses; base::canonical_order).
                if !identity {
                    let order = base::canonical_order(&m);
                    m = permuted(&m, &order);
                    if let Some(at) = order.iter().position(|&o| o == none).filter(|_| has_none) {
                        // The entry for none stays last.
                        let n = order.len() as u32;
                        let last: Vec<u32> = (0..n)
                            .filter(|&k| k != at as u32)
                            .chain([at as u32])
                            .collect();
                        m = permuted(&m, &last);
                    }
                }
            }
        }
        let mut head = chan::Head {
            name: a.name.clone(),
            domain: a.domain,
            value_type: a.value_type,
            width: a.width,
            pad: 0,
            coding: chan::NESTED,
            labels: a.labels.clone(),
        };
        // Unit normals per corner: predicted from the geometry where that is smaller.
        let normals = predicted_normals(a, out, &m)?;
        if a.domain == crate::mesh::Domain::Corner {
            // A mesh with faces has at least 3 vertices: padding entries, before the
            // entry for none (which then counts as padding too).
            let at = m.positions.len() - has_none as usize;
            while m.positions.len() < 3 {
                m.positions.insert(at, [0; 3]);
                if !m.floats.is_empty() {
                    m.floats.insert(at, [0; 3]);
                }
                if has_none {
                    m.faces
                        .iter_mut()
                        .filter(|e| **e as usize >= at)
                        .for_each(|e| *e += 1);
                }
                head.pad += 1;
            }
            if has_none {
                head.pad += 1;
                head.coding = chan::NESTED_NONE;
            }
        }
        let mut nested = encode_inner(&m, &a.quantization, &o, None)?;
        if a.domain == crate::mesh::Domain::Corner && !identity {
            // Also the entries renumbered in the nested mesh's own canonical order, so
            // that its ORDR has only the faces' order to say; the smaller is kept.
            let mut c = o.clone();
            c.keep_order = false;
            let pre = encode_inner(&m, &a.quantization, &c, None)?;
            if pre.order.len() == m.positions.len() {
                // Padding stays last.
                let keep = m.positions.len() - head.pad as usize;
                if pre.order[keep..]
                    .iter()
                    .enumerate()
                    .all(|(i, &v)| v as usize == keep + i)
                {
                    let n = permuted(&m, &pre.order);
                    let renumbered = encode_inner(&n, &a.quantization, &o, None)?;
                    if renumbered.bytes.len() < nested.bytes.len() {
                        nested = renumbered;
                    }
                }
            }
        }
        let mut payload = chan::encode(&head, &nested.bytes);
        if let Some(body) = normals.filter(|b| b.len() < nested.bytes.len()) {
            head.pad = 0;
            head.coding = chan::NORMALS;
            payload = chan::encode(&head, &body);
        }
        // A file's lines: their numbers listed where that is smaller.
        if a.domain == crate::mesh::Domain::File && !a.labels.is_empty() && a.width == 1 {
            let body = chan::encode_listed(&m.positions);
            if body.len() < nested.bytes.len() {
                head.coding = chan::LISTED;
                payload = chan::encode(&head, &body);
            }
        }
        chans.push(payload);
    }
    // The container again, the channels before its end marker.
    let c = subwave_container::Container::parse(&enc.bytes, &crate::Limits::default())?;
    let mut w = ContainerWriter::new();
    for s in c.sections.iter().filter(|s| s.kind != SectionKind::END) {
        w.section(s.kind, s.payload);
    }
    let end = enc.sections.pop();
    let transform = enc.header.transform;
    for p in &chans {
        w.section(SectionKind::CHANNEL, p);
        let bytes = p.len() + subwave_container::section_overhead(p.len());
        enc.sections
            .push(section_info(SectionKind::CHANNEL, bytes, transform, p));
    }
    enc.sections.extend(end);
    enc.bytes = w.finish();
    Ok(enc)
}

/// The corners of input face `g` (numbers into `mesh.faces`) in the order of the decoded
/// face it is, rotated by `r` ([`match_faces`]).
fn input_corners(mesh: &Mesh, (g, r): (usize, usize)) -> impl Iterator<Item = usize> {
    let s = mesh.face_starts[g] as usize;
    let d = mesh.face_starts[g + 1] as usize - s;
    (0..d).map(move |j| s + (j + r) % d)
}

/// `m`'s vertices in the order `order[new] = old` ([`base::permute`]), float bits too.
fn permuted(m: &Mesh, order: &[u32]) -> Mesh {
    let mut n = base::permute(m, order);
    if !m.floats.is_empty() {
        n.floats = order.iter().map(|&o| m.floats[o as usize]).collect();
    }
    n
}

/// Coding 1 of a CHAN section (SPEC.md 11.4) for corner channel `a` as `m` holds it
/// (its entries as positions, each decoded corner's entry as `m`'s faces) on `out`, the
/// decoded mesh: when `a` is three decimals per entry written as text, with no more
/// entries than corners; else `None`.
fn predicted_normals(a: &crate::mesh::Attribute, out: &Mesh, m: &Mesh) -> Result<Option<Vec<u8>>> {
    use crate::sections::cidx::{CornerIndices, IndexChannel};
    use crate::sections::nrml::{self, Component, MAX_DECIMALS};
    let Quantization::Decimal { decimals } = a.quantization else {
        return Ok(None);
    };
    if a.domain != crate::mesh::Domain::Corner
        || a.indices.contains(&NO_ENTRY)
        || a.width != 3
        || a.value_type != crate::mesh::ValueType::Text
        || decimals as u32 > MAX_DECIMALS
        || a.values.len() > out.corner_count()
    {
        return Ok(None);
    }
    let idx = CornerIndices {
        channels: vec![
            IndexChannel::default(),
            IndexChannel {
                corners: (0..m.faces.len() as u32).collect(),
                values: m.faces.iter().map(|&e| e + 1).collect(),
            },
        ],
    };
    let comps: Vec<Component> = m
        .positions
        .iter()
        .take(a.values.len())
        .flatten()
        .map(|&v| Component {
            m: v,
            decimals: decimals as u32,
            negative_zero: false,
        })
        .collect();
    let cidx = cidx::encode(out, &idx)?;
    let nrml = nrml::encode(out, &idx, &comps)?;
    Ok(Some(chan::encode_normals(&chan::Normals {
        decimals,
        entries: a.values.len() as u64,
        cidx: &cidx,
        nrml: &nrml,
    })))
}

/// For each face of `out` (the decoded mesh, whose vertex `i` is `mesh`'s `order[i]`),
/// the face of `mesh` it is and the rotation `r` with corner `j` of the decoded face
/// corner `(j + r) mod d` of `mesh`'s.
fn match_faces(mesh: &Mesh, out: &Mesh, order: &[u32]) -> Result<Vec<(usize, usize)>> {
    // Faces keyed by their smallest rotation (of those starting at the smallest
    // vertex), and where it starts.
    let key = |f: &[u32]| -> (usize, Vec<u32>) {
        let d = f.len();
        let low = f.iter().copied().min().unwrap_or(0);
        let rot = |s: usize| (0..d).map(move |j| f[(s + j) % d]);
        let s = (0..d)
            .filter(|&j| f[j] == low)
            .min_by(|&x, &y| rot(x).cmp(rot(y)))
            .unwrap_or(0);
        (s, rot(s).collect())
    };
    let mut by_key: HashMap<Vec<u32>, Vec<(usize, usize)>> = HashMap::new();
    for g in (0..mesh.face_count()).rev() {
        let (s, k) = key(mesh.face(g));
        by_key.entry(k).or_default().push((g, s));
    }
    let mut mapped = Vec::new();
    let mut faces = Vec::with_capacity(out.face_count());
    for f in out.iter_faces() {
        mapped.clear();
        mapped.extend(f.iter().map(|&v| order[v as usize]));
        let (s, k) = key(&mapped);
        let (g, sg) = by_key
            .get_mut(&k)
            .and_then(Vec::pop)
            .ok_or_else(|| Error::InvalidMesh("a decoded face is none of the input's".into()))?;
        let d = f.len();
        // Decoded corner s is input corner sg.
        faces.push((g, (sg + d - s) % d));
    }
    Ok(faces)
}

/// Encodes a mesh read from `file`, a file of `format` whose mesh (in the file's vertex
/// and face order) is `mesh` on `q`, with the file's own bytes around the coded values
/// (SPEC.md 11): decoding then gives the file back byte for byte
/// ([`crate::Decoded::file`]). Needs `opts.keep_order`. The mesh's attribute channels
/// are left out: the file's own bytes carry them.
pub fn encode_file(
    mesh: &Mesh,
    q: &Quantization,
    opts: &EncodeOptions,
    file: &[u8],
    format: Format,
) -> Result<Encoded> {
    if !opts.keep_order {
        return Err(Error::InvalidArgument(
            "a file's own bytes are kept only with its order (keep_order)".into(),
        ));
    }
    mesh.validate()?;
    // The file's bytes carry its attributes: the channels read from it are not coded
    // again.
    let stripped;
    let mesh = match mesh.attributes.is_empty() {
        true => mesh,
        false => {
            stripped = mesh.without_attributes();
            &stripped
        }
    };
    let (mut t, mut ch) = io::template_of(file, format, mesh, q, true)
        .unwrap_or_else(|| (io::template::verbatim(file, mesh, q), Channels::default()));
    let attr = match ch.attributes.iter().map(|a| attribute(a, opts)).collect() {
        Ok(a) => a,
        // An attribute the codec cannot take stays in the template.
        Err(_) => {
            (t, ch) = io::template_of(file, format, mesh, q, false)
                .unwrap_or_else(|| (io::template::verbatim(file, mesh, q), Channels::default()));
            Vec::new()
        }
    };
    let own = FilePayloads {
        tmpl: tmpl::encode(&t)?,
        cidx: match ch.indices.is_empty() {
            true => None,
            false => Some(cidx::encode(mesh, &ch.indices)?),
        },
        nrml: match ch.normals.is_empty() {
            true => None,
            false => Some(nrml::encode(mesh, &ch.indices, &ch.normals)?),
        },
        attr,
    };
    encode_inner(mesh, q, opts, Some(&own))
}

/// The options a nested container (an attribute's values) is coded with: `opts`'
/// search, the values' order kept, no progress of its own.
fn nested_options(opts: &EncodeOptions) -> EncodeOptions {
    EncodeOptions {
        keep_order: true,
        progress: Progress::default(),
        ..opts.clone()
    }
}

/// The ATTR payload of attribute `a` (SPEC.md 11.3): its mesh coded with its order kept
/// and `opts`' search.
fn attribute(a: &Attribute, opts: &EncodeOptions) -> Result<Vec<u8>> {
    let o = nested_options(opts);
    Ok(attr::encode(
        a.width,
        &a.name,
        &encode(&a.mesh, &a.q, &o)?.bytes,
    ))
}

/// The sections that keep a file's own bytes (SPEC.md 11): TMPL, CIDX when the
/// template has corner index channels, NRML when it has normal components, an ATTR per
/// attribute.
struct FilePayloads {
    tmpl: Vec<u8>,
    cidx: Option<Vec<u8>>,
    nrml: Option<Vec<u8>>,
    attr: Vec<Vec<u8>>,
}

/// [`encode`], with a TMPL payload when given.
fn encode_inner(
    mesh: &Mesh,
    q: &Quantization,
    opts: &EncodeOptions,
    tmpl: Option<&FilePayloads>,
) -> Result<Encoded> {
    mesh.validate()?;
    check_floats(mesh, q)?;
    let map = match opts.value_map {
        Some(false) => None,
        Some(true) => ValueMap::every_axis(&mesh.positions),
        None => ValueMap::candidate(&mesh.positions),
    };
    let Some(map) = map else {
        return encode_with(mesh, q, opts, None, tmpl, None);
    };
    let ranked = Mesh {
        positions: map.ranks(&mesh.positions),
        face_starts: mesh.face_starts.clone(),
        faces: mesh.faces.clone(),
        floats: mesh.floats.clone(),
        attributes: Vec::new(),
    };
    if opts.value_map == Some(true) {
        return encode_with(&ranked, q, opts, Some(&map), tmpl, None);
    }
    // Ranks or values by estimate, and the Catmull-Clark candidates the estimate made
    // (of the faces: the same for either coding).
    let estimate = map_by_estimate(mesh, &ranked, &map, opts)?;
    let choice = estimate.as_ref().and_then(|e| e.choice);
    // The ranks' (k = 0) or the values' (1) coding, with the candidates and its
    // estimate.
    let recovered = move |k: usize| {
        estimate.map(|e| Recovered {
            canons: e.canons,
            bits: e.bits.map(|(w, b)| (w, b[k])),
            finest: e.finest,
            fit: k == 1,
        })
    };
    match choice {
        Some(true) => return encode_with(&ranked, q, opts, Some(&map), tmpl, recovered(0)),
        Some(false) => return encode_with(mesh, q, opts, None, tmpl, recovered(1)),
        None => {}
    }
    // Both: the values' coding recovers its own candidates (one hierarchy held at a
    // time, the memory of large meshes).
    let mapped = encode_with(&ranked, q, opts, Some(&map), tmpl, recovered(0))?;
    let plain = encode_with(mesh, q, opts, None, tmpl, None)?;
    Ok(if mapped.bytes.len() < plain.bytes.len() {
        mapped
    } else {
        plain
    })
}

/// The estimates of a value map's ranks and of the values themselves must differ by
/// this many hundredths for the default effort to code one of them alone.
const MAP_MARGIN: u64 = 3;

/// The Catmull-Clark family's candidates of a mesh made before its coding
/// ([`cc_candidates`]), with the details' bits of the preferred one where estimated.
struct Recovered {
    canons: Vec<Canonical>,
    /// A transform and its details' bits ([`search::detail_bits`]) on `canons[0]`.
    bits: Option<(Wavelet, search::DetailBits)>,
    /// The level after `canons[0]`'s last (the fit's), where made.
    finest: Option<Level>,
    /// Whether the subdivision fit is tried: not on a value map's ranks, chosen by
    /// estimate. The map bends its axes (a subdivision of the values is none of their
    /// ranks) and the fit codes values: the values' coding tries it, or their screen
    /// in the estimate turned it away ([`map_by_estimate`]; on the 69 corpus codings
    /// and the Blender files the fit on ranks never won).
    fit: bool,
}

/// What [`map_by_estimate`] finds.
struct MapEstimate {
    /// Ranks (`true`) or values (`false`), or both to be coded (`None`).
    choice: Option<bool>,
    /// The Catmull-Clark family's candidates ([`cc_candidates`]).
    canons: Vec<Canonical>,
    /// A transform and its details' bits on `canons[0]` with the ranks and with the
    /// values, where estimated.
    bits: Option<(Wavelet, [search::DetailBits; 2])>,
    /// The level after `canons[0]`'s last, where made.
    finest: Option<Level>,
}

/// Whether `auto` codes `mesh` as `ranked`, its ranks on value map `map` (SPEC.md
/// 3.1), decided up to effort 6 without coding both: ranks if the details' bits of the
/// ranks ([`search::detail_bits`], on the preferred Catmull-Clark candidate, with the
/// family's first transform or the one asked for) and the map's own bytes are below
/// the values' by [`MAP_MARGIN`] %, values if above; both (`choice` `None`) within the
/// margin, without a Catmull-Clark hierarchy, or where `auto`'s fit may be tried on
/// the values. `None` (nothing made) above effort 6 and for a sqrt(2) transform or the
/// fit.
fn map_by_estimate(
    mesh: &Mesh,
    ranked: &Mesh,
    map: &ValueMap,
    opts: &EncodeOptions,
) -> Result<Option<MapEstimate>> {
    let w = match opts.transform {
        TransformChoice::Auto => Wavelet::Bicubic,
        TransformChoice::Fixed(w) if !w.is_sqrt2() => w,
        _ => return Ok(None),
    };
    let effort = Effort::of(opts.effort);
    if !effort.map_estimated || opts.max_levels == 0 {
        return Ok(None);
    }
    opts.progress.report(Stage::Recovering);
    let mut found = MapEstimate {
        choice: None,
        canons: cc_candidates(mesh, opts)?,
        bits: None,
        finest: None,
    };
    let Some(canon) = found.canons.first() else {
        return Ok(Some(found));
    };
    let disc = opts.disc.unwrap_or(DiscTransform::None);
    let estimates = (
        search::detail_bits(canon, ranked, w, disc),
        search::detail_bits(canon, mesh, w, disc),
    );
    let (Some(ranks), Some(values)) = estimates else {
        return Ok(Some(found));
    };
    found.bits = Some((w, [ranks, values]));
    let (ranks, values) = (ranks.all + 8 * map.encode().len() as u64, values.all);
    found.choice = if ranks * 100 <= values * (100 - MAP_MARGIN) {
        Some(true)
    } else if values * 100 <= ranks * (100 - MAP_MARGIN) {
        Some(false)
    } else {
        None
    };
    // The fit codes values, not ranks: ranks are chosen alone only where the fit's
    // screen turns the values away (the finest level it makes is kept for the coding's
    // own screen).
    let fits = opts.transform == TransformChoice::Auto && effort.fit;
    if let (Some(true), true, Some(last)) = (found.choice, fits, canon.levels.last()) {
        let finest = last.next();
        if !fitting::turned_away(canon, &canonical_positions(mesh, canon), &finest) {
            found.choice = None;
        }
        found.finest = Some(finest);
    }
    Ok(Some(found))
}

/// [`encode`] with a given value map (`mesh` holding the ranks on its mapped axes),
/// with the Catmull-Clark family's candidates where already made ([`cc_candidates`]).
fn encode_with(
    mesh: &Mesh,
    q: &Quantization,
    opts: &EncodeOptions,
    vmap: Option<&ValueMap>,
    tmpl: Option<&FilePayloads>,
    recovered: Option<Recovered>,
) -> Result<Encoded> {
    let mut flat_h = flat_header(mesh, q, opts);
    flat_h.has_value_map = vmap.is_some();
    flat_h.has_template = tmpl.is_some();
    flat_h.has_corner_indices = tmpl.is_some_and(|t| t.cidx.is_some());
    flat_h.has_normals = tmpl.is_some_and(|t| t.nrml.is_some());
    let best = if opts.max_levels > 0 {
        opts.progress.report(Stage::Recovering);
        best_hierarchy(mesh, opts, &flat_h, recovered)?
    } else {
        None
    };
    let (payloads, order) = match best {
        Some((p, order)) => (p, order),
        None => {
            opts.progress.report(Stage::Flat);
            best_flat(mesh, opts, &flat_h)
        }
    };
    let fbit = float_bits(mesh, q, &order)?;
    opts.progress.report(Stage::Container);
    let (bytes, sections) = write_container(&payloads, vmap, fbit.as_deref(), tmpl)?;
    let header = payloads.header;
    Ok(Encoded {
        bytes,
        order,
        header,
        sections,
    })
}

/// A mesh's float values must be those its integers stand for on the quantisation's
/// grid (SPEC.md 3.2), and one FBIT coding must give them back.
fn check_floats(mesh: &Mesh, q: &Quantization) -> Result<()> {
    if mesh.floats.is_empty() {
        return Ok(());
    }
    let Quantization::Float { width, exponent } = *q else {
        return Err(Error::InvalidArgument(
            "float values need binary float quantisation".into(),
        ));
    };
    let bits = fbit::encode(mesh.floats.iter().copied(), width, exponent);
    match fbit::decode(&bits, &mesh.positions, width, exponent) {
        Ok(back) if back == mesh.floats => Ok(()),
        _ => Err(Error::InvalidArgument(
            "the float values are not the integers' values on their grid".into(),
        )),
    }
}

/// The FBIT payload of a mesh with binary floats below their grid (SPEC.md 3.2), the
/// values in the decoder's order (`order[decoded] = input`); `None` for other meshes.
fn float_bits(mesh: &Mesh, q: &Quantization, order: &[u32]) -> Result<Option<Vec<u8>>> {
    let Quantization::Float { width, exponent } = *q else {
        return Ok(None);
    };
    if mesh.floats.is_empty() {
        return Ok(None);
    }
    let decoded = order.iter().map(|&i| mesh.floats[i as usize]);
    Ok(Some(fbit::encode(decoded, width, exponent)))
}

/// The hierarchy coding that codes `mesh` smallest, with the canonical order of the
/// hierarchy it was made from; `None` when no hierarchy is found.
/// `recovered` holds the Catmull-Clark family's candidates where already made.
fn best_hierarchy(
    mesh: &Mesh,
    opts: &EncodeOptions,
    flat_h: &Header,
    recovered: Option<Recovered>,
) -> Result<Option<(Payloads, Vec<u32>)>> {
    let mut best: Option<(Payloads, Vec<u32>)> = None;
    let (want_cc, want_sqrt2) = match opts.transform {
        TransformChoice::Auto => (true, true),
        TransformChoice::Fixed(w) => (!w.is_sqrt2(), w.is_sqrt2()),
        TransformChoice::Fit => (true, false),
    };
    let fit_only = opts.transform == TransformChoice::Fit;
    let max = opts.max_levels as usize;
    // The base mesh's faces in the order of the connectivity coder's gates, unless
    // the input's order is kept: then as recovered, which makes the order cheap.
    let gates = !opts.keep_order;
    // Per family: its candidate hierarchies, the transform that compares them, and
    // the family's other transforms (tried on the better candidate with `auto`). The
    // sqrt(2) family is recovered by the job that codes it, so that on one thread the
    // Catmull-Clark family's hierarchies are gone before it is (memory).
    let mut families: Vec<FamilyJob> = Vec::new();
    if want_cc {
        let (mut canons, known, mut finest, fit) = match recovered {
            Some(r) => (r.canons, r.bits, r.finest, r.fit),
            None => (cc_candidates(mesh, opts)?, None, None, true),
        };
        // The subdivision fit, on each candidate whose finest level is near a
        // subdivision (every candidate when asked for by name).
        let try_fit = match opts.transform {
            TransformChoice::Auto => Effort::of(opts.effort).fit && fit,
            TransformChoice::Fit => true,
            TransformChoice::Fixed(_) => false,
        };
        // The levels and fit of the first candidate whose base mesh has no
        // extraordinary vertex and whose fit was tried but missed (residuals of
        // MISSED_BITS per vertex or more).
        let mut regular_fit = None;
        // On a large mesh one hierarchy's levels at a time: the first waits stowed while
        // the others' fits are tried.
        let large = mesh.vertex_count() > search::LARGE_MESH;
        for i in (0..canons.len()).filter(|_| try_fit) {
            if i == 1 && large {
                canons[0].stow();
            }
            let canon = &mut canons[i];
            canon.unstow()?;
            let pos = canonical_positions(mesh, canon);
            let made = finest.take().filter(|_| i == 0);
            let fitted = code_fit(
                canon,
                &pos,
                flat_h,
                &FIT_BITS,
                !fit_only,
                made,
                opts.threads,
            );
            let missed = fitted.as_ref().filter(|p| {
                p.levels
                    .last()
                    .is_some_and(|r| 8 * r.len() >= MISSED_BITS * mesh.vertex_count())
            });
            if let (None, Some(p), Some(base)) = (regular_fit, missed, canon.levels.first()) {
                if canon.poles.is_empty() && no_extraordinary(base) {
                    regular_fit = Some((canon.levels.len(), p.size()));
                }
            }
            if let Some(mut p) = fitted {
                if opts.keep_order {
                    p.order = Some(hierarchy_order(mesh, canon)?);
                }
                if best.as_ref().is_none_or(|b| p.size() < b.0.size()) {
                    best = Some((p, canon.order.clone()));
                }
            }
            if i > 0 {
                canon.stow();
            }
        }
        if let Some(first) = canons.first_mut() {
            first.unstow()?;
        }
        // A base mesh without extraordinary vertices refines from a coarser one as
        // far as its grid allows, so the recovery finds a base coarser than a
        // modelling tool's control mesh (a subdivided plane or torus: a 4 x 4 sheet
        // refined four times is one quad refined six): the fit is tried again with
        // the first levels left out, the control mesh a level finer each time, on
        // the hierarchies near a subdivision, until one codes no smaller than the
        // one above after one has coded smaller (past the control mesh's depth the
        // fits only grow; above it they may too).
        if let Some((levels, mut above)) = regular_fit {
            let mut improved = false;
            for keep in (levels.saturating_sub(SHALLOWER)..levels)
                .rev()
                .filter(|&k| k > 0)
            {
                let mut size: Option<usize> = None;
                for mut canon in shallow_candidates(mesh, opts, keep)? {
                    canon.unstow()?;
                    let pos = canonical_positions(mesh, &canon);
                    if !fit_only && !fitting::near_subdivision(&canon, &pos) {
                        continue;
                    }
                    let Some(mut p) = code_fit(
                        &canon,
                        &pos,
                        flat_h,
                        &FIT_BITS,
                        !fit_only,
                        None,
                        opts.threads,
                    ) else {
                        continue;
                    };
                    size = Some(size.map_or(p.size(), |s| s.min(p.size())));
                    if best.as_ref().is_none_or(|b| p.size() < b.0.size()) {
                        if opts.keep_order {
                            p.order = Some(hierarchy_order(mesh, &canon)?);
                        }
                        best = Some((p, canon.order.clone()));
                    }
                }
                match size {
                    Some(s) if s >= above && improved => break,
                    Some(s) if s < above => (above, improved) = (s, true),
                    _ => {}
                }
            }
        }
        // A mesh and its dual can both be the base: compare them with one transform.
        if !fit_only && !canons.is_empty() {
            let first = Wavelet::Bicubic;
            families.push(FamilyJob::Ready(canons, first, &Wavelet::ALL, known));
        }
    }
    if want_sqrt2 {
        families.push(FamilyJob::Sqrt2);
    }
    // The families code apart; on several threads at once, each with its share.
    let threads = opts.threads.max(1);
    let share = (threads / families.len().max(1)).max(1);
    // Each family is taken once, by the thread that codes it (on one thread, in
    // order).
    let jobs: Vec<_> = families
        .into_iter()
        .map(|f| std::sync::Mutex::new(Some(f)))
        .collect();
    let coded = par_map(&jobs, threads, |job| {
        let taken = job.lock().map(|mut j| j.take()).ok().flatten();
        let (canons, first, others, known) = match taken.expect("each family is coded once") {
            FamilyJob::Ready(canons, first, others, known) => (canons, first, others, known),
            FamilyJob::Sqrt2 => {
                let topo = input_topo(mesh);
                let mut canons: Vec<Canonical> = Vec::new();
                for rec in topology::sqrt2::recover_candidates(&topo, max, opts.keep_order) {
                    if let Ok(canon) = topology::sqrt2::canonicalise(rec, &topo, gates) {
                        canons.push(canon);
                        canons.iter_mut().skip(1).for_each(Canonical::stow);
                    }
                }
                drop(topo);
                if opts.keep_order {
                    canons = by_order_cost(mesh, canons)?;
                }
                (canons, Wavelet::Sqrt2Lazy, &Wavelet::SQRT2[..], None)
            }
        };
        if canons.is_empty() {
            return Ok::<_, Error>(None);
        }
        // Only the order of the hierarchy is kept.
        Ok(
            code_family(mesh, opts, flat_h, canons, first, others, known, share)?
                .map(|(p, canon)| (p, canon.order)),
        )
    });
    for family in coded {
        let Some((p, order)) = family? else {
            continue;
        };
        if best.as_ref().is_none_or(|b| p.size() < b.0.size()) {
            best = Some((p, order));
        }
    }
    Ok(best)
}

/// The input's faces as a topology, for recovery only: each family makes its own and
/// drops it before coding (the memory of large meshes).
fn input_topo(mesh: &Mesh) -> Topo {
    let mut topo = Topo::new(mesh.vertex_count());
    topo.idx = mesh.faces.clone();
    topo.starts = mesh.face_starts.clone();
    topo
}

/// The Catmull-Clark family's candidate hierarchies of `mesh` (SPEC.md 8: a mesh and
/// its dual, polar labelings), the preferred first with its levels, the others stowed.
/// They depend on the faces and their order alone, not on the positions.
fn cc_candidates(mesh: &Mesh, opts: &EncodeOptions) -> Result<Vec<Canonical>> {
    let max = opts.max_levels as usize;
    // The base mesh's faces in the order of the connectivity coder's gates, unless
    // the input's order is kept: then as recovered, which makes the order cheap.
    let gates = !opts.keep_order;
    let topo = input_topo(mesh);
    let mut canons = cc_canonicals(mesh, &topo, max, opts.keep_order)?;
    // Polar levels take the Catmull-Clark transforms (SPEC.md 8.6).
    let keep = match opts.keep_order {
        true => topology::polar::KEEP_FOR_ORDER,
        false => topology::polar::KEEP,
    };
    let cc_count = canons.len();
    for canon in topology::polar::recover_all(mesh.vertex_count(), &topo, max, gates, keep) {
        canons.push(canon);
        canons.iter_mut().skip(1).for_each(Canonical::stow);
    }
    drop(topo);
    if opts.keep_order {
        // The one that codes the order best first, then as many as are coded
        // without the order (the search's time stays what it was).
        let polar = (canons.len() - cc_count).min(topology::polar::KEEP);
        canons = by_order_cost(mesh, canons)?;
        canons.truncate(cc_count + polar);
    }
    Ok(canons)
}

/// Bits per vertex of a fit's residuals from which a fit on a base mesh without
/// extraordinary vertices is tried with levels left out: a fit on its control mesh
/// leaves the rounding's one to three (a file's 6 decimals), one a level too coarse
/// ten and more.
const MISSED_BITS: usize = 4;

/// Levels left out, at most, where the fit is tried on a shallower hierarchy of a base
/// mesh without extraordinary vertices ([`best_hierarchy`]).
const SHALLOWER: usize = 3;

/// Whether every vertex of `base` is regular: four edges inside, at most three on a
/// boundary (a grid's vertices, of any depth).
fn no_extraordinary(base: &Level) -> bool {
    (0..base.nv).all(|v| {
        let edges = base.v_edges(v);
        match edges.iter().any(|&e| base.is_boundary(e as usize)) {
            false => edges.len() == 4,
            true => edges.len() <= 3,
        }
    })
}

/// The Catmull-Clark candidates of `mesh` of exactly `levels` levels (as
/// [`cc_candidates`], without polar ones): the deepest hierarchies' last `levels`.
fn shallow_candidates(mesh: &Mesh, opts: &EncodeOptions, levels: usize) -> Result<Vec<Canonical>> {
    cc_canonicals(mesh, &input_topo(mesh), levels, opts.keep_order)
}

/// The Catmull-Clark hierarchies of `mesh` (its faces `topo`) of at most `max` levels,
/// canonical; with `keep_order` led by the input's order and the base faces as
/// recovered, else in the gates' order.
fn cc_canonicals(mesh: &Mesh, topo: &Topo, max: usize, keep_order: bool) -> Result<Vec<Canonical>> {
    let mut canons = Vec::new();
    for rec in topology::cc::recover_candidates(mesh.vertex_count(), topo, max, keep_order) {
        canons.push(topology::canonicalise(&rec, !keep_order)?);
        // Every candidate but the one in hand waits with its levels stowed.
        canons.iter_mut().skip(1).for_each(Canonical::stow);
    }
    Ok(canons)
}

/// `canons` (the first with its levels, the others stowed) with the one whose ORDR
/// section codes the input's order smallest first, the others in their order after it,
/// when it saves more than a bit per vertex on the first's (less is below what the
/// candidates' geometry may differ by): of a mesh and its dual, or a polar grid's
/// labelings, only the one its producer made predicts its order (SPEC.md 7.5).
fn by_order_cost(mesh: &Mesh, mut canons: Vec<Canonical>) -> Result<Vec<Canonical>> {
    if canons.len() < 2 {
        return Ok(canons);
    }
    let mut costs = Vec::with_capacity(canons.len());
    for (i, canon) in canons.iter_mut().enumerate() {
        if i > 0 {
            canon.unstow()?;
        }
        costs.push(hierarchy_order(mesh, canon)?.len());
        canon.stow();
    }
    let mut best = (0..canons.len()).min_by_key(|&i| costs[i]).unwrap_or(0);
    if costs[0] - costs[best] <= mesh.vertex_count() / 8 {
        best = 0;
    }
    let first = canons.remove(best);
    canons.insert(0, first);
    canons[0].unstow()?;
    Ok(canons)
}

/// A family's candidate hierarchies for [`best_hierarchy`]: recovered, with the
/// transform that compares them, the family's others and a transform's details' bits
/// on the first where known; or the sqrt(2) family, to be recovered.
enum FamilyJob {
    Ready(
        Vec<Canonical>,
        Wavelet,
        &'static [Wavelet],
        Option<(Wavelet, search::DetailBits)>,
    ),
    Sqrt2,
}

/// The flat coding (no levels): faces as the connectivity coder's gates visit them
/// (rotated to start at their gate); when the order is kept, also in the input's order
/// and breadth-first, whichever codes smaller with the ORDR section. Vertices in order
/// of first use (SPEC.md 6.1).
fn best_flat(mesh: &Mesh, opts: &EncodeOptions, flat_h: &Header) -> (Payloads, Vec<u32>) {
    let mut best_flat: Option<(Payloads, Vec<u32>)> = None;
    let nf = mesh.face_count();
    let mut candidates = vec![topology::gates::gate_order(&mesh.face_starts, &mesh.faces)];
    if opts.keep_order {
        candidates.push(((0..nf as u32).collect(), vec![0; nf]));
        candidates.push((base::face_order(mesh), vec![0; nf]));
    }
    for (forder, rot) in candidates {
        let by_faces = base::permute_faces_rotated(mesh, &forder, &rot);
        let order = base::canonical_order(&by_faces);
        let canonical = base::permute(&by_faces, &order);
        let order_payload = opts.keep_order.then(|| {
            let faces = ordr::Faces {
                nv: canonical.vertex_count(),
                starts: &canonical.face_starts,
                idx: &canonical.faces,
                hierarchy: None,
            };
            order_section(&order, forder, rot, faces)
        });
        let p = Payloads {
            header: flat_h.clone(),
            base: base::encode(&canonical),
            levels: Vec::new(),
            order: order_payload,
        };
        if best_flat.as_ref().is_none_or(|b| p.size() < b.0.size()) {
            best_flat = Some((p, order));
        }
    }
    best_flat.expect("at least one candidate")
}

/// The container of a coding: its sections in order (SPEC.md 2.4), and what each is.
fn write_container(
    payloads: &Payloads,
    vmap: Option<&ValueMap>,
    fbit: Option<&[u8]>,
    tmpl: Option<&FilePayloads>,
) -> Result<(Vec<u8>, Vec<SectionInfo>)> {
    let header = &payloads.header;
    let transform = header.transform;
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
        let bytes = payload.len() + subwave_container::section_overhead(payload.len());
        sections.push(section_info(kind, bytes, transform, payload));
        Ok(())
    };
    put(&mut w, SectionKind::HEADER, &header.write())?;
    if let Some(m) = vmap {
        put(&mut w, SectionKind::VALUE_MAP, &m.encode())?;
    }
    put(&mut w, SectionKind::BASE, &payloads.base)?;
    for l in &payloads.levels {
        put(&mut w, SectionKind::LEVEL, l)?;
    }
    if let Some(f) = fbit {
        put(&mut w, SectionKind::FLOAT_BITS, f)?;
    }
    if let Some(o) = &payloads.order {
        put(&mut w, SectionKind::ORDER, o)?;
    }
    if let Some(t) = tmpl {
        put(&mut w, SectionKind::TEMPLATE, &t.tmpl)?;
        if let Some(c) = &t.cidx {
            put(&mut w, SectionKind::CORNER_INDICES, c)?;
        }
        if let Some(n) = &t.nrml {
            put(&mut w, SectionKind::NORMALS, n)?;
        }
        for a in &t.attr {
            let a = attr::share_order(a, payloads.order.as_deref());
            put(&mut w, SectionKind::ATTRIBUTE, &a)?;
        }
    }
    let bytes = w.finish();
    let end = subwave_container::section_overhead(0);
    sections.push(section_info(SectionKind::END, end, transform, &[]));
    Ok((bytes, sections))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::fixtures::{prism_with_triangles, pseudo};

    /// A prism with triangles refined three times, its hierarchy, pseudo-random 12-bit
    /// values (whose predictions' phases vary) and a header for them.
    pub(super) fn refined_prism() -> (Canonical, Mesh, Header) {
        let mut t = prism_with_triangles();
        for _ in 0..3 {
            t = topology::Level::new(&t).unwrap().fine();
        }
        let rec = topology::cc::recover_all(t.nv, &t, 16).remove(0);
        let canon = topology::canonicalise(&rec, true).unwrap();
        let vals: Vec<Vec<i64>> = (0..3).map(|k| pseudo(k + 1, t.nv, 12)).collect();
        let mesh = Mesh {
            positions: (0..t.nv)
                .map(|v| std::array::from_fn(|k| vals[k][v]))
                .collect(),
            face_starts: t.starts.clone(),
            faces: t.idx.clone(),
            floats: Vec::new(),
            attributes: Vec::new(),
        };
        let q = Quantization::Decimal { decimals: 0 };
        let header = flat_header(&mesh, &q, &EncodeOptions::default());
        (canon, mesh, header)
    }

    /// `code_hierarchy`'s bound: a coding whose BASE and LEVL payloads fit is the
    /// unbounded one, byte for byte; one byte less and it is refused. With and without
    /// a mode plan, for several transforms.
    #[test]
    fn bounded_codings_are_the_unbounded_ones_or_none() {
        let (canon, mesh, header) = refined_prism();
        let d = DiscTransform::None;
        for w in [Wavelet::Bicubic, Wavelet::Interp4, Wavelet::Lazy] {
            let free = code_hierarchy(
                &canon,
                &mesh,
                w,
                d,
                &header,
                ModeSearch::ALL,
                None,
                UNBOUNDED,
                &Progress::default(),
            )
            .unwrap();
            let plan = free.modes();
            for modes in [None, Some(plan)] {
                let whole = code_hierarchy(
                    &canon,
                    &mesh,
                    w,
                    d,
                    &header,
                    ModeSearch::ALL,
                    modes.clone(),
                    UNBOUNDED,
                    &Progress::default(),
                )
                .unwrap();
                let n = whole.coded();
                let fit = code_hierarchy(
                    &canon,
                    &mesh,
                    w,
                    d,
                    &header,
                    ModeSearch::ALL,
                    modes.clone(),
                    n,
                    &Progress::default(),
                )
                .unwrap_or_else(|| panic!("fits its own size {w:?} {:?} {n}", modes));
                assert_eq!((fit.base, fit.levels), (whole.base, whole.levels), "{w:?}");
                assert!(
                    code_hierarchy(
                        &canon,
                        &mesh,
                        w,
                        d,
                        &header,
                        ModeSearch::ALL,
                        modes,
                        n - 1,
                        &Progress::default()
                    )
                    .is_none(),
                    "{w:?}"
                );
            }
        }
    }
}

//! The HEAD section (SPEC.md 5).

use subwave_container::{ByteReader, ByteWriter, Limits};

use crate::error::{Error, Result};
use crate::quant::{FloatWidth, Quantization};
use crate::transform::polar::DiscTransform;
use crate::topology::Family;
use crate::transform::Wavelet;

/// The family's code in the header (SPEC.md 5).
impl Family {
    fn code(self) -> u8 {
        match self {
            Family::None => 0,
            Family::Cc => 1,
            Family::Sqrt2 => 2,
            Family::Polar => 3,
        }
    }
}

/// Which wavelet transform codes the levels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transform {
    /// No levels, nothing to transform.
    None,
    /// A lifted wavelet on Catmull-Clark levels.
    Wavelet(Wavelet),
    /// The subdivision fit (SPEC.md 9.10): a control mesh with `bits` extra bits of
    /// precision, refined by Catmull-Clark rules (with the header's creases), the
    /// finest values placed on the limit surface when `limit`, and the finest values'
    /// residuals.
    Fit {
        /// Extra bits of the control values, `0..=16`.
        bits: u8,
        /// The finest values are the limit surface's (SPEC.md 9.10).
        limit: bool,
        /// Boundary vertices with one face keep their values (SPEC.md 9.10).
        corners: bool,
        /// Every boundary vertex keeps its value: linear boundaries (SPEC.md 9.10).
        linear: bool,
        /// Linear everywhere: every edge sharp, every vertex kept (SPEC.md 9.10).
        bilinear: bool,
        /// At the limit, boundary vertices with one face keep their values (SPEC.md
        /// 9.10).
        limit_corners: bool,
        /// With the limit, `Some(e)`: `e` more levels refined before it, where a
        /// finite sharpness left is smooth (SPEC.md 9.10), `0..=3`.
        extra_levels: Option<u8>,
        /// With the limit, `Some(q)`: the faces of level `q` beside an extraordinary
        /// vertex are OpenSubdiv's end-cap patches (SPEC.md 9.10), `q >= 1`.
        end_caps: Option<u8>,
    },
}

impl Transform {
    /// The name `info` prints.
    pub fn name(self) -> &'static str {
        match self {
            Transform::None => "none",
            Transform::Wavelet(w) => w.name(),
            Transform::Fit { .. } => "fit",
        }
    }

    fn code(self) -> u8 {
        match self {
            Transform::None => 0,
            Transform::Wavelet(w) => w.code(),
            Transform::Fit { .. } => FIT_CODE,
        }
    }
}

/// The file format the mesh was read from, so `decompress` can default to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// Unknown or not recorded.
    Unknown,
    /// OBJ.
    Obj,
    /// ASCII PLY.
    PlyAscii,
    /// Binary PLY.
    PlyBinary,
    /// OFF.
    Off,
    /// ASCII STL.
    StlAscii,
    /// Binary STL.
    StlBinary,
}

impl Source {
    fn code(self) -> u8 {
        match self {
            Source::Unknown => 0,
            Source::Obj => 1,
            Source::PlyAscii => 2,
            Source::PlyBinary => 3,
            Source::Off => 4,
            Source::StlAscii => 5,
            Source::StlBinary => 6,
        }
    }

    fn from_code(c: u8) -> Source {
        match c {
            1 => Source::Obj,
            2 => Source::PlyAscii,
            3 => Source::PlyBinary,
            4 => Source::Off,
            5 => Source::StlAscii,
            6 => Source::StlBinary,
            _ => Source::Unknown,
        }
    }
}

/// Everything the HEAD section says.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// Vertices of the finest mesh.
    pub vertices: u64,
    /// Faces of the finest mesh.
    pub faces: u64,
    /// Face corners of the finest mesh.
    pub corners: u64,
    /// Vertices of the base mesh.
    pub base_vertices: u64,
    /// Faces of the base mesh.
    pub base_faces: u64,
    /// Face corners of the base mesh.
    pub base_corners: u64,
    /// Refinement levels after the base mesh.
    pub levels: u8,
    /// Subdivision family.
    pub family: Family,
    /// Wavelet transform.
    pub transform: Transform,
    /// How integers map to values.
    pub quantization: Quantization,
    /// The input file's format.
    pub source: Source,
    /// Whether an ORDR section restores the input vertex order.
    pub has_order: bool,
    /// A `VMAP` section follows the header (SPEC.md 3.1).
    pub has_value_map: bool,
    /// An `FBIT` section follows the levels: binary float values below their grid
    /// (SPEC.md 3.2).
    pub has_float_bits: bool,
    /// A `TMPL` section follows the input order: the input file's own bytes around the
    /// coded values (SPEC.md 11).
    pub has_template: bool,
    /// A `CIDX` section follows the template: its per-corner index channels (SPEC.md
    /// 11.1).
    pub has_corner_indices: bool,
    /// An `NRML` section follows: the template's normal components (SPEC.md 11.2).
    pub has_normals: bool,
    /// Polar hierarchies (family 3): the base mesh's poles, increasing (SPEC.md 8.6);
    /// empty for every other family.
    pub poles: Vec<u32>,
    /// Polar hierarchies: the transform of the poles' discs (SPEC.md 9.9); `None` for
    /// every other family.
    pub disc: DiscTransform,
    /// Subdivision fits: the base mesh's infinitely sharp edges (creases), numbered as
    /// in SPEC.md 8.1, increasing; empty for every other transform.
    pub creases: Vec<u32>,
    /// Subdivision fits: each crease's sharpness in units of 2^-16 of a level (SPEC.md
    /// 9.10), `1..=655360` (`10 << 16`: infinitely sharp); empty: every crease is
    /// infinitely sharp.
    pub crease_sharpness: Vec<u32>,
    /// Subdivision fits: the base mesh's creased vertices, increasing; empty: none.
    pub vertex_creases: Vec<u32>,
    /// Subdivision fits: each creased vertex's sharpness, as `crease_sharpness`
    /// (empty: every creased vertex is infinitely sharp).
    pub vertex_sharpness: Vec<u32>,
    /// Subdivision fits: the base mesh's seams, `(copy, partner)` with `partner <
    /// copy` and the copies increasing; the rules refine the base mesh with each copy
    /// glued to its partner (SPEC.md 9.10), and its creases number the glued mesh's
    /// edges and vertices. Empty: no seams.
    pub seams: Vec<(u32, u32)>,
}

const FLAG_ORDER: u64 = 1;
const FLAG_VALUE_MAP: u64 = 2;
const FLAG_FLOAT_BITS: u64 = 4;
const FLAG_TEMPLATE: u64 = 8;
const FLAG_CORNER_INDICES: u64 = 16;
const FLAG_NORMALS: u64 = 32;
/// The transform code of the subdivision fit.
const FIT_CODE: u8 = 9;
/// Fit rules: the finest values are the limit surface's.
const FIT_LIMIT: u64 = 1;
/// Fit rules: a list of creased base edges ends the header.
const FIT_CREASES: u64 = 2;
/// Fit rules: boundary vertices with one face keep their values.
const FIT_CORNERS: u64 = 4;
/// Fit rules: every boundary vertex keeps its value (linear boundaries).
const FIT_LINEAR: u64 = 8;
/// Fit rules: the creases' sharpnesses follow their list.
const FIT_SEMI_SHARP: u64 = 16;
/// Fit rules: a list of creased base vertices and their sharpnesses ends the header.
const FIT_VERTEX_CREASES: u64 = 32;
/// Fit rules: a list of seams ends the header.
const FIT_SEAMS: u64 = 64;
/// Fit rules: linear everywhere (every edge sharp, every vertex kept).
const FIT_BILINEAR: u64 = 128;
/// Fit rules: at the limit, boundary vertices with one face keep their values.
const FIT_LIMIT_CORNERS: u64 = 256;
/// Fit rules: the creased vertices' sharpnesses follow their list.
const FIT_VERTEX_SEMI_SHARP: u64 = 512;
/// Fit rules: a byte of extra levels refined before the limit follows the rules.
const FIT_EXTRA_LEVELS: u64 = 1024;
/// Fit rules: a byte, the end caps' isolation level, follows the rules (and the extra
/// levels' byte).
const FIT_END_CAPS: u64 = 2048;
/// The largest crease sharpness a header holds: infinitely sharp (SPEC.md 9.10).
const MAX_SHARPNESS: u64 = crate::transform::fit::SHARP_INFINITE as u64;

impl Header {
    /// Serialises the header.
    pub fn write(&self) -> Vec<u8> {
        let mut w = ByteWriter::new();
        for v in [
            self.vertices,
            self.faces,
            self.corners,
            self.base_vertices,
            self.base_faces,
            self.base_corners,
        ] {
            w.varint(v);
        }
        w.u8(self.levels);
        w.u8(self.family.code());
        w.u8(self.transform.code());
        if let Transform::Fit {
            bits,
            limit,
            corners,
            linear,
            bilinear,
            limit_corners,
            extra_levels,
            end_caps,
        } = self.transform
        {
            w.u8(bits);
            let flag = |on: bool, bit: u64| if on { bit } else { 0 };
            w.varint(
                flag(limit, FIT_LIMIT)
                    | flag(!self.creases.is_empty(), FIT_CREASES)
                    | flag(corners, FIT_CORNERS)
                    | flag(linear, FIT_LINEAR)
                    | flag(!self.crease_sharpness.is_empty(), FIT_SEMI_SHARP)
                    | flag(!self.vertex_creases.is_empty(), FIT_VERTEX_CREASES)
                    | flag(!self.seams.is_empty(), FIT_SEAMS)
                    | flag(bilinear, FIT_BILINEAR)
                    | flag(limit_corners, FIT_LIMIT_CORNERS)
                    | flag(!self.vertex_sharpness.is_empty(), FIT_VERTEX_SEMI_SHARP)
                    | flag(extra_levels.is_some(), FIT_EXTRA_LEVELS)
                    | flag(end_caps.is_some(), FIT_END_CAPS),
            );
            if let Some(e) = extra_levels {
                w.u8(e);
            }
            if let Some(q) = end_caps {
                w.u8(q);
            }
        }
        match self.quantization {
            Quantization::Decimal { decimals } => {
                w.u8(0);
                w.u8(decimals);
            }
            Quantization::Float { width, exponent } => {
                w.u8(1);
                w.u8(match width {
                    FloatWidth::F32 => 32,
                    FloatWidth::F64 => 64,
                });
                w.varint_signed(exponent as i64);
            }
            Quantization::Grid { bits, origin, step } => {
                w.u8(2);
                w.u8(bits);
                for o in origin {
                    w.u32_le(o.to_bits());
                }
                w.u32_le(step.to_bits());
            }
        }
        w.u8(self.source.code());
        let flag = |on: bool, bit: u64| if on { bit } else { 0 };
        w.varint(
            flag(self.has_order, FLAG_ORDER)
                | flag(self.has_value_map, FLAG_VALUE_MAP)
                | flag(self.has_float_bits, FLAG_FLOAT_BITS)
                | flag(self.has_template, FLAG_TEMPLATE)
                | flag(self.has_corner_indices, FLAG_CORNER_INDICES)
                | flag(self.has_normals, FLAG_NORMALS),
        );
        if self.family == Family::Polar {
            write_increasing(&mut w, &self.poles);
            w.u8(self.disc.code());
        }
        if !self.creases.is_empty() {
            write_increasing(&mut w, &self.creases);
            for &s in &self.crease_sharpness {
                w.varint(s as u64);
            }
        }
        if !self.vertex_creases.is_empty() {
            write_increasing(&mut w, &self.vertex_creases);
            for &s in &self.vertex_sharpness {
                w.varint(s as u64);
            }
        }
        if !self.seams.is_empty() {
            let copies: Vec<u32> = self.seams.iter().map(|s| s.0).collect();
            write_increasing(&mut w, &copies);
            for &(c, p) in &self.seams {
                // (A partner not below its copy, which the encoder never lists, wraps
                // to a gap the reader refuses.)
                w.varint((c as u64).wrapping_sub(p as u64 + 1));
            }
        }
        w.out
    }

    /// Parses and validates a header against `limits` (SPEC.md 5).
    pub fn read(payload: &[u8], offset: u64, limits: &Limits) -> Result<Header> {
        let mut r = ByteReader::new(payload, offset);
        let mut count = |what: &'static str, limit: u64| -> Result<u64> {
            let v = r.varint(what)?;
            if v > limit {
                return Err(subwave_container::Error::Limit {
                    what,
                    requested: v,
                    limit,
                }
                .into());
            }
            Ok(v)
        };
        let vertices = count("vertices", limits.max_vertices)?;
        let faces = count("faces", limits.max_faces)?;
        let corners = count("face corners", limits.max_corners)?;
        let base_vertices = count("base vertices", limits.max_vertices)?;
        let base_faces = count("base faces", limits.max_faces)?;
        let base_corners = count("base face corners", limits.max_corners)?;
        let levels = r.u8("levels")?;
        if levels as u64 > limits.max_levels {
            return Err(subwave_container::Error::Limit {
                what: "levels",
                requested: levels as u64,
                limit: limits.max_levels,
            }
            .into());
        }
        let at = r.offset();
        let family = match r.u8("family")? {
            0 => Family::None,
            1 => Family::Cc,
            2 => Family::Sqrt2,
            3 => Family::Polar,
            f => {
                return Err(Error::Unsupported(format!(
                    "subdivision family code {f} (byte {at})"
                )))
            }
        };
        let (transform, rules) = read_transform(&mut r, levels)?;
        let quantization = read_quantization(&mut r)?;
        let source = Source::from_code(r.u8("source format")?);
        let at = r.offset();
        let flags = r.varint("flags")?;
        let known = FLAG_ORDER
            | FLAG_VALUE_MAP
            | FLAG_FLOAT_BITS
            | FLAG_TEMPLATE
            | FLAG_CORNER_INDICES
            | FLAG_NORMALS;
        if flags & !known != 0 {
            return Err(Error::Unsupported(format!(
                "header flags {flags:#x} (byte {at})"
            )));
        }
        // Polar hierarchies: the poles, as gaps, and the discs' transform (SPEC.md 5).
        let (poles, disc) = if family == Family::Polar && levels > 0 {
            read_poles(&mut r, base_vertices)?
        } else {
            (Vec::new(), DiscTransform::None)
        };
        // Fits with creases: the creased base edges, as gaps (SPEC.md 5).
        let creases = if rules & FIT_CREASES != 0 {
            read_increasing(&mut r, "crease", base_corners)?
        } else {
            Vec::new()
        };
        let crease_sharpness = if rules & FIT_SEMI_SHARP != 0 {
            read_sharpness(&mut r, creases.len())?
        } else {
            Vec::new()
        };
        let (vertex_creases, vertex_sharpness) = if rules & FIT_VERTEX_CREASES != 0 {
            let list = read_increasing(&mut r, "vertex crease", base_vertices)?;
            let sharpness = if rules & FIT_VERTEX_SEMI_SHARP != 0 {
                read_sharpness(&mut r, list.len())?
            } else {
                Vec::new()
            };
            (list, sharpness)
        } else {
            (Vec::new(), Vec::new())
        };
        // Fits with seams: the copies, as gaps, then each one's partner below it.
        let seams = if rules & FIT_SEAMS != 0 {
            let copies = read_increasing(&mut r, "seam copy", base_vertices)?;
            let mut seams = Vec::with_capacity(copies.len());
            for c in copies {
                let gap = r.varint("seam partner")?;
                if gap >= c as u64 {
                    return Err(malformed(
                        r.offset(),
                        format!("seam copy {c}'s partner is {gap} + 1 below it"),
                    ));
                }
                seams.push((c, c - 1 - gap as u32));
            }
            seams
        } else {
            Vec::new()
        };
        r.finish("the header")?;
        let h = Header {
            vertices,
            faces,
            corners,
            base_vertices,
            base_faces,
            base_corners,
            levels,
            family,
            transform,
            quantization,
            source,
            has_order: flags & FLAG_ORDER != 0,
            has_value_map: flags & FLAG_VALUE_MAP != 0,
            has_float_bits: flags & FLAG_FLOAT_BITS != 0,
            has_template: flags & FLAG_TEMPLATE != 0,
            has_corner_indices: flags & FLAG_CORNER_INDICES != 0,
            has_normals: flags & FLAG_NORMALS != 0,
            poles,
            disc,
            creases,
            crease_sharpness,
            vertex_creases,
            vertex_sharpness,
            seams,
        };
        h.check(offset, limits)?;
        Ok(h)
    }

    /// An upper bound on what decoding this container allocates (SPEC.md 2.5): 128 bytes
    /// per vertex (152 with an FBIT section, 64 more with an NRML section, 64 more for a
    /// fit with seams), 24 per corner (56 with a CIDX section), 8 per face. (Measured
    /// peaks: about 110 per vertex for the levels' values, topology, edge tables and
    /// output; the flat path's edge tables about 20 per corner; seams add the glued
    /// levels, the cut mesh's faces and the map between them, about 50 per vertex.)
    pub fn memory_estimate(&self) -> u64 {
        // (A fit with seams refines its glued levels beside the cut mesh's.)
        let per_vertex = if self.has_float_bits { 152 } else { 128 }
            + if self.has_normals { 64 } else { 0 }
            + if self.seams.is_empty() { 0 } else { 64 };
        let per_corner = if self.has_corner_indices { 56 } else { 24 };
        self.vertices
            .saturating_mul(per_vertex)
            .saturating_add(self.corners.saturating_mul(per_corner))
            .saturating_add(self.faces.saturating_mul(8))
    }

    fn check(&self, offset: u64, limits: &Limits) -> Result<()> {
        if self.levels == 0
            && (self.base_vertices != self.vertices
                || self.base_faces != self.faces
                || self.base_corners != self.corners)
        {
            return Err(malformed(
                offset,
                "base counts differ from mesh counts with no levels",
            ));
        }
        if self.has_template && !self.has_order {
            return Err(malformed(offset, "a file template without the input order"));
        }
        if self.has_corner_indices && !self.has_template {
            return Err(malformed(offset, "corner index channels without a file template"));
        }
        if self.has_normals && !self.has_template {
            return Err(malformed(offset, "normal components without a file template"));
        }
        if self.has_float_bits && !matches!(self.quantization, Quantization::Float { .. }) {
            return Err(malformed(offset, "float bits without binary float quantisation"));
        }
        if self.levels == 0 && (self.family != Family::None || self.transform != Transform::None) {
            return Err(malformed(offset, "a family or transform without levels"));
        }
        if self.levels > 0 {
            let sqrt2 = match self.family {
                Family::Cc => false,
                Family::Sqrt2 => true,
                Family::Polar if !self.poles.is_empty() => false,
                f => return Err(Error::Unsupported(format!("{} hierarchies", f.name()))),
            };
            match self.transform {
                Transform::None => {
                    return Err(malformed(offset, "levels without a transform"));
                }
                Transform::Wavelet(w) if w.is_sqrt2() != sqrt2 => {
                    return Err(malformed(
                        offset,
                        format!(
                            "transform {} does not run on {} levels",
                            w.name(),
                            self.family.name()
                        ),
                    ));
                }
                Transform::Wavelet(_) => {}
                Transform::Fit { .. } if self.family != Family::Cc => {
                    return Err(malformed(
                        offset,
                        format!("a fit on {} levels", self.family.name()),
                    ));
                }
                Transform::Fit { .. } => {}
            }
            if self.base_vertices > self.vertices
                || self.base_faces > self.faces
                || self.corners > 4 * self.faces
                || (self.family != Family::Polar && self.corners != 4 * self.faces)
                || self.base_corners < 3 * self.base_faces
            {
                return Err(malformed(
                    offset,
                    "base and mesh counts do not fit a refinement",
                ));
            }
        }
        if self.corners < 3 * self.faces || (self.faces == 0 && self.corners != 0) {
            return Err(malformed(
                offset,
                format!("{} corners cannot make {} faces", self.corners, self.faces),
            ));
        }
        if self.corners > self.faces.saturating_mul(limits.max_face_degree) {
            return Err(malformed(
                offset,
                format!(
                    "{} corners in {} faces exceed the face degree limit",
                    self.corners, self.faces
                ),
            ));
        }
        if self.faces > 0 && self.vertices < 3 {
            return Err(malformed(offset, "faces without at least 3 vertices"));
        }
        let bytes = self.memory_estimate();
        if bytes > limits.max_alloc_bytes {
            return Err(subwave_container::Error::Limit {
                what: "decoder memory (bytes)",
                requested: bytes,
                limit: limits.max_alloc_bytes,
            }
            .into());
        }
        Ok(())
    }
}

fn malformed(offset: u64, what: impl Into<String>) -> Error {
    subwave_container::Error::malformed(offset, what).into()
}

/// Writes increasing numbers as SPEC.md 5 lists poles and creases: the count, then the
/// first number and each further one's gap less one.
fn write_increasing(w: &mut ByteWriter, list: &[u32]) {
    w.varint(list.len() as u64);
    let mut prev = 0u64;
    for (i, &p) in list.iter().enumerate() {
        let p = p as u64;
        w.varint(if i == 0 { p } else { p - prev - 1 });
        prev = p;
    }
}

/// Reads what [`write_increasing`] wrote: at least one and at most `bound` numbers,
/// each below `bound`.
fn read_increasing(r: &mut ByteReader<'_>, what: &'static str, bound: u64) -> Result<Vec<u32>> {
    let n = r.varint(what)?;
    if n == 0 || n > bound {
        return Err(malformed(
            r.offset(),
            format!("{n} {what}s where at most {bound} can be"),
        ));
    }
    let mut list = Vec::new();
    let mut next = 0u64;
    for _ in 0..n {
        let p = next.saturating_add(r.varint(what)?);
        if p >= bound {
            return Err(malformed(
                r.offset(),
                format!("{what} {p} is past {bound}"),
            ));
        }
        list.push(p as u32);
        next = p + 1;
    }
    Ok(list)
}

/// `n` crease sharpnesses, each `1..=MAX_SHARPNESS` (SPEC.md 5).
fn read_sharpness(r: &mut ByteReader<'_>, n: usize) -> Result<Vec<u32>> {
    (0..n)
        .map(|_| {
            let s = r.varint("crease sharpness")?;
            if s == 0 || s > MAX_SHARPNESS {
                return Err(malformed(
                    r.offset(),
                    format!("crease sharpness {s}, not in 1..={MAX_SHARPNESS}"),
                ));
            }
            Ok(s as u32)
        })
        .collect()
}

/// The header's transform (SPEC.md 5), and for a fit its rules (0 otherwise).
fn read_transform(r: &mut ByteReader<'_>, levels: u8) -> Result<(Transform, u64)> {
    let at = r.offset();
    Ok(match r.u8("transform")? {
        0 => (Transform::None, 0),
        FIT_CODE => {
            let at = r.offset();
            let bits = r.u8("fit precision")?;
            if bits > crate::transform::fit::MAX_EXTRA_BITS {
                return Err(malformed(
                    at,
                    format!("a fit with {bits} extra bits, at most 16"),
                ));
            }
            let at = r.offset();
            let rules = r.varint("fit rules")?;
            let known = FIT_LIMIT
                | FIT_CREASES
                | FIT_CORNERS
                | FIT_LINEAR
                | FIT_SEMI_SHARP
                | FIT_VERTEX_CREASES
                | FIT_SEAMS
                | FIT_BILINEAR
                | FIT_LIMIT_CORNERS
                | FIT_VERTEX_SEMI_SHARP
                | FIT_EXTRA_LEVELS
                | FIT_END_CAPS;
            if rules & !known != 0 {
                return Err(Error::Unsupported(format!(
                    "fit rules {rules:#x} (byte {at})"
                )));
            }
            if rules & FIT_SEMI_SHARP != 0 && rules & FIT_CREASES == 0 {
                return Err(malformed(at, "crease sharpnesses without creases"));
            }
            if rules & FIT_VERTEX_SEMI_SHARP != 0 && rules & FIT_VERTEX_CREASES == 0 {
                return Err(malformed(at, "vertex sharpnesses without creased vertices"));
            }
            // Linear everywhere leaves nothing for the other rules to change.
            let moot = FIT_LIMIT | FIT_CREASES | FIT_CORNERS | FIT_LINEAR | FIT_VERTEX_CREASES;
            if rules & FIT_BILINEAR != 0 && rules & moot != 0 {
                return Err(malformed(
                    at,
                    format!("fit rules {rules:#x}: linear everywhere with other rules"),
                ));
            }
            if rules & FIT_LIMIT_CORNERS != 0 && rules & FIT_LIMIT == 0 {
                return Err(malformed(at, "limit corners without the limit"));
            }
            if rules & FIT_EXTRA_LEVELS != 0 && rules & FIT_LIMIT == 0 {
                return Err(malformed(at, "extra levels without the limit"));
            }
            let extra_levels = if rules & FIT_EXTRA_LEVELS != 0 {
                let at = r.offset();
                let e = r.u8("fit extra levels")?;
                if e > crate::transform::fit::MAX_EXTRA_LEVELS {
                    return Err(malformed(
                        at,
                        format!("a fit with {e} extra levels, at most 3"),
                    ));
                }
                Some(e)
            } else {
                None
            };
            if rules & FIT_END_CAPS != 0 && (rules & FIT_LIMIT == 0 || extra_levels.is_some()) {
                return Err(malformed(
                    at,
                    "end caps without the limit or with extra levels",
                ));
            }
            let end_caps = if rules & FIT_END_CAPS != 0 {
                let at = r.offset();
                let q = r.u8("fit end caps")?;
                let depth = crate::transform::gregory::MAX_DEPTH;
                if q == 0 || u32::from(levels) > u32::from(q) + depth {
                    return Err(malformed(
                        at,
                        format!(
                            "end caps at level {q} of {levels}: not 1 or more, or more than {depth} levels above"
                        ),
                    ));
                }
                Some(q)
            } else {
                None
            };
            let fit = Transform::Fit {
                bits,
                limit: rules & FIT_LIMIT != 0,
                corners: rules & FIT_CORNERS != 0,
                linear: rules & FIT_LINEAR != 0,
                bilinear: rules & FIT_BILINEAR != 0,
                limit_corners: rules & FIT_LIMIT_CORNERS != 0,
                extra_levels,
                end_caps,
            };
            (fit, rules)
        }
        t => match Wavelet::from_code(t) {
            Some(w) => (Transform::Wavelet(w), 0),
            _ => {
                return Err(Error::Unsupported(format!(
                    "transform code {t} (byte {at})"
                )))
            }
        },
    })
}

/// The header's quantisation (SPEC.md 5, 3).
fn read_quantization(r: &mut ByteReader<'_>) -> Result<Quantization> {
    let at = r.offset();
    Ok(match r.u8("quantisation kind")? {
        0 => {
            let decimals = r.u8("decimals")?;
            if decimals > crate::quant::MAX_DECIMALS {
                return Err(malformed(at, format!("{decimals} decimals, at most 18")));
            }
            Quantization::Decimal { decimals }
        }
        1 => {
            let width = match r.u8("float width")? {
                32 => FloatWidth::F32,
                64 => FloatWidth::F64,
                w => return Err(malformed(at, format!("float width {w}"))),
            };
            let e = r.varint_signed("float exponent")?;
            if !(-1100..=1100).contains(&e) {
                return Err(malformed(at, format!("float exponent {e}")));
            }
            Quantization::Float {
                width,
                exponent: e as i32,
            }
        }
        2 => {
            let bits = r.u8("grid bits")?;
            if !(1..=30).contains(&bits) {
                return Err(malformed(at, format!("grid of {bits} bits")));
            }
            let mut origin = [0f32; 3];
            for o in &mut origin {
                *o = f32::from_bits(r.u32_le("grid origin")?);
            }
            let step = f32::from_bits(r.u32_le("grid step")?);
            if !step.is_finite() || origin.iter().any(|o| !o.is_finite()) {
                return Err(malformed(at, "grid origin or step is not finite"));
            }
            Quantization::Grid { bits, origin, step }
        }
        k => {
            return Err(Error::Unsupported(format!(
                "quantisation kind {k} (byte {at})"
            )))
        }
    })
}

/// A polar hierarchy's poles, as gaps, and its discs' transform (SPEC.md 5).
fn read_poles(r: &mut ByteReader<'_>, base_vertices: u64) -> Result<(Vec<u32>, DiscTransform)> {
    let poles = read_increasing(r, "pole", base_vertices)?;
    let at = r.offset();
    let code = r.u8("disc transform")?;
    let disc = DiscTransform::from_code(code).ok_or_else(|| {
        Error::Unsupported(format!("disc transform code {code} (byte {at})"))
    })?;
    Ok((poles, disc))
}

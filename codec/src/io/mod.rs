//! Reading and writing OBJ, PLY (ASCII and binary), OFF and STL (ASCII and binary), keeping polygons as they
//! are and every number exact.
//!
//! OBJ is read by this crate's own reader rather than `tobj`: `tobj` renumbers vertices
//! per object in first-use order and drops unreferenced ones, which loses exactly what a
//! lossless codec must keep (the tests use `tobj` as an independent reference reader).

mod obj;
mod off;
mod ply;
mod stl;
pub(crate) mod template;

use std::collections::BTreeSet;
use std::io::Write;

use crate::error::{Error, Result};
use crate::mesh::{Attribute, Domain, Mesh, ValueType};
use crate::quant::{FloatWidth, Quantization, RawCoords};

/// Mesh file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Wavefront OBJ.
    Obj,
    /// PLY, ASCII.
    PlyAscii,
    /// PLY, binary little-endian.
    PlyBinary,
    /// PLY, binary big-endian (read only; written as little-endian).
    PlyBinaryBigEndian,
    /// Object File Format.
    Off,
    /// STL, ASCII.
    StlAscii,
    /// STL, binary (little-endian binary32 positions).
    StlBinary,
}

impl Format {
    /// The format a file name's extension names, if any (`.obj`, `.ply`, `.off`,
    /// `.stl`, in any case). `.ply` and `.stl` give the binary variant; callers choose
    /// ASCII where they prefer it.
    pub fn from_path(path: &str) -> Option<Format> {
        let ext = path.rsplit_once('.')?.1.to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(Format::Obj),
            "ply" => Some(Format::PlyBinary),
            "off" => Some(Format::Off),
            "stl" => Some(Format::StlBinary),
            _ => None,
        }
    }

    /// Guesses the format from a file's bytes: `ply`; a binary STL (an 84-byte head
    /// whose facet count accounts for the file's length); `solid` (ASCII STL); `OFF`
    /// (after any comment lines); else OBJ.
    pub fn sniff(bytes: &[u8]) -> Format {
        let head = &bytes[..bytes.len().min(4096)];
        if head.starts_with(b"ply") {
            return Format::PlyAscii;
        }
        if stl::is_binary(bytes) {
            return Format::StlBinary;
        }
        if stl::is_ascii(head) {
            return Format::StlAscii;
        }
        // The first line that is neither blank nor a comment.
        let first = head
            .split(|&b| b == b'\n')
            .map(|l| l.trim_ascii_start())
            .find(|l| !l.is_empty() && !l.starts_with(b"#"))
            .unwrap_or(&[]);
        let trimmed: Vec<u8> = first.iter().copied().take(8).collect();
        let word: Vec<u8> = trimmed
            .iter()
            .copied()
            .take_while(|b| b.is_ascii_alphabetic())
            .collect();
        if word.ends_with(b"OFF") {
            return Format::Off;
        }
        Format::Obj
    }

    /// The format's name.
    pub fn name(self) -> &'static str {
        match self {
            Format::Obj => "OBJ",
            Format::PlyAscii => "PLY (ASCII)",
            Format::PlyBinary => "PLY (binary little-endian)",
            Format::PlyBinaryBigEndian => "PLY (binary big-endian)",
            Format::Off => "OFF",
            Format::StlAscii => "STL (ASCII)",
            Format::StlBinary => "STL (binary)",
        }
    }

    /// The file name extension of the format (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            Format::Obj => "obj",
            Format::Off => "off",
            Format::PlyAscii | Format::PlyBinary | Format::PlyBinaryBigEndian => "ply",
            Format::StlAscii | Format::StlBinary => "stl",
        }
    }

    /// This format, or its ASCII variant where binary floats cannot hold values on `q`
    /// exactly: decimals in PLY (binary PLY writes floats), anything but binary32
    /// values in STL.
    pub fn exact_for(self, q: &Quantization) -> Format {
        match self {
            Format::PlyBinary | Format::PlyBinaryBigEndian
                if matches!(q, Quantization::Decimal { .. }) =>
            {
                Format::PlyAscii
            }
            Format::StlBinary if !q.prefers_f32() => Format::StlAscii,
            f => f,
        }
    }

    /// Whether this is one of the STL variants.
    pub fn is_stl(self) -> bool {
        matches!(self, Format::StlAscii | Format::StlBinary)
    }

    /// Whether this is one of the PLY variants.
    pub fn is_ply(self) -> bool {
        matches!(
            self,
            Format::PlyAscii | Format::PlyBinary | Format::PlyBinaryBigEndian
        )
    }
}

/// A mesh as read from a file, before its numbers become integers.
#[derive(Debug, Clone)]
pub struct RawMesh {
    /// Positions, exactly as written.
    pub coords: RawCoords,
    /// Faces (the positions of this value are empty).
    pub topology: Mesh,
    /// The format read.
    pub format: Format,
    /// What the file had that is not carried (normals, texture coordinates, ...).
    pub dropped: BTreeSet<String>,
    /// Why the text's decimals cannot be kept exactly, if they cannot (too many digits
    /// or too large): such a file can only be coded with `--bits`.
    pub inexact: Option<String>,
    /// Its attribute channels (texture coordinates, normals, colours, other PLY
    /// properties), before their numbers become integers.
    pub attributes: Vec<RawAttribute>,
}

/// A named attribute channel as read ([`crate::Attribute`] before its numbers become
/// integers).
#[derive(Debug, Clone)]
pub struct RawAttribute {
    /// Its name ([`crate::Attribute::name`]).
    pub name: String,
    /// What its entries belong to.
    pub domain: Domain,
    /// The type its values were written as.
    pub value_type: ValueType,
    /// Values per entry, 1..=3.
    pub width: u8,
    /// The entries (values past `width` are 0), exactly as written.
    pub values: RawCoords,
    /// [`Domain::Corner`]: per face corner, its entry.
    pub indices: Vec<u32>,
    /// The names a channel of names stands for ([`crate::Attribute::labels`]).
    pub labels: Vec<String>,
}

impl RawAttribute {
    /// A channel of names ([`crate::Attribute::labels`]) with value `values[e]` per
    /// entry: `labels[v]`, or none for -1.
    pub(crate) fn names(name: &str, domain: Domain, values: &[i64], labels: Vec<String>) -> Self {
        let int = crate::quant::Decimal::integer;
        let values = values.iter().map(|&m| [int(m), int(0), int(0)]).collect();
        RawAttribute {
            name: name.to_string(),
            domain,
            value_type: ValueType::Text,
            width: 1,
            values: RawCoords::Decimal(values),
            indices: Vec::new(),
            labels,
        }
    }

    /// The channel with its values as integers, exactly ([`crate::integerize`]).
    pub fn integerize(&self) -> Result<Attribute> {
        let (values, quantization, floats) = crate::quant::integerize(&self.values, None)?;
        Ok(Attribute {
            name: self.name.clone(),
            domain: self.domain,
            value_type: self.value_type,
            width: self.width,
            values,
            floats,
            quantization,
            indices: self.indices.clone(),
            labels: self.labels.clone(),
        })
    }
}

/// A file's lines that the writers put back as they were (an OBJ's comments and
/// `mtllib`, a PLY's header comments): a per-file channel of names, equal lines once.
#[derive(Default)]
pub(crate) struct FileLines {
    labels: Vec<String>,
    index: std::collections::HashMap<String, i64>,
    values: Vec<i64>,
}

impl FileLines {
    pub(crate) fn push(&mut self, line: &str) {
        let next = self.labels.len() as i64;
        let v = *self.index.entry(line.to_string()).or_insert(next);
        if v == next {
            self.labels.push(line.to_string());
        }
        self.values.push(v);
    }

    /// The channel `name`, if any line was kept.
    pub(crate) fn finish(self, name: &str) -> Option<RawAttribute> {
        (!self.values.is_empty())
            .then(|| RawAttribute::names(name, Domain::File, &self.values, self.labels))
    }
}

/// Reads a mesh file from bytes. The format is sniffed from the content. A file with
/// nothing in it, or that is no OBJ, PLY, OFF or STL, is an error.
pub fn read_mesh(bytes: &[u8]) -> Result<RawMesh> {
    if bytes.trim_ascii().is_empty() {
        return Err(Error::MeshFile("the file is empty: no mesh in it".into()));
    }
    let mut m = match Format::sniff(bytes) {
        Format::Off => off::read(bytes)?,
        Format::Obj => obj::read(bytes)?,
        Format::StlAscii | Format::StlBinary => stl::read(bytes)?,
        _ => ply::read(bytes)?,
    };
    check_faces(&mut m)?;
    // The faces grew as they were read: give back the room they did not fill.
    m.topology.faces.shrink_to_fit();
    m.topology.face_starts.shrink_to_fit();
    Ok(m)
}

fn check_faces(m: &mut RawMesh) -> Result<()> {
    let n = m.coords.len();
    for (f, face) in m.topology.iter_faces().enumerate() {
        if face.len() < 3 {
            return Err(Error::InvalidMesh(format!(
                "face {} has {} corners; faces need at least 3",
                f + 1,
                face.len()
            )));
        }
        if let Some(&i) = face.iter().find(|&&i| i as usize >= n) {
            return Err(Error::InvalidMesh(format!(
                "face {} refers to vertex {} but the file has only {n} vertices",
                f + 1,
                i as u64 + 1
            )));
        }
    }
    Ok(())
}

/// A file's lines, each with its line end (`\n`, and a `\r` before it, kept).
pub(crate) fn lines_with_ends(bytes: &[u8]) -> impl Iterator<Item = &[u8]> {
    bytes.split_inclusive(|&c| c == b'\n')
}

/// The template of `bytes` (SPEC.md 11) and its channels (11.1-11.3), with attributes
/// if `attributes`, a file of
/// `format` whose mesh (in the file's vertex and face order) is `mesh` on `q`, checked
/// to expand back to `bytes`; `None` where the file strays from what the walkers follow
/// (the caller keeps it whole).
pub(crate) fn template_of(
    bytes: &[u8],
    format: Format,
    mesh: &Mesh,
    q: &Quantization,
    attributes: bool,
) -> Option<(Vec<u8>, template::Channels)> {
    let walk = |attributes: bool| {
        let mut b = template::builder(mesh, q, bytes.len(), attributes);
        match format {
            Format::Obj => obj::template(bytes, &mut b)?,
            Format::PlyAscii | Format::PlyBinary | Format::PlyBinaryBigEndian => {
                ply::template(bytes, &mut b)?
            }
            Format::Off => off::template(bytes, &mut b)?,
            Format::StlAscii | Format::StlBinary => stl::template(bytes, &mut b)?,
        }
        template::checked(b, bytes)
    };
    // With attributes (SPEC.md 11.3) if asked; a file whose attributes the walk cannot
    // follow is tried again without.
    match attributes {
        true => walk(true).or_else(|| walk(false)),
        false => walk(false),
    }
}

/// An attribute's values from its text (SPEC.md 11.3): rows of three tokens, the first
/// `width` the values (the rest "0"), read as positions are (exact decimals on their
/// grid, else binary floats). (Measured: on Blender's ASCII PLY, whose values are
/// binary32s' shortest texts, the decimal grid with the values it does not write back
/// left in the template is smaller than the binary32s.)
pub(crate) fn text_values(rows: &[[&str; 3]]) -> Option<crate::quant::Integers> {
    let mut text = crate::quant::TextCoords::default();
    for r in rows {
        text.push(*r).ok()?;
    }
    crate::quant::integerize(&text.finish().0, None).ok()
}

/// Whether [`write_mesh`] writes attribute channel `a` in `format`: an OBJ its
/// `color`, `uv` and `normal` channels (`v` line colours, `vt`, `vn`), a PLY every
/// channel (per vertex and per face as properties, per corner as a face list of its
/// values for each corner in turn), OFF and STL none.
pub fn writes_attribute(format: Format, a: &Attribute) -> bool {
    match format {
        Format::Obj => obj::writes(a),
        f if f.is_ply() => ply::writes(a),
        _ => false,
    }
}

/// Writes `mesh` in `format`, mapping integers to values with `q`, with the attribute
/// channels the format holds ([`writes_attribute`]). A mesh that is not valid
/// ([`Mesh::validate`]) is an error.
pub fn write_mesh<W: Write>(out: W, mesh: &Mesh, q: &Quantization, format: Format) -> Result<()> {
    // The writers index the faces and channels as a valid mesh has them.
    mesh.validate()?;
    let mut out = std::io::BufWriter::with_capacity(1 << 16, out);
    match format {
        Format::Obj => obj::write(&mut out, mesh, q)?,
        Format::Off => off::write(&mut out, mesh, q)?,
        Format::PlyAscii => ply::write(&mut out, mesh, q, false)?,
        Format::PlyBinary | Format::PlyBinaryBigEndian => ply::write(&mut out, mesh, q, true)?,
        Format::StlAscii => stl::write(&mut out, mesh, q, false)?,
        Format::StlBinary => stl::write(&mut out, mesh, q, true)?,
    }
    out.flush()?;
    Ok(())
}

/// Writes vertex `v`'s line (`prefix x y z`) to a `String` buffer; shared by the text
/// writers.
pub(crate) fn coords_line(
    prefix: &str,
    mesh: &Mesh,
    v: usize,
    q: &Quantization,
    line: &mut String,
) {
    line.clear();
    line.push_str(prefix);
    for k in 0..3 {
        if k > 0 || !prefix.is_empty() {
            line.push(' ');
        }
        format_coord(mesh, v, k, q, line);
    }
    line.push('\n');
}

/// Appends vertex `v`'s coordinate `k` as text: the shortest text of its float when the
/// mesh keeps one, else as its quantisation writes it ([`Quantization::write_text`]).
pub(crate) fn format_coord(mesh: &Mesh, v: usize, k: usize, q: &Quantization, out: &mut String) {
    text_at(&mesh.positions, &mesh.floats, v, k, q, out)
}

/// Appends integer `v`'s decimal text (as `{}` writes it, without a formatter).
pub(crate) fn push_int(out: &mut String, v: impl itoa::Integer) {
    out.push_str(itoa::Buffer::new().format(v));
}

/// Vertex `v`'s coordinate `k` as `f64` (its float when the mesh keeps one).
pub(crate) fn value_f64(mesh: &Mesh, v: usize, k: usize, q: &Quantization) -> f64 {
    f64_at(&mesh.positions, &mesh.floats, v, k, q)
}

/// Vertex `v`'s coordinate `k` as `f32` (exact for binary32 values and grids).
pub(crate) fn value_f32(mesh: &Mesh, v: usize, k: usize, q: &Quantization) -> f32 {
    f32_at(&mesh.positions, &mesh.floats, v, k, q)
}

/// [`format_coord`] of entry `v` of the integers `p` with the float bits `f` (empty
/// when there are none): shared by positions and attribute values.
pub(crate) fn text_at(
    p: &[[i64; 3]],
    f: &[[u64; 3]],
    v: usize,
    k: usize,
    q: &Quantization,
    out: &mut String,
) {
    match (f.get(v), q) {
        (Some(f), Quantization::Float { width, .. }) => {
            use std::fmt::Write as _;
            let _ = match width {
                FloatWidth::F32 => write!(out, "{}", f32::from_bits(f[k] as u32)),
                FloatWidth::F64 => write!(out, "{}", f64::from_bits(f[k])),
            };
        }
        _ => q.write_text(p[v][k], k, out),
    }
}

/// Entry `v`'s value `k` in exponent form, as C++'s and Python's shortest float text
/// writes small and large values (`-2.3283064e-10`, `1e+16`): the shortest digits
/// that read back as the same float, one before the point, then `e`, the exponent's
/// sign and at least two digits (SPEC.md 11). `None` without float bits.
pub(crate) fn exp_text_at(
    f: &[[u64; 3]],
    v: usize,
    k: usize,
    q: &Quantization,
    out: &mut String,
) -> Option<()> {
    let (Some(f), Quantization::Float { width, .. }) = (f.get(v), q) else {
        return None;
    };
    let t = match width {
        FloatWidth::F32 => format!("{:e}", f32::from_bits(f[k] as u32)),
        FloatWidth::F64 => format!("{:e}", f64::from_bits(f[k])),
    };
    let (mantissa, exp) = t.split_once('e')?;
    let (sign, digits) = match exp.strip_prefix('-') {
        Some(d) => ('-', d),
        None => ('+', exp),
    };
    use std::fmt::Write as _;
    let _ = write!(out, "{mantissa}e{sign}{digits:0>2}");
    Some(())
}

/// [`value_f64`] of entry `v` of `p` with the float bits `f`.
pub(crate) fn f64_at(p: &[[i64; 3]], f: &[[u64; 3]], v: usize, k: usize, q: &Quantization) -> f64 {
    match (f.get(v), q) {
        (
            Some(f),
            Quantization::Float {
                width: FloatWidth::F32,
                ..
            },
        ) => f32::from_bits(f[k] as u32) as f64,
        (Some(f), _) => f64::from_bits(f[k]),
        (None, _) => q.value_f64(p[v][k], k),
    }
}

/// [`value_f32`] of entry `v` of `p` with the float bits `f`.
pub(crate) fn f32_at(p: &[[i64; 3]], f: &[[u64; 3]], v: usize, k: usize, q: &Quantization) -> f32 {
    match (f.get(v), q) {
        (
            Some(f),
            Quantization::Float {
                width: FloatWidth::F32,
                ..
            },
        ) => f32::from_bits(f[k] as u32),
        (Some(_), _) => f64_at(p, f, v, k, q) as f32,
        (None, _) => q.value_f32(p[v][k], k),
    }
}

/// Writes the vertex lines (`x y z`) and face lines (`k i0 i1 ...`, 0-based) that OFF
/// and ASCII PLY bodies share.
pub(crate) fn write_counted_text<W: Write>(
    out: &mut W,
    mesh: &Mesh,
    q: &Quantization,
) -> Result<()> {
    let mut line = String::with_capacity(128);
    for v in 0..mesh.vertex_count() {
        coords_line("", mesh, v, q, &mut line);
        out.write_all(line.as_bytes())?;
    }
    for face in mesh.iter_faces() {
        line.clear();
        push_int(&mut line, face.len());
        for &i in face {
            line.push(' ');
            push_int(&mut line, i);
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
    }
    Ok(())
}

/// A file-level syntax error with its 1-based line number.
pub(crate) fn syntax(format: &str, line: usize, what: impl std::fmt::Display) -> Error {
    Error::MeshFile(format!("{format} line {line}: {what}"))
}

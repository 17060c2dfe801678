//! The integer mesh every stage works on: positions on an integer grid and polygonal
//! faces of any degree >= 3, stored flat.

use crate::error::{Error, Result};
use crate::quant::Quantization;

/// Largest magnitude of an integer coordinate: 2^44 - 1 (SPEC.md 3.1). It leaves 19 bits of
/// headroom in `i64` for the sums of weighted neighbours the transforms accumulate.
pub const MAX_COORD: i64 = (1 << 44) - 1;

/// Bits of [`MAX_COORD`].
pub const COORD_BITS: u32 = 44;

/// A polygon mesh with integer positions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// One integer position per vertex.
    pub positions: Vec<[i64; 3]>,
    /// `faces[face_starts[f]..face_starts[f + 1]]` are face `f`'s vertex indices, in
    /// order around the face. `face_starts` has one more entry than there are faces.
    pub face_starts: Vec<u32>,
    /// All faces' vertex indices, concatenated.
    pub faces: Vec<u32>,
    /// Binary float positions finer than their grid (SPEC.md 3.2): per vertex and axis,
    /// the value's IEEE 754 bits (binary32 in the low 32 bits), from which `positions`
    /// hold the integers on the grid. Empty when every value is its integer times the
    /// grid step (decimal and grid quantisation, and floats that fit one grid).
    pub floats: Vec<[u64; 3]>,
    /// Named attribute channels (SPEC.md 11.4): texture coordinates, normals, colours,
    /// a PLY's other vertex and face properties. Each value is kept exactly, as
    /// positions are (its own [`Quantization`]); the encoder codes them in the
    /// decoded mesh's order.
    pub attributes: Vec<Attribute>,
}

/// A corner's entry in a per-corner channel when it has none (an OBJ face without
/// `vt` numbers among faces with them): [`Attribute::indices`].
pub const NO_ENTRY: u32 = u32::MAX;

/// Most named attribute channels a mesh may carry (SPEC.md 11.4).
pub const MAX_ATTRIBUTES: usize = 32;

/// What an attribute's entries belong to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Domain {
    /// One entry per vertex.
    Vertex,
    /// One entry per face.
    Face,
    /// A table of entries and, per face corner, the entry it uses
    /// ([`Attribute::indices`]): an OBJ's `vt` or `vn` with the faces' `v/vt/vn`.
    Corner,
    /// Entries of the file as a whole, any number of them: an OBJ's lines that name
    /// no vertex (comments, `mtllib`), a PLY's header comments and the records of its
    /// other elements.
    File,
}

impl Domain {
    /// Its name: `vertex`, `face`, `corner` or `file`.
    pub fn name(self) -> &'static str {
        match self {
            Domain::Vertex => "vertex",
            Domain::Face => "face",
            Domain::Corner => "corner",
            Domain::File => "file",
        }
    }
}

/// The type an attribute's values are written as (a PLY property's type; `Text` for a
/// value written as text, as an OBJ's are).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValueType {
    /// Text, as its quantisation writes it.
    Text,
    /// IEEE 754 binary32.
    F32,
    /// IEEE 754 binary64.
    F64,
    /// 8-bit signed integer.
    I8,
    /// 8-bit unsigned integer.
    U8,
    /// 16-bit signed integer.
    I16,
    /// 16-bit unsigned integer.
    U16,
    /// 32-bit signed integer.
    I32,
    /// 32-bit unsigned integer.
    U32,
}

impl ValueType {
    /// Every type, in the order of their codes (SPEC.md 11.4).
    pub const ALL: [ValueType; 9] = [
        ValueType::Text,
        ValueType::F32,
        ValueType::F64,
        ValueType::I8,
        ValueType::U8,
        ValueType::I16,
        ValueType::U16,
        ValueType::I32,
        ValueType::U32,
    ];

    /// The type's code in a CHAN section (SPEC.md 11.4).
    pub fn code(self) -> u8 {
        ValueType::ALL.iter().position(|&t| t == self).unwrap_or(0) as u8
    }

    /// The type of a code, if any.
    pub fn from_code(c: u8) -> Option<ValueType> {
        ValueType::ALL.get(c as usize).copied()
    }

    /// The range of an integer type; `None` for text and floats.
    pub fn int_range(self) -> Option<(i64, i64)> {
        Some(match self {
            ValueType::I8 => (i8::MIN as i64, i8::MAX as i64),
            ValueType::U8 => (0, u8::MAX as i64),
            ValueType::I16 => (i16::MIN as i64, i16::MAX as i64),
            ValueType::U16 => (0, u16::MAX as i64),
            ValueType::I32 => (i32::MIN as i64, i32::MAX as i64),
            ValueType::U32 => (0, u32::MAX as i64),
            _ => return None,
        })
    }

    /// Its name in a PLY header.
    pub fn ply_name(self) -> &'static str {
        match self {
            ValueType::Text | ValueType::F32 => "float",
            ValueType::F64 => "double",
            ValueType::I8 => "char",
            ValueType::U8 => "uchar",
            ValueType::I16 => "short",
            ValueType::U16 => "ushort",
            ValueType::I32 => "int",
            ValueType::U32 => "uint",
        }
    }
}

/// A named attribute channel: `width` values per entry, each kept exactly as integers
/// on its own [`Quantization`] (and binary float bits where they are finer), as
/// positions are.
#[derive(Debug, Clone, PartialEq)]
pub struct Attribute {
    /// Its name: `uv`, `normal` or `color` for an OBJ's `vt`, `vn` and vertex colours;
    /// a PLY's property names, space-separated (`red green blue`).
    pub name: String,
    /// What its entries belong to.
    pub domain: Domain,
    /// The type its values are written as.
    pub value_type: ValueType,
    /// Values per entry, 1..=3.
    pub width: u8,
    /// Per entry, its values' integers (those past `width` are 0).
    pub values: Vec<[i64; 3]>,
    /// Per entry, its values' IEEE 754 bits where the values are binary floats finer
    /// than their grid (as [`Mesh::floats`]); else empty.
    pub floats: Vec<[u64; 3]>,
    /// How the integers map to values.
    pub quantization: Quantization,
    /// [`Domain::Corner`]: per face corner (in the order of [`Mesh::faces`]), its
    /// entry, or [`NO_ENTRY`] for none. For the other domains, empty, or for a *list
    /// channel* (a PLY list property of any length per record, one value per entry)
    /// per vertex, face or record its number of entries: the entries hold every
    /// record's list in turn ([`Attribute::list`]).
    pub indices: Vec<u32>,
    /// A channel of names (an OBJ's materials, groups, objects, smoothing groups): the
    /// names its values (one per entry, integers) stand for, value `i` for
    /// `labels[i]` and -1 for none. Empty for a channel of numbers.
    pub labels: Vec<String>,
}

impl Attribute {
    /// Whether it is a list channel: a list of values per vertex, face or record
    /// ([`Attribute::indices`]).
    pub fn is_list(&self) -> bool {
        self.domain != Domain::Corner && !self.indices.is_empty()
    }

    /// A list channel's records (vertices, faces or the file's records), each the
    /// range of its entries.
    pub fn list(&self) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        let mut start = 0usize;
        self.indices.iter().map(move |&n| {
            let r = start..start + n as usize;
            start = r.end;
            r
        })
    }

    /// In a channel of names, the name value `v` stands for (none for -1 or a value
    /// past its names).
    pub fn label(&self, v: i64) -> Option<&str> {
        usize::try_from(v).ok().and_then(|i| self.labels.get(i)).map(String::as_str)
    }

    /// Number of entries.
    pub fn entry_count(&self) -> usize {
        self.values.len()
    }

    /// Entry `e`'s value `k` as `f64` (exact for binary32 and binary64 values and for
    /// integers below 2^53).
    pub fn value_f64(&self, e: usize, k: usize) -> f64 {
        crate::io::f64_at(&self.values, &self.floats, e, k, &self.quantization)
    }

    /// Entry `e`'s value `k` as text, as an OBJ or ASCII PLY writes it (the shortest
    /// text of a binary float; a decimal with its own decimals).
    pub fn value_text(&self, e: usize, k: usize) -> String {
        let mut s = String::new();
        crate::io::text_at(&self.values, &self.floats, e, k, &self.quantization, &mut s);
        s
    }

    /// Appends entry `e`'s values as text ([`Attribute::value_text`]), each after a
    /// space: what the text writers put on a line.
    pub(crate) fn push_text(&self, e: usize, out: &mut String) {
        for k in 0..self.width as usize {
            out.push(' ');
            crate::io::text_at(&self.values, &self.floats, e, k, &self.quantization, out);
        }
    }

    /// Which of a per-file channel's values number vertices (from 0), by the PLY
    /// convention of its name: `ELEMENT/PROPERTIES` whose property is `vertex1`,
    /// `vertex2`, `vertex_index` (an `edge` element's ends) or `vertex_indices` (a
    /// list), of an integer type. The encoder renumbers them with the vertices when it
    /// reorders them.
    pub fn vertex_components(&self) -> [bool; 3] {
        let mut out = [false; 3];
        let props = match (self.domain, self.value_type.int_range(), self.name.split_once('/')) {
            (Domain::File, Some(_), Some((_, props))) if self.labels.is_empty() => props,
            _ => return out,
        };
        let words: Vec<&str> = props.split_ascii_whitespace().collect();
        if words.len() == self.width as usize {
            for (k, w) in words.iter().enumerate() {
                out[k] = matches!(*w, "vertex1" | "vertex2" | "vertex_index" | "vertex_indices");
            }
        }
        out
    }

    /// Its values with those that number vertices ([`Attribute::vertex_components`])
    /// renumbered for vertices in the order `order` (new vertex `i` is old `order[i]`),
    /// as the encoder codes them in canonical order: each that is an old vertex's
    /// number and whose new number fits the channel's type (the others as they are).
    pub fn renumbered(&self, order: &[u32]) -> Vec<[i64; 3]> {
        let ks = self.vertex_components();
        if !ks.iter().any(|&k| k) {
            return self.values.clone();
        }
        let mut new = vec![0i64; order.len()];
        for (i, &o) in order.iter().enumerate() {
            if let Some(n) = new.get_mut(o as usize) {
                *n = i as i64;
            }
        }
        let hi = self.value_type.int_range().map_or(0, |r| r.1);
        let mut out = self.values.clone();
        for v in &mut out {
            for k in (0..3).filter(|&k| ks[k]) {
                match usize::try_from(v[k]).ok().and_then(|i| new.get(i)) {
                    Some(&n) if n <= hi => v[k] = n,
                    _ => {}
                }
            }
        }
        out
    }

    /// Checks the channel against `mesh`: its width, its entries per domain, its
    /// indices in range, its values within [`MAX_COORD`].
    pub(crate) fn validate(&self, mesh: &Mesh) -> Result<()> {
        let bad = |what: String| Err(Error::InvalidMesh(format!("attribute '{}': {what}", self.name)));
        if !(1..=3).contains(&self.width) {
            return bad(format!("{} values per entry (1 to 3)", self.width));
        }
        if self.name.len() > 255 {
            return bad("a name longer than 255 bytes".into());
        }
        if !self.floats.is_empty() && self.floats.len() != self.values.len() {
            return bad(format!("{} float values for {} entries", self.floats.len(), self.values.len()));
        }
        let want = match self.domain {
            Domain::Vertex => Some((mesh.vertex_count(), "vertices")),
            Domain::Face => Some((mesh.face_count(), "faces")),
            Domain::Corner | Domain::File => None,
        };
        if self.is_list() {
            if let Some((n, what)) = want.filter(|&(n, _)| n != self.indices.len()) {
                return bad(format!("{} lists for {n} {what}", self.indices.len()));
            }
            let total: u64 = self.indices.iter().map(|&n| n as u64).sum();
            if total != self.values.len() as u64 {
                return bad(format!("lists of {total} values in all, {} entries", self.values.len()));
            }
            if self.width != 1 || !self.labels.is_empty() {
                return bad("a list channel needs one value per entry and no names".into());
            }
        } else if let Some((n, what)) = want {
            if self.values.len() != n {
                return bad(format!("{} entries for {n} {what}", self.values.len()));
            }
        } else if self.domain == Domain::Corner {
            if self.indices.len() != mesh.corner_count() {
                return bad(format!("{} corner indices for {} corners", self.indices.len(), mesh.corner_count()));
            }
            let past = |i: u32| i as usize >= self.values.len() && i != NO_ENTRY;
            if let Some(&i) = self.indices.iter().find(|&&i| past(i)) {
                return bad(format!("corner index {i} past its {} entries", self.values.len()));
            }
        }
        if !self.labels.is_empty() {
            let n = self.labels.len() as i64;
            if self.width != 1 || self.quantization != (Quantization::Decimal { decimals: 0 }) {
                return bad("names need one integer per entry".into());
            }
            if let Some(v) = self.values.iter().find(|v| !(-1..n).contains(&v[0])) {
                return bad(format!("value {} names none of its {n} names", v[0]));
            }
        }
        if let Some((lo, hi)) = self.value_type.int_range() {
            if self.quantization != (Quantization::Decimal { decimals: 0 }) {
                return bad(format!(
                    "{:?} values need integers (decimal quantisation with 0 decimals)",
                    self.value_type
                ));
            }
            if let Some(v) = self.values.iter().flatten().find(|&&v| v < lo || v > hi) {
                return bad(format!("{v} is outside the {:?} range", self.value_type));
            }
        }
        if self.values.iter().any(|p| p.iter().any(|c| c.abs() > MAX_COORD)) {
            return bad(format!("a value outside the codec's range of +-(2^{COORD_BITS} - 1)"));
        }
        Ok(())
    }
}

impl Mesh {
    /// An empty mesh.
    pub fn new() -> Self {
        Mesh {
            positions: Vec::new(),
            face_starts: vec![0],
            faces: Vec::new(),
            floats: Vec::new(),
            attributes: Vec::new(),
        }
    }

    /// The attribute channel named `name`, if any.
    pub fn attribute(&self, name: &str) -> Option<&Attribute> {
        self.attributes.iter().find(|a| a.name == name)
    }

    /// The mesh without its attribute channels (positions and faces only).
    pub fn without_attributes(&self) -> Mesh {
        Mesh {
            positions: self.positions.clone(),
            face_starts: self.face_starts.clone(),
            faces: self.faces.clone(),
            floats: self.floats.clone(),
            attributes: Vec::new(),
        }
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.face_starts.len().saturating_sub(1)
    }

    /// Number of face corners (the sum of face degrees).
    pub fn corner_count(&self) -> usize {
        self.faces.len()
    }

    /// Face `f`'s vertex indices.
    pub fn face(&self, f: usize) -> &[u32] {
        &self.faces[self.face_starts[f] as usize..self.face_starts[f + 1] as usize]
    }

    /// Iterates over the faces.
    pub fn iter_faces(&self) -> impl Iterator<Item = &[u32]> + '_ {
        self.face_starts
            .windows(2)
            .map(move |w| &self.faces[w[0] as usize..w[1] as usize])
    }

    /// Appends a face.
    pub fn push_face(&mut self, corners: &[u32]) {
        if self.face_starts.is_empty() {
            self.face_starts.push(0);
        }
        self.faces.extend_from_slice(corners);
        self.face_starts.push(self.faces.len() as u32);
    }

    /// Checks the invariants every stage relies on: face structure consistent, every
    /// face has at least 3 corners, every index is in range, every coordinate is within
    /// [`MAX_COORD`].
    pub fn validate(&self) -> Result<()> {
        if self.face_starts.first() != Some(&0)
            || self.face_starts.last().map(|&e| e as usize) != Some(self.faces.len())
            || self.face_starts.windows(2).any(|w| w[1] < w[0])
        {
            return Err(Error::InvalidMesh("face table is inconsistent".into()));
        }
        if !self.floats.is_empty() && self.floats.len() != self.positions.len() {
            return Err(Error::InvalidMesh(format!(
                "{} float values for {} vertices",
                self.floats.len(),
                self.positions.len()
            )));
        }
        if self.face_count() > 0 && self.positions.len() < 3 {
            return Err(Error::InvalidMesh(format!(
                "{} faces on {} vertices; faces need at least 3",
                self.face_count(),
                self.positions.len()
            )));
        }
        if self.positions.len() > u32::MAX as usize {
            return Err(Error::InvalidMesh("more than 2^32 - 1 vertices".into()));
        }
        for (f, face) in self.iter_faces().enumerate() {
            if face.len() < 3 {
                return Err(Error::InvalidMesh(format!(
                    "face {} has {} corners; faces need at least 3",
                    f + 1,
                    face.len()
                )));
            }
            if let Some(&i) = face.iter().find(|&&i| i as usize >= self.positions.len()) {
                return Err(Error::InvalidMesh(format!(
                    "face {} refers to vertex {} but there are only {} vertices",
                    f + 1,
                    i as u64 + 1,
                    self.positions.len()
                )));
            }
        }
        if let Some((v, p)) = self
            .positions
            .iter()
            .enumerate()
            .find(|(_, p)| p.iter().any(|c| c.abs() > MAX_COORD))
        {
            return Err(Error::Range(format!(
                "vertex {} has coordinate {:?} outside the codec's range of +-(2^{} - 1)",
                v + 1,
                p,
                COORD_BITS
            )));
        }
        if self.attributes.len() > MAX_ATTRIBUTES {
            return Err(Error::InvalidMesh(format!(
                "{} attribute channels; at most {MAX_ATTRIBUTES}",
                self.attributes.len()
            )));
        }
        for a in &self.attributes {
            a.validate(self)?;
        }
        Ok(())
    }
}

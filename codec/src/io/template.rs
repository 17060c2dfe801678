//! A mesh file's own bytes around the values the codec codes (SPEC.md 11): the file
//! with each coordinate and each face corner's vertex index replaced by a marker where
//! the decoded mesh writes it the same way, so that the decoder gives the file back byte
//! for byte. Everything else (attributes, comments, number styles, line endings, a PLY
//! header) is kept as it is; the TMPL section compresses it.

use super::{exp_text_at, format_coord, value_f32, value_f64};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::quant::Quantization;
use crate::sections::cidx::{CornerIndices, IndexChannel, MAX_CHANNELS};
use crate::sections::nrml::Component;

/// The values a template's channel markers write (SPEC.md 11.1-11.3): the corner index
/// channels, the normal components and the attributes.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Channels {
    /// Corner index channels (CIDX).
    pub indices: CornerIndices,
    /// Normal components, three per `vn` line (NRML).
    pub normals: Vec<Component>,
    /// Attributes coded as meshes of their own (ATTR).
    pub attributes: Vec<Attribute>,
}

/// A vertex attribute of a file as the positions of a mesh of its own (SPEC.md 11.3):
/// `width` values per entry (1..=3; the positions' other axes are 0), entry i the
/// mesh's vertex i, its faces the attribute's.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Attribute {
    /// Its name, as a channel of the file would have it (`uv`, `color`, a PLY's
    /// property names), for `info`.
    pub name: String,
    /// Values per entry, 1..=3.
    pub width: u8,
    /// The entries as positions, and the faces they form.
    pub mesh: Mesh,
    /// How the positions' integers map to the file's values.
    pub q: Quantization,
}

impl Attribute {
    /// An attribute of `width` values per entry, the integers `values`, on `faces`'
    /// faces.
    pub(crate) fn on_faces(width: usize, values: crate::quant::Integers, faces: &Mesh) -> Self {
        let (positions, q, floats) = values;
        Attribute {
            name: String::new(),
            width: width as u8,
            mesh: Mesh {
                positions,
                face_starts: faces.face_starts.clone(),
                faces: faces.faces.clone(),
                floats,
                attributes: Vec::new(),
            },
            q,
        }
    }

    /// The attribute named `name`.
    pub(crate) fn named(self, name: &str) -> Self {
        Attribute {
            name: name.to_string(),
            ..self
        }
    }
}

/// The channel number of normal components after marker [`CHANNEL_TEXT`].
pub(crate) const NORMAL_MARK: u8 = 4;
/// Channel numbers from this on, after marker [`CHANNEL_TEXT`]: attribute
/// `k - FIRST_ATTRIBUTE`, then a form byte ([`Form`]).
pub(crate) const FIRST_ATTRIBUTE: u8 = 16;
/// Most attributes a template may use.
pub(crate) const MAX_ATTRIBUTES: usize = 16;

/// How an attribute value is written (SPEC.md 11.3): the byte after an attribute's
/// channel number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub(crate) enum Form {
    /// As text, as a coordinate is (marker 0x01).
    Text = 0,
    F32Le = 1,
    F32Be = 2,
    F64Le = 3,
    F64Be = 4,
    I8 = 5,
    U8 = 6,
    I16Le = 7,
    I16Be = 8,
    U16Le = 9,
    U16Be = 10,
    I32Le = 11,
    I32Be = 12,
    U32Le = 13,
    U32Be = 14,
    /// Not written here (the bytes stand literally beside).
    Skip = 15,
    /// Not a value: the last corner's vertex in the attribute's faces, counted from 1,
    /// as decimal text (an OBJ corner's `vt` number).
    Corner = 16,
    /// Text in exponent form (SPEC.md 11: as 0x10 writes a coordinate).
    TextExp = 17,
}

impl Form {
    fn from_byte(b: u8) -> Option<Form> {
        use Form::*;
        [
            Text, F32Le, F32Be, F64Le, F64Be, I8, U8, I16Le, I16Be, U16Le, U16Be, I32Le, I32Be,
            U32Le, U32Be, Skip, Corner, TextExp,
        ]
        .get(b as usize)
        .copied()
    }

    /// The form of a binary value of `size` bytes, a float or not, signed or not.
    pub(crate) fn binary(size: usize, float: bool, signed: bool, big: bool) -> Option<Form> {
        use Form::*;
        Some(match (size, float, signed, big) {
            (4, true, _, false) => F32Le,
            (4, true, _, true) => F32Be,
            (8, true, _, false) => F64Le,
            (8, true, _, true) => F64Be,
            (1, false, true, _) => I8,
            (1, false, false, _) => U8,
            (2, false, true, false) => I16Le,
            (2, false, true, true) => I16Be,
            (2, false, false, false) => U16Le,
            (2, false, false, true) => U16Be,
            (4, false, true, false) => I32Le,
            (4, false, true, true) => I32Be,
            (4, false, false, false) => U32Le,
            (4, false, false, true) => U32Be,
            _ => return None,
        })
    }

    /// Appends value `i` of attribute `a` in this form; `None` where there is no such
    /// value or an integer form cannot hold it.
    fn write(self, a: &Attribute, i: usize, out: &mut Vec<u8>) -> Option<()> {
        let w = a.width as usize;
        let (v, k) = (i / w, i % w);
        if v >= a.mesh.vertex_count() {
            return None;
        }
        let int = || match a.q {
            Quantization::Decimal { decimals: 0 } => Some(a.mesh.positions[v][k]),
            _ => None,
        };
        use Form::*;
        match self {
            Text => {
                let mut t = String::new();
                format_coord(&a.mesh, v, k, &a.q, &mut t);
                out.extend_from_slice(t.as_bytes());
            }
            TextExp => {
                let mut t = String::new();
                exp_text_at(&a.mesh.floats, v, k, &a.q, &mut t)?;
                out.extend_from_slice(t.as_bytes());
            }
            F32Le => out.extend_from_slice(&value_f32(&a.mesh, v, k, &a.q).to_le_bytes()),
            F32Be => out.extend_from_slice(&value_f32(&a.mesh, v, k, &a.q).to_be_bytes()),
            F64Le => out.extend_from_slice(&value_f64(&a.mesh, v, k, &a.q).to_le_bytes()),
            F64Be => out.extend_from_slice(&value_f64(&a.mesh, v, k, &a.q).to_be_bytes()),
            I8 => out.extend_from_slice(&i8::try_from(int()?).ok()?.to_le_bytes()),
            U8 => out.extend_from_slice(&u8::try_from(int()?).ok()?.to_le_bytes()),
            I16Le => out.extend_from_slice(&i16::try_from(int()?).ok()?.to_le_bytes()),
            I16Be => out.extend_from_slice(&i16::try_from(int()?).ok()?.to_be_bytes()),
            U16Le => out.extend_from_slice(&u16::try_from(int()?).ok()?.to_le_bytes()),
            U16Be => out.extend_from_slice(&u16::try_from(int()?).ok()?.to_be_bytes()),
            I32Le => out.extend_from_slice(&i32::try_from(int()?).ok()?.to_le_bytes()),
            I32Be => out.extend_from_slice(&i32::try_from(int()?).ok()?.to_be_bytes()),
            U32Le => out.extend_from_slice(&u32::try_from(int()?).ok()?.to_le_bytes()),
            U32Be => out.extend_from_slice(&u32::try_from(int()?).ok()?.to_be_bytes()),
            Skip | Corner => {}
        }
        Some(())
    }
}

/// Expands an attribute marker (SPEC.md 11.3): attribute `g` and the form byte, after
/// `corner` corners; `used` counts each attribute's values written.
fn attribute_marker(
    (g, form): (u8, Option<u8>),
    channels: &Channels,
    corner: usize,
    used: &mut [usize],
    out: &mut Vec<u8>,
) -> Result<()> {
    let bad = |what: &str| Error::corrupt("TMPL", what.to_string());
    let g = g as usize;
    let form = form
        .and_then(Form::from_byte)
        .ok_or_else(|| bad("an attribute marker without its form"))?;
    let a = channels
        .attributes
        .get(g)
        .ok_or_else(|| bad("an attribute marker past the ATTR sections"))?;
    if form == Form::Corner {
        let v = corner
            .checked_sub(1)
            .and_then(|c| attribute_corner(a, c))
            .ok_or_else(|| bad("a corner marker past the attribute's faces"))?;
        out.extend_from_slice(itoa::Buffer::new().format(v).as_bytes());
        return Ok(());
    }
    form.write(a, used[g], out).ok_or_else(|| {
        bad("an attribute value past the attribute's, or out of its type's range")
    })?;
    used[g] += 1;
    Ok(())
}

/// Corner `c`'s vertex in attribute `a`'s faces, counted from 1, when `a`'s faces
/// have the mesh's corners.
fn attribute_corner(a: &Attribute, c: usize) -> Option<u64> {
    a.mesh.faces.get(c).map(|&v| v as u64 + 1)
}

/// The next coordinate, as text (how [`format_coord`] writes it).
const COORD_TEXT: u8 = 1;
/// The next corner's vertex index, as text, counted from 1.
const INDEX_TEXT_1: u8 = 2;
/// The next byte is literal.
const ESCAPE: u8 = 3;
/// The next coordinate is not written here (its text stands literally beside).
const SKIP_COORD: u8 = 4;
/// The next corner index is not written here.
const SKIP_INDEX: u8 = 5;
/// The next corner's vertex index, as text, counted from 0.
const INDEX_TEXT_0: u8 = 6;
/// The next coordinate as binary32, little-endian.
const COORD_F32_LE: u8 = 7;
/// The next coordinate as binary64, little-endian.
const COORD_F64_LE: u8 = 8;
/// The next corner index as a 32-bit integer, little-endian.
const INDEX_32_LE: u8 = 9;
/// The next coordinate as binary32, big-endian.
const COORD_F32_BE: u8 = 10;
/// The next coordinate as binary64, big-endian.
const COORD_F64_BE: u8 = 11;
/// The next corner index as a 32-bit integer, big-endian.
const INDEX_32_BE: u8 = 12;
/// The next corner's vertex's three coordinates as binary32, little-endian (STL).
const CORNER_F32_LE: u8 = 13;
/// The next corner's vertex's three coordinates as text, a space before each (STL).
const CORNER_TEXT: u8 = 14;
/// Followed by a channel number k: the next value of corner index channel k (CIDX,
/// SPEC.md 11.1) as text.
const CHANNEL_TEXT: u8 = 15;
/// The next coordinate as text in exponent form (a vertex with float bits).
const COORD_EXP: u8 = 16;
/// Bytes at most this are markers; a literal one is escaped.
const LAST_MARKER: u8 = 16;

/// Builds a template while a format's walker reads the file.
pub(super) struct Builder<'m> {
    out: Vec<u8>,
    mesh: &'m Mesh,
    q: &'m Quantization,
    /// Coordinates and corners met so far.
    coord: usize,
    corner: usize,
    text: String,
    /// The channels' values the markers stand for.
    channels: Channels,
    /// Whether the walk may make attributes.
    attributes: bool,
    /// Values of each attribute met so far.
    attr_used: Vec<usize>,
    /// The attribute whose faces give channel 0's values (an OBJ's `vt` table), when
    /// they have the mesh's corners.
    uv_attribute: Option<usize>,
}

impl<'m> Builder<'m> {
    fn new(mesh: &'m Mesh, q: &'m Quantization, capacity: usize) -> Self {
        Builder {
            out: Vec::with_capacity(capacity),
            mesh,
            q,
            coord: 0,
            corner: 0,
            text: String::new(),
            channels: Channels::default(),
            attributes: true,
            attr_used: Vec::new(),
            uv_attribute: None,
        }
    }

    /// The mesh the template is of, in the file's order.
    pub(super) fn mesh(&self) -> &'m Mesh {
        self.mesh
    }

    /// Takes `a` as the next attribute, if the walk may make one: its number.
    pub(super) fn attribute(&mut self, a: Attribute) -> Option<usize> {
        let g = self.channels.attributes.len();
        if !self.attributes || g >= MAX_ATTRIBUTES || a.mesh.validate().is_err() {
            return None;
        }
        self.channels.attributes.push(a);
        self.attr_used.push(0);
        Some(g)
    }

    /// Takes attribute `g`'s faces as the source of channel 0's values (an OBJ's `vt`
    /// numbers, SPEC.md 11.3), if they have the mesh's corners.
    pub(super) fn corners_from(&mut self, g: Option<usize>) {
        self.uv_attribute =
            g.filter(|&g| self.channels.attributes[g].mesh.face_starts == self.mesh.face_starts);
    }

    /// The next value of attribute `g`, written in the file as `token` in `form`: its
    /// marker where the attribute writes it the same way, else the marker that skips
    /// it and the token as it stands.
    pub(super) fn attr_value(&mut self, g: usize, form: Form, token: &[u8]) {
        let i = self.attr_used[g];
        self.attr_used[g] += 1;
        let mut w = Vec::with_capacity(token.len());
        let a = &self.channels.attributes[g];
        let mut same = |form: Form| {
            w.clear();
            form.write(a, i, &mut w).is_some() && w == token
        };
        let form = match form {
            f if same(f) => f,
            Form::Text if same(Form::TextExp) => Form::TextExp,
            _ => Form::Skip,
        };
        let same = form != Form::Skip;
        self.out
            .extend_from_slice(&[CHANNEL_TEXT, FIRST_ATTRIBUTE + g as u8, form as u8]);
        if !same {
            self.literal(token);
        }
    }

    /// Bytes kept as they are.
    pub(super) fn literal(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if (1..=LAST_MARKER).contains(&b) {
                self.out.push(ESCAPE);
            }
            self.out.push(b);
        }
    }

    /// The next coordinate, written in the file as `token`.
    pub(super) fn coord_text(&mut self, token: &[u8]) {
        let (v, k) = (self.coord / 3, self.coord % 3);
        self.coord += 1;
        self.text.clear();
        if v < self.mesh.vertex_count() {
            format_coord(self.mesh, v, k, self.q, &mut self.text);
        }
        if v < self.mesh.vertex_count() && self.text.as_bytes() == token {
            self.out.push(COORD_TEXT);
            return;
        }
        self.text.clear();
        let exp = exp_text_at(&self.mesh.floats, v, k, self.q, &mut self.text);
        if exp.is_some() && self.text.as_bytes() == token {
            self.out.push(COORD_EXP);
        } else {
            self.out.push(SKIP_COORD);
            self.literal(token);
        }
    }

    /// The next corner's vertex index, written as `token`, counted from `base`.
    pub(super) fn index_text(&mut self, token: &[u8], base: u32) {
        let c = self.corner;
        self.corner += 1;
        let mut text = itoa::Buffer::new();
        let want = self
            .mesh
            .faces
            .get(c)
            .map(|&i| text.format(i as u64 + base as u64));
        if want.map(str::as_bytes) == Some(token) {
            self.out.push(if base == 1 {
                INDEX_TEXT_1
            } else {
                INDEX_TEXT_0
            });
        } else {
            self.out.push(SKIP_INDEX);
            self.literal(token);
        }
    }

    /// A number of channel `k` (an OBJ corner's `vt` or `vn` number) at the last corner
    /// met, written as `token`: a marker where the token is a number's plain decimal
    /// text (SPEC.md 11.1), else the token as it stands.
    pub(super) fn channel_text(&mut self, k: u8, token: &[u8]) {
        let corner = self.corner.checked_sub(1).map(|c| c as u32);
        let value = plain_decimal(token);
        let ki = k as usize;
        // A `vt` number that the `vt` attribute's faces give (SPEC.md 11.3).
        if let (0, Some(c), Some(a), Some(g)) = (k, corner, value, self.uv_attribute) {
            if attribute_corner(&self.channels.attributes[g], c as usize) == Some(a as u64) {
                self.out.extend_from_slice(&[
                    CHANNEL_TEXT,
                    FIRST_ATTRIBUTE + g as u8,
                    Form::Corner as u8,
                ]);
                return;
            }
        }
        if let (Some(c), Some(a), true) = (corner, value, ki < MAX_CHANNELS) {
            let indices = &mut self.channels.indices;
            if indices.channels.len() <= ki {
                indices.channels.resize(ki + 1, IndexChannel::default());
            }
            let ch = &mut indices.channels[ki];
            if ch.corners.last().is_none_or(|&l| l < c) {
                ch.corners.push(c);
                ch.values.push(a);
                self.out.extend_from_slice(&[CHANNEL_TEXT, k]);
                return;
            }
        }
        self.literal(token);
    }

    /// A normal component (an OBJ `vn` value), written as `token`, a plain decimal
    /// ([`Component::parse`]): marker 0x0F 4 (SPEC.md 11.2).
    pub(super) fn normal_text(&mut self, c: Component) {
        self.channels.normals.push(c);
        self.out.extend_from_slice(&[CHANNEL_TEXT, NORMAL_MARK]);
    }

    /// The next coordinate, stored as the binary float `bytes` (4 or 8, `big` endian).
    pub(super) fn coord_binary(&mut self, bytes: &[u8], big: bool) {
        let (v, k) = (self.coord / 3, self.coord % 3);
        self.coord += 1;
        let want: Option<Vec<u8>> =
            (v < self.mesh.vertex_count()).then(|| match (bytes.len(), big) {
                (4, false) => value_f32(self.mesh, v, k, self.q).to_le_bytes().to_vec(),
                (4, true) => value_f32(self.mesh, v, k, self.q).to_be_bytes().to_vec(),
                (_, false) => value_f64(self.mesh, v, k, self.q).to_le_bytes().to_vec(),
                (_, true) => value_f64(self.mesh, v, k, self.q).to_be_bytes().to_vec(),
            });
        if want.as_deref() == Some(bytes) {
            self.out.push(match (bytes.len(), big) {
                (4, false) => COORD_F32_LE,
                (4, true) => COORD_F32_BE,
                (_, false) => COORD_F64_LE,
                (_, true) => COORD_F64_BE,
            });
        } else {
            self.out.push(SKIP_COORD);
            self.literal(bytes);
        }
    }

    /// The next corner index, stored as the 32-bit integer `bytes` (`big` endian).
    pub(super) fn index_binary(&mut self, bytes: &[u8], big: bool) {
        let c = self.corner;
        self.corner += 1;
        let want = self.mesh.faces.get(c).map(|&i| match big {
            false => i.to_le_bytes(),
            true => i.to_be_bytes(),
        });
        if bytes.len() == 4 && want.as_ref().map(|w| &w[..]) == Some(bytes) {
            self.out.push(if big { INDEX_32_BE } else { INDEX_32_LE });
        } else {
            self.out.push(SKIP_INDEX);
            self.literal(bytes);
        }
    }
}

impl Builder<'_> {
    /// The next corner's position, written in the file as `bytes` (STL): marker
    /// `marker` ([`CORNER_F32_LE`] or [`CORNER_TEXT`]) where the corner's vertex writes
    /// it the same way.
    fn corner(&mut self, marker: u8, bytes: &[u8]) {
        let c = self.corner;
        self.corner += 1;
        let want = self.mesh.faces.get(c).map(|&v| {
            let mut w = Vec::with_capacity(bytes.len());
            write_corner(marker, self.mesh, v as usize, self.q, &mut w);
            w
        });
        if want.as_deref() == Some(bytes) {
            self.out.push(marker);
        } else {
            self.out.push(SKIP_INDEX);
            self.literal(bytes);
        }
    }

    /// The next corner's position, stored as three binary32 little-endian `bytes`.
    pub(super) fn corner_f32(&mut self, bytes: &[u8]) {
        self.corner(CORNER_F32_LE, bytes);
    }

    /// The next corner's position, written as three (gap, token) pairs.
    pub(super) fn corner_text(&mut self, parts: [(&[u8], &[u8]); 3]) {
        let mut written = Vec::new();
        for (gap, tok) in parts {
            written.extend_from_slice(gap);
            written.extend_from_slice(tok);
        }
        self.corner(CORNER_TEXT, &written);
    }
}

/// What a corner marker writes for vertex `v`: its three coordinates as binary32
/// little-endian ([`CORNER_F32_LE`]), or as text each after one space ([`CORNER_TEXT`]).
fn write_corner(marker: u8, mesh: &Mesh, v: usize, q: &Quantization, out: &mut Vec<u8>) {
    let mut text = String::new();
    for k in 0..3 {
        if marker == CORNER_TEXT {
            text.clear();
            text.push(' ');
            format_coord(mesh, v, k, q, &mut text);
            out.extend_from_slice(text.as_bytes());
        } else {
            out.extend_from_slice(&value_f32(mesh, v, k, q).to_le_bytes());
        }
    }
}

/// A builder for a template of a file of about `len` bytes, that makes attributes
/// (SPEC.md 11.3) if `attributes`.
pub(super) fn builder<'m>(
    mesh: &'m Mesh,
    q: &'m Quantization,
    len: usize,
    attributes: bool,
) -> Builder<'m> {
    let mut b = Builder::new(mesh, q, len / 2);
    b.attributes = attributes;
    b
}

/// The template a walk built and its channels, if they expand back to `bytes`.
pub(super) fn checked(b: Builder<'_>, bytes: &[u8]) -> Option<(Vec<u8>, Channels)> {
    let (mesh, q) = (b.mesh, b.q);
    let (t, mut ch) = (b.out, b.channels);
    // Channels the walk never used are not carried.
    while ch
        .indices
        .channels
        .last()
        .is_some_and(|c| c.values.is_empty())
    {
        ch.indices.channels.pop();
    }
    // Compared as it is written, not made whole beside the file (a large file's memory).
    let mut same = Same { rest: bytes };
    let n = expand_into(&t, mesh, q, &ch, &mut same).ok()?;
    (n == bytes.len() as u64).then_some((t, ch))
}

/// A writer that takes only the bytes `rest` starts with (each write the next of them);
/// any other byte is an error.
struct Same<'a> {
    rest: &'a [u8],
}

impl std::io::Write for Same<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.rest.strip_prefix(buf) {
            Some(rest) => {
                self.rest = rest;
                Ok(buf.len())
            }
            None => Err(std::io::Error::other("not the file's bytes")),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// How many normal components a template's markers write.
pub(crate) fn normal_markers(t: &[u8]) -> usize {
    let mut n = 0;
    let mut i = 0;
    while i < t.len() {
        match t[i] {
            ESCAPE => i += 2,
            CHANNEL_TEXT => {
                n += (t.get(i + 1) == Some(&NORMAL_MARK)) as usize;
                i += match t.get(i + 1) {
                    Some(&k) if k >= FIRST_ATTRIBUTE => 3,
                    _ => 2,
                };
            }
            _ => i += 1,
        }
    }
    n
}

/// The number `token` is the plain decimal text of (digits, no leading zero), if it
/// fits 32 bits.
fn plain_decimal(token: &[u8]) -> Option<u32> {
    if token.is_empty() || (token.len() > 1 && token[0] == b'0') {
        return None;
    }
    token.iter().try_fold(0u32, |n, &c| {
        c.is_ascii_digit().then_some(())?;
        n.checked_mul(10)?.checked_add((c - b'0') as u32)
    })
}

/// A template that gives `bytes` back whatever the mesh: every byte literal.
pub(crate) fn verbatim(bytes: &[u8], mesh: &Mesh, q: &Quantization) -> Vec<u8> {
    let mut b = Builder::new(mesh, q, bytes.len() + bytes.len() / 16);
    b.literal(bytes);
    b.out
}

/// The file a template stands for, with the decoded `mesh` (in the file's order) and
/// its corner index channels.
/// Bytes [`expand_into`] gathers before it hands them to its writer.
const CHUNK: usize = 1 << 16;

/// The file of template `t` written to `sink` in chunks of about [`CHUNK`] bytes (the
/// file is not held whole); the bytes written. On an error part of the file may have
/// been written.
pub(crate) fn expand_into<W: std::io::Write>(
    t: &[u8],
    mesh: &Mesh,
    q: &Quantization,
    channels: &Channels,
    mut sink: W,
) -> Result<u64> {
    let indices = &channels.indices;
    let mut normals = channels.normals.iter();
    let mut attr_used = vec![0usize; channels.attributes.len()];
    let bad = |what: &str| Error::corrupt("TMPL", what.to_string());
    let mut out = Vec::with_capacity(2 * CHUNK);
    let mut written = 0u64;
    let (mut coord, mut corner) = (0usize, 0usize);
    let mut used = [0usize; MAX_CHANNELS];
    // Integers written as text (corner indices), without an allocation each.
    let mut digits = itoa::Buffer::new();
    let mut text = String::new();
    let mut i = 0;
    let next_coord = |coord: &mut usize| {
        let c = *coord;
        *coord += 1;
        (c / 3 < mesh.vertex_count()).then_some((c / 3, c % 3))
    };
    let next_corner = |corner: &mut usize| {
        let c = *corner;
        *corner += 1;
        mesh.faces.get(c).copied()
    };
    while i < t.len() {
        if out.len() >= CHUNK {
            sink.write_all(&out)?;
            written += out.len() as u64;
            out.clear();
        }
        let b = t[i];
        i += 1;
        match b {
            COORD_TEXT => {
                let (v, k) =
                    next_coord(&mut coord).ok_or_else(|| bad("more coordinates than vertices"))?;
                text.clear();
                format_coord(mesh, v, k, q, &mut text);
                out.extend_from_slice(text.as_bytes());
            }
            COORD_EXP => {
                let (v, k) =
                    next_coord(&mut coord).ok_or_else(|| bad("more coordinates than vertices"))?;
                text.clear();
                exp_text_at(&mesh.floats, v, k, q, &mut text)
                    .ok_or_else(|| bad("a coordinate in exponent form without float bits"))?;
                out.extend_from_slice(text.as_bytes());
            }
            COORD_F32_LE | COORD_F32_BE | COORD_F64_LE | COORD_F64_BE => {
                let (v, k) =
                    next_coord(&mut coord).ok_or_else(|| bad("more coordinates than vertices"))?;
                match b {
                    COORD_F32_LE => out.extend_from_slice(&value_f32(mesh, v, k, q).to_le_bytes()),
                    COORD_F32_BE => out.extend_from_slice(&value_f32(mesh, v, k, q).to_be_bytes()),
                    COORD_F64_LE => out.extend_from_slice(&value_f64(mesh, v, k, q).to_le_bytes()),
                    _ => out.extend_from_slice(&value_f64(mesh, v, k, q).to_be_bytes()),
                }
            }
            INDEX_TEXT_1 | INDEX_TEXT_0 | INDEX_32_LE | INDEX_32_BE => {
                let v =
                    next_corner(&mut corner).ok_or_else(|| bad("more corners than faces have"))?;
                match b {
                    INDEX_TEXT_1 => out.extend_from_slice(digits.format(v as u64 + 1).as_bytes()),
                    INDEX_TEXT_0 => out.extend_from_slice(digits.format(v).as_bytes()),
                    INDEX_32_LE => out.extend_from_slice(&v.to_le_bytes()),
                    _ => out.extend_from_slice(&v.to_be_bytes()),
                }
            }
            CORNER_F32_LE | CORNER_TEXT => {
                let v =
                    next_corner(&mut corner).ok_or_else(|| bad("more corners than faces have"))?;
                write_corner(b, mesh, v as usize, q, &mut out);
            }
            SKIP_COORD => {
                next_coord(&mut coord).ok_or_else(|| bad("more coordinates than vertices"))?;
            }
            SKIP_INDEX => {
                next_corner(&mut corner).ok_or_else(|| bad("more corners than faces have"))?;
            }
            ESCAPE => {
                out.push(*t.get(i).ok_or_else(|| bad("ends inside an escape"))?);
                i += 1;
            }
            CHANNEL_TEXT if t.get(i) == Some(&NORMAL_MARK) => {
                i += 1;
                let c = normals
                    .next()
                    .ok_or_else(|| bad("more normal components than NRML carries"))?;
                out.extend_from_slice(c.text().as_bytes());
            }
            CHANNEL_TEXT if t.get(i).is_some_and(|&k| k >= FIRST_ATTRIBUTE) => {
                let marker = (t[i] - FIRST_ATTRIBUTE, t.get(i + 1).copied());
                i += 2;
                attribute_marker(marker, channels, corner, &mut attr_used, &mut out)?;
            }
            CHANNEL_TEXT => {
                let k = *t
                    .get(i)
                    .ok_or_else(|| bad("ends inside a channel marker"))?
                    as usize;
                i += 1;
                let a = indices
                    .channels
                    .get(k)
                    .and_then(|c| c.values.get(used[k]))
                    .ok_or_else(|| bad("more channel values than CIDX carries"))?;
                used[k] += 1;
                out.extend_from_slice(a.to_string().as_bytes());
            }
            _ => out.push(b),
        }
    }
    if indices
        .channels
        .iter()
        .zip(used)
        .any(|(c, u)| c.values.len() != u)
        || normals.next().is_some()
        || channels
            .attributes
            .iter()
            .zip(&attr_used)
            .any(|(a, &u)| a.mesh.vertex_count() * a.width as usize != u)
    {
        return Err(bad(
            "CIDX, NRML or ATTR carries values the template does not write",
        ));
    }
    sink.write_all(&out)?;
    sink.flush()?;
    Ok(written + out.len() as u64)
}

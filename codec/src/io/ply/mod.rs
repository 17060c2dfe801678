//! PLY: ASCII, binary little-endian and big-endian; `vertex` (x, y, z) and `face`
//! (`vertex_indices`) elements. Their other properties are attribute channels (per
//! vertex, per face, per corner; lists as list channels), as are header comments and
//! other elements' properties (per file).

use std::collections::{BTreeSet, HashMap};
use std::io::Write;

use super::{
    push_int, value_f32, value_f64, write_counted_text, FileLines, Format, RawAttribute, RawMesh,
};

mod walk;
use crate::error::{Error, Result};
use crate::mesh::{Attribute, Domain, Mesh, ValueType};
use crate::quant::{Decimal, Quantization, RawCoords, TextCoords};
pub(super) use walk::template;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn value_type(self) -> ValueType {
        match self {
            Scalar::I8 => ValueType::I8,
            Scalar::U8 => ValueType::U8,
            Scalar::I16 => ValueType::I16,
            Scalar::U16 => ValueType::U16,
            Scalar::I32 => ValueType::I32,
            Scalar::U32 => ValueType::U32,
            Scalar::F32 => ValueType::F32,
            Scalar::F64 => ValueType::F64,
        }
    }

    /// Zero of this type, as [`Body::num`] reads one in a binary body.
    fn zero(self) -> Num {
        match self {
            Scalar::F32 => Num::F32(0.0),
            Scalar::F64 => Num::F64(0.0),
            _ => Num::Int(0),
        }
    }

    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// An element's runs of up to three consecutive scalar properties of one type (besides
/// x, y, z with `skip_axes`): (first property, length, type). Each is an attribute
/// channel (SPEC.md 11.3, 11.4).
fn runs(props: &[Prop], skip_axes: bool) -> Vec<(usize, usize, Scalar)> {
    let mut runs: Vec<(usize, usize, Scalar)> = Vec::new();
    for (i, p) in props.iter().enumerate() {
        let Prop::Scalar(name, ty) = p else { continue };
        if skip_axes && ["x", "y", "z"].contains(&name.as_str()) {
            continue;
        }
        match runs.last_mut() {
            Some((first, len, t)) if *t == *ty && *first + *len == i && *len < 3 => *len += 1,
            _ => runs.push((i, 1, *ty)),
        }
    }
    runs
}

/// The name of the run of `len` properties from `first`: theirs, space-separated.
fn run_name(props: &[Prop], first: usize, len: usize) -> String {
    props[first..first + len]
        .iter()
        .map(|p| match p {
            Prop::Scalar(n, _) | Prop::List(n, _, _) => n.as_str(),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The name of the per-file channel of a PLY's `comment` and `obj_info` header lines,
/// which its writer puts after the format line.
pub(crate) const HEADER: &str = "header";

/// The name of the per-file channel of properties `props` (space-separated) of an
/// element `element` other than vertex and face: `element/props`.
fn extra_channel(element: &str, props: &str) -> String {
    format!("{element}/{props}")
}

/// The attribute channels of a vertex or face element as they are read: per run of
/// properties ([`runs`]), its values as text (ASCII) or numbers.
struct Columns<'a> {
    runs: Vec<(usize, usize, Scalar)>,
    /// Per property, its run and place in it.
    place: Vec<Option<(usize, usize)>>,
    tokens: Vec<Vec<[&'a str; 3]>>,
    nums: Vec<Vec<[Num; 3]>>,
}

impl<'a> Columns<'a> {
    fn new(el: &Element, is_vertex: bool) -> Self {
        let runs = runs(&el.props, is_vertex);
        let mut place = vec![None; el.props.len()];
        for (r, &(first, len, _)) in runs.iter().enumerate() {
            for k in 0..len {
                place[first + k] = Some((r, k));
            }
        }
        let n = runs.len();
        Columns {
            runs,
            place,
            tokens: vec![Vec::new(); n],
            nums: vec![Vec::new(); n],
        }
    }

    /// Room for the next record's values (those past a run's length are 0).
    fn next_record(&mut self, mode: Mode) {
        for (r, &(_, _, ty)) in self.runs.iter().enumerate() {
            match mode {
                Mode::Ascii => self.tokens[r].push(["0"; 3]),
                _ => self.nums[r].push([ty.zero(); 3]),
            }
        }
    }

    /// Reads property `i`'s value into the current record, if it is one of the runs'.
    fn read(&mut self, i: usize, ty: Scalar, body: &mut Body<'a>) -> Result<bool> {
        let Some((r, k)) = self.place.get(i).copied().flatten() else {
            return Ok(false);
        };
        match body.mode {
            Mode::Ascii => {
                if let Some(row) = self.tokens[r].last_mut() {
                    row[k] = body.token()?;
                }
            }
            _ => {
                let v = body.num(ty)?;
                if let Some(row) = self.nums[r].last_mut() {
                    row[k] = v;
                }
            }
        }
        Ok(true)
    }

    /// The channels, named by their properties.
    fn finish(
        self,
        el: &Element,
        domain: Domain,
        mode: Mode,
        out: &mut Vec<RawAttribute>,
        dropped: &mut BTreeSet<String>,
    ) -> Result<()> {
        for (r, &(first, len, ty)) in self.runs.iter().enumerate() {
            let mut name = run_name(&el.props, first, len);
            if domain == Domain::File {
                name = extra_channel(&el.name, &name);
            }
            let values = match mode {
                Mode::Ascii => {
                    let mut t = TextCoords::default();
                    // Values that are no numbers are no channel (the file's bytes keep
                    // them).
                    if let Some(e) = self.tokens[r].iter().find_map(|row| t.push(*row).err()) {
                        dropped.insert(format!("{} property '{name}' ({e})", el.name));
                        continue;
                    }
                    t.finish().0
                }
                _ => to_coords(&self.nums[r])?,
            };
            out.push(RawAttribute {
                name,
                domain,
                value_type: ty.value_type(),
                width: len as u8,
                values,
                indices: Vec::new(),
                labels: Vec::new(),
            });
        }
        Ok(())
    }
}

/// An element's lists (a face's besides its vertex indices: texture coordinates per
/// corner, as MeshLab writes `texcoord`) as they are read: per list property, its
/// lengths and values, as text (ASCII) or numbers.
#[derive(Default)]
struct Lists<'a> {
    read: Vec<List<'a>>,
}

/// One list property as read.
struct List<'a> {
    /// The property.
    prop: usize,
    /// Its items' type.
    ty: Scalar,
    /// Per record, its length.
    lens: Vec<u64>,
    /// The items (binary).
    nums: Vec<Num>,
    /// The items' text (ASCII).
    tokens: Vec<&'a str>,
}

impl List<'_> {
    /// The list channel of this property of element `el` (SPEC.md 11.4): its items in
    /// turn, one value each, and per record its length; `None`, noted as dropped, when
    /// ASCII items are no numbers.
    fn channel(
        self,
        name: String,
        domain: Domain,
        el: &Element,
        dropped: &mut BTreeSet<String>,
    ) -> Result<Option<RawAttribute>> {
        let values = match self.tokens.is_empty() {
            true => {
                let rows: Vec<[Num; 3]> = self
                    .nums
                    .iter()
                    .map(|&n| [n, self.ty.zero(), self.ty.zero()])
                    .collect();
                to_coords(&rows)?
            }
            false => {
                let mut t = TextCoords::default();
                if let Some(e) = self
                    .tokens
                    .iter()
                    .find_map(|&x| t.push([x, "0", "0"]).err())
                {
                    dropped.insert(format!("{} property '{name}' ({e})", el.name));
                    return Ok(None);
                }
                t.finish().0
            }
        };
        let indices = self
            .lens
            .iter()
            .map(|&n| u32::try_from(n).map_err(|_| err(format!("a '{name}' list of {n} items"))))
            .collect::<Result<_>>()?;
        Ok(Some(RawAttribute {
            name,
            domain,
            value_type: self.ty.value_type(),
            width: 1,
            values,
            indices,
            labels: Vec::new(),
        }))
    }
}

impl<'a> Lists<'a> {
    /// Every list as a list channel (a vertex's, or per file another element's,
    /// [`extra_channel`]).
    fn finish_lists(
        self,
        el: &Element,
        domain: Domain,
        out: &mut Vec<RawAttribute>,
        dropped: &mut BTreeSet<String>,
    ) -> Result<()> {
        for list in self.read {
            let Prop::List(name, _, _) = &el.props[list.prop] else {
                continue;
            };
            let name = match domain {
                Domain::File => extra_channel(&el.name, name),
                _ => name.clone(),
            };
            out.extend(list.channel(name, domain, el, dropped)?);
        }
        Ok(())
    }

    /// Reads property `i`'s list of the current face.
    fn read(&mut self, i: usize, ty: Scalar, body: &mut Body<'a>, cty: Scalar) -> Result<()> {
        let n = list_len(body, cty, ty)?;
        let at = match self.read.iter().position(|r| r.prop == i) {
            Some(at) => at,
            None => {
                self.read.push(List {
                    prop: i,
                    ty,
                    lens: Vec::new(),
                    nums: Vec::new(),
                    tokens: Vec::new(),
                });
                self.read.len() - 1
            }
        };
        let r = &mut self.read[at];
        r.lens.push(n);
        for _ in 0..n {
            match body.mode {
                Mode::Ascii => r.tokens.push(body.token()?),
                _ => r.nums.push(body.num(ty)?),
            }
        }
        Ok(())
    }

    /// The lists that hold the same number (1 to 3) of values for each corner of every
    /// face, as corner channels named by their properties (equal entries once); then
    /// the others, as list channels per face.
    fn finish(
        self,
        el: &Element,
        topo: &Mesh,
        out: &mut Vec<RawAttribute>,
        dropped: &mut BTreeSet<String>,
    ) -> Result<()> {
        let mut lists = Vec::new();
        for List {
            prop: i,
            ty: ity,
            lens,
            nums,
            tokens,
        } in self.read
        {
            let Prop::List(name, _, _) = &el.props[i] else {
                continue;
            };
            let degrees = topo.face_starts.windows(2).map(|w| (w[1] - w[0]) as u64);
            let width = match (lens.first(), degrees.clone().next()) {
                (Some(&n), Some(d)) if n % d == 0 && (1..=3).contains(&(n / d)) => n / d,
                _ => 0,
            };
            if width == 0
                || lens.len() != topo.face_count()
                || degrees.zip(&lens).any(|(d, &n)| n != width * d)
            {
                // Not 1 to 3 values for each corner: a list per face.
                let list = List {
                    prop: i,
                    ty: ity,
                    lens,
                    nums,
                    tokens,
                };
                lists.extend(list.channel(name.clone(), Domain::Face, el, dropped)?);
                continue;
            }
            let w = width as usize;
            // Equal entries (the same text, the same bits) are one entry of the table.
            let mut seen: HashMap<Vec<u64>, u32> = HashMap::new();
            let mut indices = Vec::with_capacity(lens.len());
            let (mut rows, mut texts): (Vec<[Num; 3]>, Vec<[&str; 3]>) = (Vec::new(), Vec::new());
            let corners = nums.len().max(tokens.len()) / w;
            for c in 0..corners {
                let key: Vec<u64> = match tokens.is_empty() {
                    true => nums[c * w..c * w + w].iter().map(Num::bits).collect(),
                    false => tokens[c * w..c * w + w]
                        .iter()
                        .flat_map(|t| t.bytes().map(u64::from).chain([u64::MAX]))
                        .collect(),
                };
                let next = seen.len() as u32;
                let e = *seen.entry(key).or_insert(next);
                if e == next {
                    match tokens.is_empty() {
                        true => rows.push(std::array::from_fn(|k| {
                            nums.get(c * w + k)
                                .filter(|_| k < w)
                                .copied()
                                .unwrap_or(ity.zero())
                        })),
                        false => texts.push(std::array::from_fn(|k| {
                            if k < w {
                                tokens[c * w + k]
                            } else {
                                "0"
                            }
                        })),
                    }
                }
                indices.push(e);
            }
            let values = match tokens.is_empty() {
                true => to_coords(&rows)?,
                false => {
                    let mut t = TextCoords::default();
                    if let Some(e) = texts.iter().find_map(|row| t.push(*row).err()) {
                        dropped.insert(format!("{} property '{name}' ({e})", el.name));
                        continue;
                    }
                    t.finish().0
                }
            };
            out.push(RawAttribute {
                name: name.clone(),
                domain: Domain::Corner,
                value_type: ity.value_type(),
                width: width as u8,
                values,
                indices,
                labels: Vec::new(),
            });
        }
        out.extend(lists);
        Ok(())
    }
}

#[derive(Debug, Clone)]
enum Prop {
    Scalar(String, Scalar),
    List(String, Scalar, Scalar),
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Prop>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Ascii,
    Le,
    Be,
}

#[derive(Debug, Clone, Copy)]
enum Num {
    Int(i64),
    F32(f32),
    F64(f64),
    Dec(Decimal),
}

impl Num {
    /// What tells two values apart: their kind and bits.
    fn bits(&self) -> u64 {
        match *self {
            Num::Int(i) => i as u64,
            Num::F32(f) => f.to_bits() as u64,
            Num::F64(f) => f.to_bits(),
            Num::Dec(d) => d.mantissa as u64 ^ (d.decimals as u64) << 56,
        }
    }
}

fn err(what: impl std::fmt::Display) -> Error {
    Error::MeshFile(format!("PLY: {what}"))
}

/// Bytes up to and with the first line break of `rest` (all of it without one): what
/// an ASCII record's line has left after its values.
fn line_len(rest: &[u8]) -> usize {
    super::lines_with_ends(rest).next().map_or(0, <[u8]>::len)
}

struct Body<'a> {
    data: &'a [u8],
    pos: usize,
    mode: Mode,
}

impl<'a> Body<'a> {
    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    fn token(&mut self) -> Result<&'a str> {
        while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if start == self.pos {
            return Err(err("file ends before all elements were read"));
        }
        std::str::from_utf8(&self.data[start..self.pos]).map_err(|_| err("body is not ASCII text"))
    }

    /// In an ASCII body, after a record: goes past the end of its line (a record is a
    /// line; some writers put more values on it than the header names). Whether there
    /// were such values.
    fn end_line(&mut self) -> bool {
        let rest = &self.data[self.pos..];
        let end = line_len(rest);
        let extra = !rest[..end].trim_ascii().is_empty();
        self.pos += end;
        extra
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N]> {
        if self.remaining() < N {
            return Err(err("file ends before all elements were read"));
        }
        let mut b = [0u8; N];
        b.copy_from_slice(&self.data[self.pos..self.pos + N]);
        self.pos += N;
        if self.mode == Mode::Be {
            b.reverse();
        }
        Ok(b)
    }

    fn num(&mut self, ty: Scalar) -> Result<Num> {
        if self.mode == Mode::Ascii {
            let t = self.token()?;
            return if ty.is_float() {
                Decimal::parse(t).map(Num::Dec).map_err(err)
            } else {
                t.parse::<i64>()
                    .map(Num::Int)
                    .map_err(|_| err(format!("'{t}' is not an integer")))
            };
        }
        Ok(match ty {
            Scalar::I8 => Num::Int(i8::from_le_bytes(self.take()?) as i64),
            Scalar::U8 => Num::Int(u8::from_le_bytes(self.take()?) as i64),
            Scalar::I16 => Num::Int(i16::from_le_bytes(self.take()?) as i64),
            Scalar::U16 => Num::Int(u16::from_le_bytes(self.take()?) as i64),
            Scalar::I32 => Num::Int(i32::from_le_bytes(self.take()?) as i64),
            Scalar::U32 => Num::Int(u32::from_le_bytes(self.take()?) as i64),
            Scalar::F32 => Num::F32(f32::from_le_bytes(self.take()?)),
            Scalar::F64 => Num::F64(f64::from_le_bytes(self.take()?)),
        })
    }

    /// Goes past a value that is not coded: in an ASCII body its text, whatever its
    /// digits (a number past exact mode's 18 decimals is still a file to keep).
    fn skip(&mut self, ty: Scalar) -> Result<()> {
        match self.mode {
            Mode::Ascii => self.token().map(|_| ()),
            _ => self.num(ty).map(|_| ()),
        }
    }

    fn int(&mut self, ty: Scalar, what: &str) -> Result<i64> {
        match self.num(ty)? {
            Num::Int(i) => Ok(i),
            Num::Dec(d) if d.decimals == 0 => Ok(d.mantissa),
            Num::F32(x) if x.fract() == 0.0 && x.abs() < 1e9 => Ok(x as i64),
            Num::F64(x) if x.fract() == 0.0 && x.abs() < 1e18 => Ok(x as i64),
            _ => Err(err(format!("{what} is not an integer"))),
        }
    }
}

/// A PLY header: its format, its elements, where its body starts, and its `comment`
/// and `obj_info` lines.
type Header = (Mode, Vec<Element>, usize, Vec<String>);

fn parse_header(bytes: &[u8]) -> Result<Header> {
    let end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .ok_or_else(|| err("no end_header line"))?;
    let mut body = end + 10;
    // The header ends with the line break after end_header (LF or CR LF).
    if bytes.get(body) == Some(&b'\r') {
        body += 1;
    }
    if bytes.get(body) == Some(&b'\n') {
        body += 1;
    } else if body < bytes.len() {
        return Err(err("end_header is not followed by a line break"));
    }
    let head = std::str::from_utf8(&bytes[..end]).map_err(|_| err("header is not text"))?;
    let mut mode = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut comments = Vec::new();
    for (n, line) in head.lines().enumerate() {
        let mut t = line.split_ascii_whitespace();
        let Some(kw) = t.next() else { continue };
        let bad = |what: &str| err(format!("header line {}: {what}", n + 1));
        match kw {
            "ply" if n == 0 => {}
            "format" => {
                mode = Some(match t.next() {
                    Some("ascii") => Mode::Ascii,
                    Some("binary_little_endian") => Mode::Le,
                    Some("binary_big_endian") => Mode::Be,
                    _ => return Err(bad("unknown format")),
                });
            }
            "comment" | "obj_info" => comments.push(line.to_string()),
            "element" => {
                let name = t.next().ok_or_else(|| bad("element without a name"))?;
                let count = t
                    .next()
                    .and_then(|c| c.parse::<u64>().ok())
                    .ok_or_else(|| bad("element without a count"))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            "property" => {
                let el = elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?;
                let ty = t.next().ok_or_else(|| bad("property without a type"))?;
                let prop = if ty == "list" {
                    let c = t
                        .next()
                        .and_then(Scalar::parse)
                        .ok_or_else(|| bad("bad list count type"))?;
                    let i = t
                        .next()
                        .and_then(Scalar::parse)
                        .ok_or_else(|| bad("bad list item type"))?;
                    if c.is_float() {
                        return Err(bad("list count type must be an integer"));
                    }
                    let name = t.next().ok_or_else(|| bad("property without a name"))?;
                    Prop::List(name.to_string(), c, i)
                } else {
                    let s = Scalar::parse(ty).ok_or_else(|| bad("unknown property type"))?;
                    let name = t.next().ok_or_else(|| bad("property without a name"))?;
                    Prop::Scalar(name.to_string(), s)
                };
                el.props.push(prop);
            }
            _ if n == 0 => return Err(err("file does not start with 'ply'")),
            other => return Err(bad(&format!("unknown keyword '{other}'"))),
        }
    }
    let mode = mode.ok_or_else(|| err("no format line"))?;
    Ok((mode, elements, body, comments))
}

/// Checks an element's header against the file: its records fit in the `remaining`
/// bytes, a vertex element (the only one, unless `have_vertices`) has x, y and z, a face
/// element a vertex index list. Notes what subwave does not keep as dropped: another
/// element unless it is `extra` (kept as per-file channels, [`extra_channel`]).
fn check_element(
    el: &Element,
    mode: Mode,
    remaining: usize,
    have_vertices: bool,
    extra: bool,
    dropped: &mut BTreeSet<String>,
) -> Result<()> {
    // Every record needs at least this many bytes; refuse counts the file cannot hold
    // before allocating for them.
    let min_record: usize = el
        .props
        .iter()
        .map(|p| match (mode, p) {
            (Mode::Ascii, _) => 2,
            (_, Prop::Scalar(_, s)) => s.size(),
            (_, Prop::List(_, c, _)) => c.size(),
        })
        .sum::<usize>()
        .max(1);
    if el.count.saturating_mul(min_record as u64) > remaining as u64 {
        return Err(err(format!(
            "element '{}' declares {} records, more than the {} bytes left can hold",
            el.name, el.count, remaining
        )));
    }
    let is_vertex = el.name == "vertex";
    let is_face = el.name == "face";
    if is_vertex {
        if have_vertices {
            return Err(err("two vertex elements"));
        }
        for a in ["x", "y", "z"] {
            if !el
                .props
                .iter()
                .any(|p| matches!(p, Prop::Scalar(n, _) if n == a))
            {
                return Err(err(format!("vertex element has no '{a}' property")));
            }
        }
    } else if is_face {
        if !el.props.iter().any(
            |p| matches!(p, Prop::List(n, _, _) if n == "vertex_indices" || n == "vertex_index"),
        ) {
            return Err(err("face element has no vertex_indices list"));
        }
    } else if !extra {
        dropped.insert(format!("'{}' elements", el.name));
        return Ok(());
    }
    // Its properties are attribute channels, per vertex, per face or per file; lists
    // list channels (a face's per corner channels when they hold as many values for
    // each corner, decided once read, [`Lists::finish`]).
    Ok(())
}

pub(crate) fn read(bytes: &[u8]) -> Result<RawMesh> {
    let (mode, elements, body_start, comments) = parse_header(bytes)?;
    let mut body = Body {
        data: bytes,
        pos: body_start,
        mode,
    };
    let mut dropped = BTreeSet::new();
    let mut nums: Vec<[Num; 3]> = Vec::new();
    let mut text = TextCoords::default();
    let mut have_vertices = false;
    let mut topo = Mesh::new();
    let mut face = Vec::new();
    let mut attributes = Vec::new();
    let mut extras = BTreeSet::new();
    for el in &elements {
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        // Another element's scalar properties are per-file channels, once per name.
        let extra = !is_vertex && !is_face && !el.name.contains('/') && extras.insert(&el.name);
        check_element(
            el,
            mode,
            body.remaining(),
            have_vertices,
            extra,
            &mut dropped,
        )?;
        let mut columns = Columns::new(el, is_vertex);
        let mut lists = Lists::default();
        let channels = (is_vertex || is_face || extra) && !columns.runs.is_empty();
        let axis_of = |name: &str| ["x", "y", "z"].iter().position(|a| *a == name);
        if is_vertex {
            have_vertices = true;
            if mode != Mode::Ascii {
                nums.reserve(el.count as usize);
            }
        }
        for _ in 0..el.count {
            let mut v = [Num::Int(0); 3];
            let mut toks = [""; 3];
            let mut took_list = false;
            if channels {
                columns.next_record(mode);
            }
            for (i, p) in el.props.iter().enumerate() {
                match p {
                    Prop::Scalar(_, ty) if channels && columns.read(i, *ty, &mut body)? => {}
                    Prop::Scalar(name, ty) => {
                        match (is_vertex && mode == Mode::Ascii, axis_of(name)) {
                            (true, Some(a)) => toks[a] = body.token()?,
                            (false, Some(a)) if is_vertex => v[a] = body.num(*ty)?,
                            _ => body.skip(*ty)?,
                        }
                    }
                    Prop::List(name, cty, ity) => {
                        let want = is_face
                            && !took_list
                            && (name == "vertex_indices" || name == "vertex_index");
                        if (is_face || is_vertex || extra) && !want {
                            lists.read(i, *ity, &mut body, *cty)?;
                            continue;
                        }
                        read_list(&mut body, *cty, *ity, want.then_some(&mut face))?;
                        if want {
                            took_list = true;
                            if face.len() < 3 {
                                return Err(Error::InvalidMesh(format!(
                                    "PLY face {} has {} corners; faces need at least 3",
                                    topo.face_count() + 1,
                                    face.len()
                                )));
                            }
                            topo.push_face(&face);
                        }
                    }
                }
            }
            if mode == Mode::Ascii && body.end_line() {
                dropped.insert(format!("values past the end of a '{}' record", el.name));
            }
            if is_vertex {
                if mode == Mode::Ascii {
                    text.push(toks).map_err(err)?;
                } else {
                    nums.push(v);
                }
            }
        }
        if channels {
            let domain = match (is_vertex, is_face) {
                (true, _) => Domain::Vertex,
                (_, true) => Domain::Face,
                _ => Domain::File,
            };
            columns.finish(el, domain, mode, &mut attributes, &mut dropped)?;
        }
        if is_face {
            lists.finish(el, &topo, &mut attributes, &mut dropped)?;
        } else if is_vertex || extra {
            let domain = if is_vertex {
                Domain::Vertex
            } else {
                Domain::File
            };
            lists.finish_lists(el, domain, &mut attributes, &mut dropped)?;
        }
    }
    let mut header = FileLines::default();
    comments.iter().for_each(|c| header.push(c));
    attributes.extend(header.finish(HEADER));
    // A file without a vertex element is an empty mesh (its header says so); a face
    // element then refers to vertices that are not there, which check_faces reports.
    let (coords, inexact) = if mode == Mode::Ascii {
        text.finish()
    } else {
        (to_coords(&nums)?, None)
    };
    Ok(RawMesh {
        coords,
        inexact,
        topology: topo,
        format: match mode {
            Mode::Ascii => Format::PlyAscii,
            Mode::Le => Format::PlyBinary,
            Mode::Be => Format::PlyBinaryBigEndian,
        },
        dropped,
        attributes,
    })
}

/// A list's length, read, that the bytes left can hold (two per item in ASCII).
fn list_len(body: &mut Body<'_>, cty: Scalar, ity: Scalar) -> Result<u64> {
    let n = body.int(cty, "list count")?;
    let item = if body.mode == Mode::Ascii {
        2
    } else {
        ity.size() as u64
    };
    if n < 0 || (n as u64).saturating_mul(item) > body.remaining() as u64 {
        return Err(err(format!("list of {n} items does not fit in the file")));
    }
    Ok(n as u64)
}

/// One list property's items; with `face`, kept as vertex indices.
fn read_list(
    body: &mut Body<'_>,
    cty: Scalar,
    ity: Scalar,
    mut face: Option<&mut Vec<u32>>,
) -> Result<()> {
    let n = list_len(body, cty, ity)?;
    if let Some(f) = face.as_deref_mut() {
        f.clear();
    }
    for _ in 0..n {
        let Some(f) = face.as_deref_mut() else {
            // Another list (texture coordinates per corner, say): its items of any type.
            body.num(ity)?;
            continue;
        };
        let i = body.int(ity, "vertex index")?;
        if !(0..u32::MAX as i64).contains(&i) {
            return Err(err(format!("vertex index {i} is out of range")));
        }
        f.push(i as u32);
    }
    Ok(())
}

fn to_coords(nums: &[[Num; 3]]) -> Result<RawCoords> {
    let (mut any_f32, mut any_f64, mut any_int) = (false, false, false);
    for v in nums.iter().take(1) {
        for x in v {
            match x {
                Num::F32(_) => any_f32 = true,
                Num::F64(_) => any_f64 = true,
                Num::Int(_) => any_int = true,
                Num::Dec(_) => {}
            }
        }
    }
    let dec = |x: &Num| match *x {
        Num::Dec(d) => d,
        Num::Int(i) => Decimal::integer(i),
        _ => unreachable!("types are uniform per property"),
    };
    let f64_of = |x: &Num| match *x {
        Num::F32(f) => f as f64,
        Num::F64(f) => f,
        Num::Int(i) => i as f64,
        Num::Dec(d) => d.to_f64(),
    };
    Ok(if any_f64 || (any_f32 && any_int) {
        RawCoords::F64(nums.iter().map(|v| v.map(|x| f64_of(&x))).collect())
    } else if any_f32 {
        RawCoords::F32(
            nums.iter()
                .map(|v| {
                    v.map(|x| {
                        if let Num::F32(f) = x {
                            f
                        } else {
                            f64_of(&x) as f32
                        }
                    })
                })
                .collect(),
        )
    } else {
        RawCoords::Decimal(nums.iter().map(|v| v.map(|x| dec(&x))).collect())
    })
}

/// A channel's property names in a PLY header: its name's words when there are as
/// many as values per entry, else the name (spaces as `_`) with `_0`, `_1`, ... after it
/// for more than one value.
fn property_names(a: &Attribute) -> Vec<String> {
    let words: Vec<&str> = a.name.split_ascii_whitespace().collect();
    if words.len() == a.width as usize {
        return words.iter().map(|w| w.to_string()).collect();
    }
    let base = a.name.replace(|c: char| c.is_ascii_whitespace(), "_");
    match a.width {
        1 => vec![base],
        w => (0..w).map(|k| format!("{base}_{k}")).collect(),
    }
}

/// A channel's PLY type: its own, or for text values the float type that holds them.
fn property_type(a: &Attribute) -> &'static str {
    match a.value_type {
        ValueType::Text if !a.quantization.prefers_f32() => "double",
        t => t.ply_name(),
    }
}

/// Appends entry `e`'s values of channel `a`: binary little-endian in its type, or as
/// text (each after a space).
fn put_values(a: &Attribute, e: usize, binary: bool, buf: &mut Vec<u8>, text: &mut String) {
    if !binary {
        return a.push_text(e, text);
    }
    let (p, f, q) = (&a.values, &a.floats, &a.quantization);
    for k in 0..a.width as usize {
        let n = p[e][k];
        match (a.value_type, property_type(a)) {
            (ValueType::I8, _) => buf.push(n as i8 as u8),
            (ValueType::U8, _) => buf.push(n as u8),
            (ValueType::I16 | ValueType::U16, _) => {
                buf.extend_from_slice(&(n as u16).to_le_bytes())
            }
            (ValueType::I32 | ValueType::U32, _) => {
                buf.extend_from_slice(&(n as u32).to_le_bytes())
            }
            (_, "float") => buf.extend_from_slice(&super::f32_at(p, f, e, k, q).to_le_bytes()),
            _ => buf.extend_from_slice(&super::f64_at(p, f, e, k, q).to_le_bytes()),
        }
    }
}

/// A channel as the PLY writer writes it: a run of scalar properties, or a list
/// property whose lengths are written as `count` (its records' lists, in turn).
struct Column<'a> {
    a: &'a Attribute,
    lists: Vec<std::ops::Range<usize>>,
    count: &'static str,
}

impl<'a> Column<'a> {
    fn new(a: &'a Attribute) -> Self {
        let lists: Vec<_> = a.list().collect();
        let count = match lists.iter().all(|r| r.len() <= 255) {
            true => "uchar",
            false => "uint",
        };
        Column { a, lists, count }
    }

    /// Records: entries, or lists.
    fn records(&self) -> usize {
        match self.a.is_list() {
            true => self.lists.len(),
            false => self.a.entry_count(),
        }
    }

    /// Its header lines.
    fn header<W: Write>(&self, out: &mut W) -> Result<()> {
        let ty = property_type(self.a);
        if self.a.is_list() {
            let name = self.a.name.replace(|c: char| c.is_ascii_whitespace(), "_");
            writeln!(out, "property list {} {ty} {name}", self.count)?;
        } else {
            for n in property_names(self.a) {
                writeln!(out, "property {ty} {n}")?;
            }
        }
        Ok(())
    }

    /// Appends record `r`'s values ([`put_values`]), a list after its length.
    fn put(&self, r: usize, binary: bool, buf: &mut Vec<u8>, text: &mut String) {
        if !self.a.is_list() {
            return put_values(self.a, r, binary, buf, text);
        }
        let items = self.lists[r].clone();
        let n = items.len();
        match (binary, self.count) {
            (false, _) => {
                text.push(' ');
                push_int(text, n);
            }
            (true, "uchar") => buf.push(n as u8),
            (true, _) => buf.extend_from_slice(&(n as u32).to_le_bytes()),
        }
        for e in items {
            put_values(self.a, e, binary, buf, text);
        }
    }
}

/// Ends a record: an ASCII one's `line` and its line break into `buf`; `buf` out to
/// `out` once it is large.
fn end_record<W: Write>(binary: bool, line: &str, buf: &mut Vec<u8>, out: &mut W) -> Result<()> {
    if !binary {
        buf.extend_from_slice(line.as_bytes());
        buf.push(b'\n');
    }
    if buf.len() > 60_000 {
        out.write_all(buf)?;
        buf.clear();
    }
    Ok(())
}

pub(crate) fn write<W: Write>(
    out: &mut W,
    mesh: &Mesh,
    q: &Quantization,
    binary: bool,
) -> Result<()> {
    let f32_out = binary && q.prefers_f32();
    let cty = if mesh.iter_faces().all(|f| f.len() <= 255) {
        "uchar"
    } else {
        "uint"
    };
    let ity = if mesh.vertex_count() <= i32::MAX as usize {
        "int"
    } else {
        "uint"
    };
    let of = |d: Domain| -> Vec<&Attribute> {
        mesh.attributes
            .iter()
            .filter(|a| a.domain == d && writes(a))
            .collect()
    };
    let columns = |d: Domain| -> Vec<Column<'_>> { of(d).into_iter().map(Column::new).collect() };
    let (vchan, cchan) = (columns(Domain::Vertex), of(Domain::Corner));
    // A face's scalar properties, then its per-corner lists, then its other lists: as
    // the reader makes channels of them.
    let (fchan, flists): (Vec<_>, Vec<_>) = columns(Domain::Face)
        .into_iter()
        .partition(|c| !c.a.is_list());
    let header = mesh
        .attributes
        .iter()
        .find(|a| a.domain == Domain::File && a.name == HEADER && !a.labels.is_empty());
    let extras = extra_elements(mesh);
    // A corner channel is a list per face: its values for each corner in turn.
    let longest = mesh.iter_faces().map(<[u32]>::len).max().unwrap_or(0);
    let ltys: Vec<&str> = cchan
        .iter()
        .map(|a| match longest * a.width as usize <= 255 {
            true => "uchar",
            false => "uint",
        })
        .collect();
    let format = match binary {
        true => "binary_little_endian",
        false => "ascii",
    };
    writeln!(out, "ply\nformat {format} 1.0")?;
    if let Some(a) = header {
        for v in &a.values {
            if let Some(l) = a.label(v[0]) {
                writeln!(out, "{l}")?;
            }
        }
    }
    writeln!(out, "element vertex {}", mesh.vertex_count())?;
    let fty = if f32_out || (!binary && q.prefers_f32()) {
        "float"
    } else {
        "double"
    };
    for a in ["x", "y", "z"] {
        writeln!(out, "property {fty} {a}")?;
    }
    for c in &vchan {
        c.header(out)?;
    }
    write!(
        out,
        "element face {}\nproperty list {cty} {ity} vertex_indices\n",
        mesh.face_count()
    )?;
    for c in &fchan {
        c.header(out)?;
    }
    for (a, lty) in cchan.iter().zip(&ltys) {
        let name = a.name.replace(|c: char| c.is_ascii_whitespace(), "_");
        writeln!(out, "property list {lty} {} {name}", property_type(a))?;
    }
    for c in &flists {
        c.header(out)?;
    }
    let extras: Vec<(&str, Vec<Column<'_>>)> = extras
        .iter()
        .map(|(e, g)| (*e, g.iter().map(Column::new).collect()))
        .collect();
    for (element, group) in &extras {
        writeln!(out, "element {element} {}", group[0].records())?;
        for c in group {
            c.header(out)?;
        }
    }
    writeln!(out, "end_header")?;
    let plain = vchan.is_empty() && fchan.is_empty() && flists.is_empty() && cchan.is_empty();
    if !binary && plain && extras.is_empty() {
        return write_counted_text(out, mesh, q);
    }
    let mut buf = Vec::with_capacity(1 << 16);
    let mut line = String::with_capacity(128);
    for v in 0..mesh.vertex_count() {
        if binary {
            for k in 0..3 {
                if f32_out {
                    buf.extend_from_slice(&value_f32(mesh, v, k, q).to_le_bytes());
                } else {
                    buf.extend_from_slice(&value_f64(mesh, v, k, q).to_le_bytes());
                }
            }
        } else {
            super::coords_line("", mesh, v, q, &mut line);
            line.pop();
        }
        for c in &vchan {
            c.put(v, binary, &mut buf, &mut line);
        }
        end_record(binary, &line, &mut buf, out)?;
    }
    for (f, face) in mesh.iter_faces().enumerate() {
        line.clear();
        if !binary {
            push_int(&mut line, face.len());
            for &i in face {
                line.push(' ');
                push_int(&mut line, i);
            }
        } else if cty == "uchar" {
            buf.push(face.len() as u8);
        } else {
            buf.extend_from_slice(&(face.len() as u32).to_le_bytes());
        }
        if binary {
            for &i in face {
                buf.extend_from_slice(&i.to_le_bytes());
            }
        }
        for c in &fchan {
            c.put(f, binary, &mut buf, &mut line);
        }
        let corners = mesh.face_starts[f] as usize..mesh.face_starts[f + 1] as usize;
        for (a, &lty) in cchan.iter().zip(&ltys) {
            let n = corners.len() * a.width as usize;
            if !binary {
                line.push(' ');
                push_int(&mut line, n);
            } else if lty == "uchar" {
                buf.push(n as u8);
            } else {
                buf.extend_from_slice(&(n as u32).to_le_bytes());
            }
            for c in corners.clone() {
                put_values(a, a.indices[c] as usize, binary, &mut buf, &mut line);
            }
        }
        for c in &flists {
            c.put(f, binary, &mut buf, &mut line);
        }
        end_record(binary, &line, &mut buf, out)?;
    }
    for (_, group) in &extras {
        for e in 0..group[0].records() {
            line.clear();
            for c in group {
                c.put(e, binary, &mut buf, &mut line);
            }
            // Values are written each after a space.
            let record = line.get(1..).unwrap_or("");
            end_record(binary, record, &mut buf, out)?;
        }
    }
    out.write_all(&buf)?;
    Ok(())
}

/// Whether the PLY writer writes channel `a`: every per-vertex, per-face and
/// per-corner channel, the header's lines ([`HEADER`]) and another element's
/// properties ([`extra_channel`]).
pub(crate) fn writes(a: &Attribute) -> bool {
    match a.domain {
        Domain::File => match a.labels.is_empty() {
            true => a.name.split_once('/').is_some_and(|(e, p)| {
                !e.is_empty() && !e.contains(char::is_whitespace) && !p.is_empty()
            }),
            false => a.name == HEADER,
        },
        // A list per face holds a value for every corner.
        Domain::Corner => !a.indices.contains(&crate::mesh::NO_ENTRY),
        _ => true,
    }
}

/// The elements of the per-file channels besides the header's, in their order: the
/// consecutive channels of one element name and entry count ([`extra_channel`]), each
/// named by what follows the `/`.
fn extra_elements(mesh: &Mesh) -> Vec<(&str, Vec<Attribute>)> {
    let mut out: Vec<(&str, Vec<Attribute>)> = Vec::new();
    for a in mesh
        .attributes
        .iter()
        .filter(|a| a.domain == Domain::File && a.labels.is_empty())
    {
        let Some((element, props)) = a.name.split_once('/').filter(|_| writes(a)) else {
            continue;
        };
        let mut a = a.clone();
        a.name = props.to_string();
        let records = |a: &Attribute| match a.is_list() {
            true => a.indices.len(),
            false => a.entry_count(),
        };
        match out.last_mut() {
            Some((e, g)) if *e == element && records(&g[0]) == records(&a) => g.push(a),
            _ => out.push((element, vec![a])),
        }
    }
    out
}

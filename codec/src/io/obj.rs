//! Wavefront OBJ: `v` and `f` statements; `vt`, `vn`, vertex colours, `o`, `g`, `s`,
//! `usemtl`, comments, `mtllib`, `l` and `p` lines as attribute channels; what else
//! the file holds is reported as dropped.

use std::collections::BTreeSet;
use std::io::Write;

use super::template::{Attribute as FileAttribute, Builder, Form};
use super::{coords_line, push_int, syntax, FileLines, Format, RawAttribute, RawMesh};
use crate::error::Result;
use crate::mesh::{Attribute, Domain, Mesh, ValueType, NO_ENTRY};
use crate::quant::{Quantization, TextCoords};
use crate::sections::nrml::Component;

/// The OBJ statements (Wavefront's specification and common extensions) besides those
/// read above that name no vertex: kept as lines of the file (with comments and
/// `mtllib`; [`LINES`]).
const OTHER_KEYWORDS: [&str; 13] = [
    "mg",
    "bevel",
    "c_interp",
    "d_interp",
    "lod",
    "usemap",
    "maplib",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "call",
    "csh",
];

/// Wavefront's free-form geometry statements, which name vertices by their numbers:
/// noted as dropped (the file's own bytes keep them). A line that starts with none of
/// these or the statements above is not OBJ.
const FREE_FORM: [&str; 14] = [
    "cstype", "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv", "sp",
    "end", "con",
];

/// The name of the per-file channel of an OBJ's lines that name nothing the mesh holds
/// (comments, `mtllib`, [`OTHER_KEYWORDS`]), which its writer puts first.
pub(crate) const LINES: &str = "lines";

pub(crate) fn read(bytes: &[u8]) -> Result<RawMesh> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        syntax(
            "OBJ",
            line_of(bytes, e.valid_up_to()),
            "not UTF-8 text: not an OBJ file (subwave reads OBJ, PLY, OFF and STL)",
        )
    })?;
    let mut coords = TextCoords::default();
    let mut topo = Mesh::new();
    let mut dropped = BTreeSet::new();
    let mut face: Vec<u32> = Vec::new();
    let mut joined = String::new();
    let mut lines = text.lines().enumerate();
    // Vertex colours, `vt` and `vn` tables, and the corners' `vt` and `vn` numbers.
    let (mut colours, mut colour_lines) = (TextCoords::default(), 0usize);
    let mut uv = Table::new("texture coordinates", "vt");
    let mut nrm = Table::new("normals", "vn");
    let mut refs: Vec<(Option<i64>, Option<i64>)> = Vec::new();
    // Objects, groups, smoothing groups and materials: channels of names per face.
    let mut names = NAMED.map(|(kw, _)| Names::new(kw));
    let mut kept = FileLines::default();
    // `l` and `p` lines of plain vertex numbers, until one is not.
    let mut elements = [
        Elements::new("l", "line elements"),
        Elements::new("p", "point elements"),
    ];
    while let Some((n, raw)) = lines.next() {
        let lineno = n + 1;
        let mut line: &str = raw;
        // A trailing backslash continues the statement on the next line.
        if line.trim_end().ends_with('\\') {
            join_continued(raw, &mut lines, &mut joined);
            line = &joined;
        }
        if line.trim_start().starts_with('#') {
            kept.push(line);
            continue;
        }
        let whole = line;
        let line = line.split('#').next().unwrap_or("");
        let mut tok = line.split_ascii_whitespace();
        let Some(kw) = tok.next() else { continue };
        match kw {
            "v" => {
                let mut p = [""; 3];
                for (k, slot) in p.iter_mut().enumerate() {
                    *slot = tok.next().ok_or_else(|| {
                        syntax(
                            "OBJ",
                            lineno,
                            format!("vertex has {k} coordinates, needs 3"),
                        )
                    })?;
                }
                coords.push(p).map_err(|e| syntax("OBJ", lineno, e))?;
                // The tokens after the position.
                let (rest, count) = first_three(tok, "");
                match count {
                    0 => {}
                    1 => {
                        dropped.insert("homogeneous w coordinates".to_string());
                    }
                    3 if colour_lines + 1 == coords.len() => {
                        // Colours that are no numbers are no channel (the file's bytes
                        // keep them).
                        match colours.push([rest[0], rest[1], rest[2]]) {
                            Ok(()) => colour_lines += 1,
                            Err(e) => {
                                dropped.insert(format!("vertex colors (line {lineno}: {e})"));
                            }
                        }
                    }
                    _ => {
                        dropped.insert("vertex colors".to_string());
                    }
                }
            }
            "f" | "fo" => {
                read_face(tok, lineno, coords.len(), &mut face, &mut refs)?;
                if face.len() >= 3 {
                    topo.push_face(&face);
                    uv.corners(&refs, |r| r.0, lineno);
                    nrm.corners(&refs, |r| r.1, lineno);
                    names.iter_mut().for_each(Names::face);
                } else {
                    // A face of one or two corners is a point or a line, not a polygon.
                    dropped.insert("faces of fewer than 3 corners".to_string());
                }
            }
            "vt" => uv.push(tok, lineno),
            "vn" => nrm.push(tok, lineno),
            "vp" => {
                dropped.insert("parameter-space vertices".to_string());
            }
            "l" | "p" => {
                let e = &mut elements[(kw == "p") as usize];
                if !e.push(tok, coords.len()) {
                    dropped.insert(e.what.to_string());
                }
            }
            "o" | "g" | "s" | "usemtl" => {
                if let Some(n) = names.iter_mut().find(|n| n.keyword == kw) {
                    n.set(tok);
                }
            }
            "mtllib" => kept.push(whole),
            other if OTHER_KEYWORDS.contains(&other) => kept.push(whole),
            other if FREE_FORM.contains(&other) => {
                dropped.insert(format!("'{other}' statements"));
            }
            other => {
                // Not OBJ: text that is no mesh, or a format subwave does not read.
                return Err(syntax(
                    "OBJ",
                    lineno,
                    format!("'{other}' is no OBJ statement: not an OBJ file (subwave reads OBJ, PLY, OFF and STL)"),
                ));
            }
        }
        // A kept line keeps its comment; the statements the mesh holds do not.
        if line.len() < whole.len() && kw != "mtllib" && !OTHER_KEYWORDS.contains(&kw) {
            dropped.insert("comments after statements".to_string());
        }
    }
    let mut attributes = Vec::new();
    if colour_lines > 0 && colour_lines == coords.len() {
        attributes.push(RawAttribute {
            name: "color".into(),
            domain: Domain::Vertex,
            value_type: ValueType::Text,
            width: 3,
            values: colours.finish().0,
            indices: Vec::new(),
            labels: Vec::new(),
        });
    } else if colour_lines > 0 {
        dropped.insert("vertex colors".to_string());
    }
    for (n, (_, name)) in names.into_iter().zip(NAMED) {
        if let Some(a) = n.finish(name) {
            attributes.push(a);
        }
    }
    attributes.extend(kept.finish(LINES));
    for e in elements {
        match e.finish(coords.len()) {
            Ok(a) => attributes.extend(a),
            Err(what) => {
                dropped.insert(what.to_string());
            }
        }
    }
    for (t, name) in [(uv, "uv"), (nrm, "normal")] {
        if let Some(a) = t.finish(name, topo.corner_count(), &mut dropped) {
            attributes.push(a);
        }
    }
    let (coords, inexact) = coords.finish();
    Ok(RawMesh {
        coords,
        topology: topo,
        format: Format::Obj,
        dropped,
        inexact,
        attributes,
    })
}

/// The statements that name the faces after them, and their channels' names, in the
/// order the writer writes them before a face.
const NAMED: [(&str, &str); 4] = [
    ("o", "object"),
    ("g", "group"),
    ("s", "smoothing"),
    ("usemtl", "material"),
];

/// A statement's names as read: each face's name (its tokens, space-separated; none
/// before the first statement or after one without tokens).
struct Names {
    keyword: &'static str,
    labels: Vec<String>,
    index: std::collections::HashMap<String, i64>,
    current: i64,
    faces: Vec<i64>,
    seen: bool,
}

impl Names {
    fn new(keyword: &'static str) -> Self {
        Names {
            keyword,
            labels: Vec::new(),
            index: std::collections::HashMap::new(),
            current: -1,
            faces: Vec::new(),
            seen: false,
        }
    }

    fn set<'a>(&mut self, tok: impl Iterator<Item = &'a str>) {
        self.seen = true;
        let label = tok.collect::<Vec<_>>().join(" ");
        self.current = match label.is_empty() {
            true => -1,
            false => {
                let next = self.labels.len() as i64;
                *self.index.entry(label.clone()).or_insert_with(|| {
                    self.labels.push(label);
                    next
                })
            }
        };
    }

    fn face(&mut self) {
        self.faces.push(self.current);
    }

    /// The channel `name` of the faces' names, if the statement stood in the file.
    fn finish(self, name: &str) -> Option<RawAttribute> {
        self.seen
            .then(|| RawAttribute::names(name, Domain::Face, &self.faces, self.labels))
    }
}

/// A `vt` or `vn` table as read and the faces' numbers into it: a corner channel
/// (SPEC.md 11.4) when every line has the same number of values, every value is a
/// number and every corner a number in the table. A table that is not one is noted as
/// dropped, with its first fault: the file is still read (its own bytes keep it).
struct Table {
    /// Why it is no channel: its first fault, with its line.
    bad: Option<String>,
    /// What it holds, for messages.
    what: &'static str,
    /// Its keyword.
    keyword: &'static str,
    rows: TextCoords,
    /// Values per line (the first line's); `None` once lines disagree.
    width: Option<usize>,
    /// Lines read.
    lines: usize,
    /// Per corner so far, its entry; `None` once a corner has none.
    indices: Option<Vec<u32>>,
    /// Corners with a number.
    numbered: usize,
    /// The largest number a corner gave, with its line (numbers may point forward).
    largest: (u64, usize),
}

impl Table {
    fn new(what: &'static str, keyword: &'static str) -> Self {
        Table {
            bad: None,
            what,
            keyword,
            rows: TextCoords::default(),
            width: Some(0),
            lines: 0,
            indices: Some(Vec::new()),
            numbered: 0,
            largest: (0, 0),
        }
    }

    /// A `vt` or `vn` line's values.
    fn push<'a>(&mut self, tok: impl Iterator<Item = &'a str>, lineno: usize) {
        let (t, n) = first_three(tok, "0");
        self.lines += 1;
        let first = self.lines == 1;
        match self.width {
            Some(_) if first && (1..=3).contains(&n) => self.width = Some(n),
            Some(_) if first => self.width = None,
            Some(w) if w == n => {}
            _ => self.width = None,
        }
        if self.width.is_some() && self.bad.is_none() {
            if let Err(e) = self.rows.push(t) {
                self.bad = Some(format!("line {lineno}: {e}"));
            }
        }
    }

    /// A face's corners' numbers into this table (`pick` of each corner's pair), 0-based
    /// as far as they can be resolved now.
    fn corners(
        &mut self,
        refs: &[(Option<i64>, Option<i64>)],
        pick: impl Fn(&(Option<i64>, Option<i64>)) -> Option<i64>,
        lineno: usize,
    ) {
        for r in refs {
            let Some(i) = pick(r) else {
                // A corner without a number has no entry.
                if let Some(v) = &mut self.indices {
                    v.push(NO_ENTRY);
                }
                continue;
            };
            self.numbered += 1;
            let idx = match i {
                i if i > 0 => i - 1,
                i if i < 0 => self.lines as i64 + i,
                _ => -1,
            };
            if idx < 0 || idx >= u32::MAX as i64 {
                let why = format!(
                    "line {lineno}: {} reference {i} is out of range",
                    self.keyword
                );
                self.bad.get_or_insert(why);
                self.indices = None;
                continue;
            }
            if idx as u64 + 1 > self.largest.0 {
                self.largest = (idx as u64 + 1, lineno);
            }
            if let Some(v) = &mut self.indices {
                v.push(idx as u32);
            }
        }
    }

    /// The channel named `name`, if the table is one; why it is not noted in
    /// `dropped`.
    fn finish(
        self,
        name: &str,
        corners: usize,
        dropped: &mut BTreeSet<String>,
    ) -> Option<RawAttribute> {
        if self.largest.0 > self.lines as u64 {
            let why = format!(
                "line {}: {} reference {} is past the file's {} '{}' lines",
                self.largest.1, self.keyword, self.largest.0, self.lines, self.keyword
            );
            dropped.insert(format!("{} ({})", self.what, self.bad.unwrap_or(why)));
            return None;
        }
        if let Some(why) = self.bad {
            dropped.insert(format!("{} ({why})", self.what));
            return None;
        }
        if self.lines == 0 && self.numbered == 0 {
            return None;
        }
        let why = match (self.width, &self.indices) {
            (None, _) => "of differing lengths",
            (_, None) => "with numbers out of range",
            (_, Some(v)) if v.len() != corners || corners == 0 => "that no face uses",
            _ => "",
        };
        if !why.is_empty() {
            dropped.insert(format!("{} {why}", self.what));
            return None;
        }
        let (values, _) = self.rows.finish();
        Some(RawAttribute {
            name: name.to_string(),
            domain: Domain::Corner,
            value_type: ValueType::Text,
            width: self.width.unwrap_or(1) as u8,
            values,
            indices: self.indices.unwrap_or_default(),
            labels: Vec::new(),
        })
    }
}

/// A statement continued by trailing backslashes, joined into `joined`.
fn join_continued<'a>(
    first: &'a str,
    lines: &mut impl Iterator<Item = (usize, &'a str)>,
    joined: &mut String,
) {
    joined.clear();
    let mut cur = first;
    loop {
        let t = cur.trim_end();
        if let Some(stripped) = t.strip_suffix('\\') {
            joined.push_str(stripped);
            joined.push(' ');
            match lines.next() {
                Some((_, next)) => cur = next,
                None => break,
            }
        } else {
            joined.push_str(cur);
            break;
        }
    }
}

/// The first three of a statement's remaining tokens (`fill` where there are fewer)
/// and how many there are, without an allocation a line.
fn first_three<'a>(tok: impl Iterator<Item = &'a str>, fill: &'a str) -> ([&'a str; 3], usize) {
    let mut t = [fill; 3];
    let mut n = 0;
    for v in tok {
        if let Some(slot) = t.get_mut(n) {
            *slot = v;
        }
        n += 1;
    }
    (t, n)
}

/// An `f` statement's corners (`v`, `v/vt`, `v/vt/vn`, `v//vn`; negative numbers count
/// back from the `nv` vertices so far) into `face`, and each corner's `vt` and `vn`
/// numbers as written into `refs`. The caller checks that there are at least 3.
fn read_face<'a>(
    tok: impl Iterator<Item = &'a str>,
    lineno: usize,
    nv: usize,
    face: &mut Vec<u32>,
    refs: &mut Vec<(Option<i64>, Option<i64>)>,
) -> Result<()> {
    face.clear();
    refs.clear();
    // A number that is no number is number 0, out of every table's range (its table
    // is then no channel).
    let number = |s: &str| -> Option<i64> { (!s.is_empty()).then(|| s.parse().unwrap_or(0)) };
    for t in tok {
        let mut parts = t.split('/');
        let vi = parts.next().unwrap_or("");
        let vt = number(parts.next().unwrap_or(""));
        let vn = number(parts.next().unwrap_or(""));
        refs.push((vt, vn));
        let i: i64 = vi
            .parse()
            .map_err(|_| syntax("OBJ", lineno, format!("'{t}' is not a vertex reference")))?;
        let idx = if i > 0 {
            i - 1
        } else if i < 0 {
            nv as i64 + i
        } else {
            -1
        };
        if idx < 0 || idx >= u32::MAX as i64 {
            return Err(syntax(
                "OBJ",
                lineno,
                format!("vertex reference {i} is out of range"),
            ));
        }
        face.push(idx as u32);
    }
    Ok(())
}

/// An OBJ's `l` or `p` statements as read: each its vertices' numbers (from 0), while
/// every one names vertices by plain numbers (no `vt`).
struct Elements {
    keyword: &'static str,
    /// What they are, for the note of them as dropped.
    what: &'static str,
    lists: Option<Vec<Vec<i64>>>,
}

impl Elements {
    fn new(keyword: &'static str, what: &'static str) -> Self {
        Elements {
            keyword,
            what,
            lists: Some(Vec::new()),
        }
    }

    /// A statement's vertex numbers (counted from 1, or back from the `nv` vertices so
    /// far); false once one is not plain numbers.
    fn push<'a>(&mut self, tok: impl Iterator<Item = &'a str>, nv: usize) -> bool {
        let vertex = |t: &str| -> Option<i64> {
            let i: i64 = t.parse().ok()?;
            let v = if i > 0 { i - 1 } else { nv as i64 + i };
            (i != 0 && (0..u32::MAX as i64).contains(&v)).then_some(v)
        };
        let list: Option<Vec<i64>> = tok.map(vertex).collect();
        match (list, self.lists.as_mut()) {
            (Some(l), Some(all)) if !l.is_empty() => {
                all.push(l);
                true
            }
            _ => {
                self.lists = None;
                false
            }
        }
    }

    /// Their channel for a file of `nv` vertices: `l` lines all of two vertices as the
    /// edges ([`EDGES`]), else a list channel `l/vertex_indices` or `p/vertex_indices`,
    /// per file ([`ELEMENT_LISTS`]); none when there are none; what they are (to note
    /// as dropped) when one names a vertex past the file's.
    fn finish(self, nv: usize) -> std::result::Result<Option<RawAttribute>, &'static str> {
        let Some(lists) = self.lists.filter(|l| !l.is_empty()) else {
            return Ok(None);
        };
        let all = || lists.iter().flatten();
        if all().any(|&v| v as usize >= nv) {
            return Err(self.what);
        }
        let int = crate::quant::Decimal::integer;
        let value_type = match all().any(|&v| v > i32::MAX as i64) {
            true => ValueType::U32,
            false => ValueType::I32,
        };
        let edges = self.keyword == "l" && lists.iter().all(|l| l.len() == 2);
        let (name, values, indices) = match edges {
            true => (
                EDGES.to_string(),
                lists
                    .iter()
                    .map(|l| [int(l[0]), int(l[1]), int(0)])
                    .collect(),
                Vec::new(),
            ),
            false => (
                format!("{}/vertex_indices", self.keyword),
                all().map(|&v| [int(v), int(0), int(0)]).collect(),
                lists.iter().map(|l| l.len() as u32).collect(),
            ),
        };
        Ok(Some(RawAttribute {
            name,
            domain: Domain::File,
            value_type,
            width: if edges { 2 } else { 1 },
            values: crate::quant::RawCoords::Decimal(values),
            indices,
            labels: Vec::new(),
        }))
    }
}

/// The list channels of an OBJ's `l` and `p` statements, per file, written back as
/// they were read (each statement's vertex numbers renumbered with the vertices).
pub(crate) const ELEMENT_LISTS: [(&str, &str); 2] =
    [("l", "l/vertex_indices"), ("p", "p/vertex_indices")];

/// The name of the channel of an OBJ's `l` lines of two vertices (and a PLY's `edge`
/// element of its ends alone).
pub(crate) const EDGES: &str = "edge/vertex1 vertex2";

fn line_of(bytes: &[u8], offset: usize) -> usize {
    bytes[..offset].iter().filter(|&&b| b == b'\n').count() + 1
}

/// The channels an OBJ writes: vertex colours (`color`, three values per vertex) on the
/// `v` lines, texture coordinates (`uv`) as `vt` lines and normals (`normal`) as `vn`
/// lines, each per corner or per vertex; the names of faces' objects, groups, smoothing
/// groups and materials; per file, its lines ([`LINES`]), edges ([`EDGES`]) and
/// other `l` and `p` lines ([`ELEMENT_LISTS`]).
pub(crate) fn writes(a: &Attribute) -> bool {
    if a.is_list() {
        return a.domain == Domain::File
            && a.value_type.int_range().is_some()
            && ELEMENT_LISTS.iter().any(|(_, n)| *n == a.name);
    }
    match a.name.as_str() {
        "color" => a.domain == Domain::Vertex && a.width == 3,
        "uv" | "normal" => matches!(a.domain, Domain::Vertex | Domain::Corner),
        LINES => a.domain == Domain::File && !a.labels.is_empty(),
        EDGES => {
            a.domain == Domain::File
                && a.width == 2
                && a.labels.is_empty()
                && a.value_type.int_range().is_some()
        }
        n if NAMED.iter().any(|(_, c)| *c == n) => {
            a.domain == Domain::Face
                && a.width == 1
                && (!a.labels.is_empty() || a.values.iter().all(|v| v[0] == -1))
        }
        _ => false,
    }
}

pub(crate) fn write<W: Write>(out: &mut W, mesh: &Mesh, q: &Quantization) -> Result<()> {
    let find = |name: &str| mesh.attributes.iter().find(|a| a.name == name && writes(a));
    let (colour, uv, normal) = (find("color"), find("uv"), find("normal"));
    let mut line = String::with_capacity(128);
    if let Some(a) = find(LINES) {
        for v in &a.values {
            if let Some(l) = a.label(v[0]) {
                writeln!(out, "{l}")?;
            }
        }
    }
    let table = |a: &Attribute, keyword: &str, out: &mut W, line: &mut String| -> Result<()> {
        for e in 0..a.entry_count() {
            line.clear();
            line.push_str(keyword);
            a.push_text(e, line);
            line.push('\n');
            out.write_all(line.as_bytes())?;
        }
        Ok(())
    };
    for v in 0..mesh.vertex_count() {
        coords_line("v", mesh, v, q, &mut line);
        if let Some(c) = colour {
            line.pop();
            c.push_text(v, &mut line);
            line.push('\n');
        }
        out.write_all(line.as_bytes())?;
    }
    if let Some(a) = uv {
        table(a, "vt", out, &mut line)?;
    }
    if let Some(a) = normal {
        table(a, "vn", out, &mut line)?;
    }
    // A corner's entry in a channel, counted from 1; none for none.
    let entry = |a: &Attribute, c: usize, v: u32| -> Option<u64> {
        match a.domain {
            Domain::Corner if a.indices[c] == NO_ENTRY => None,
            Domain::Corner => Some(a.indices[c] as u64 + 1),
            _ => Some(v as u64 + 1),
        }
    };
    // The statements that name faces, written where a face's name changes.
    let named: Vec<(&str, &Attribute)> = NAMED
        .iter()
        .filter_map(|&(kw, name)| find(name).map(|a| (kw, a)))
        .collect();
    let mut names = vec![-1i64; named.len()];
    for f in 0..mesh.face_count() {
        let s = mesh.face_starts[f] as usize;
        for (k, &(kw, a)) in named.iter().enumerate() {
            let v = a.values[f][0];
            if v != names[k] {
                names[k] = v;
                line.clear();
                line.push_str(kw);
                if let Some(l) = a.label(v) {
                    line.push(' ');
                    line.push_str(l);
                }
                line.push('\n');
                out.write_all(line.as_bytes())?;
            }
        }
        line.clear();
        line.push('f');
        for (j, &i) in mesh.face(f).iter().enumerate() {
            line.push(' ');
            push_int(&mut line, i as u64 + 1);
            let t = uv.and_then(|t| entry(t, s + j, i));
            match (t, normal.and_then(|n| entry(n, s + j, i))) {
                (None, None) => {}
                (Some(t), None) => {
                    line.push('/');
                    push_int(&mut line, t);
                }
                (None, Some(n)) => {
                    line.push_str("//");
                    push_int(&mut line, n);
                }
                (Some(t), Some(n)) => {
                    line.push('/');
                    push_int(&mut line, t);
                    line.push('/');
                    push_int(&mut line, n);
                }
            }
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
    }
    // Lines and points: their vertices' numbers, each a vertex of the mesh.
    let nv = mesh.vertex_count() as i64;
    let number = |v: i64| -> Result<i64> {
        match (0..nv).contains(&v) {
            true => Ok(v + 1),
            false => Err(crate::Error::InvalidMesh(format!(
                "a line or point element names vertex {v} of {nv}"
            ))),
        }
    };
    if let Some(a) = find(EDGES) {
        for v in &a.values {
            writeln!(out, "l {} {}", number(v[0])?, number(v[1])?)?;
        }
    }
    for (keyword, name) in ELEMENT_LISTS {
        let Some(a) = find(name) else { continue };
        for items in a.list() {
            line.clear();
            line.push_str(keyword);
            for v in &a.values[items] {
                line.push(' ');
                push_int(&mut line, number(v[0])?);
            }
            line.push('\n');
            out.write_all(line.as_bytes())?;
        }
    }
    Ok(())
}

/// Spans of the whitespace-separated tokens of `code` (ASCII whitespace, as the reader
/// splits them).
pub(super) fn tokens(code: &[u8]) -> impl Iterator<Item = (usize, usize)> + '_ {
    let mut i = 0;
    std::iter::from_fn(move || {
        while i < code.len() && code[i].is_ascii_whitespace() {
            i += 1;
        }
        let start = i;
        while i < code.len() && !code[i].is_ascii_whitespace() {
            i += 1;
        }
        (i > start).then_some((start, i))
    })
}

/// A line's statement: its tokens before any comment.
fn statement(line: &[u8]) -> Vec<&[u8]> {
    let code = &line[..line.iter().position(|&c| c == b'#').unwrap_or(line.len())];
    tokens(code).map(|(s, e)| &code[s..e]).collect()
}

/// An attribute of `width` values from each entry's tokens (the rest 0), on the faces
/// `faces` (each a list of entry numbers), if its numbers are finite.
fn attribute_of(entries: &[Vec<&[u8]>], width: usize, faces: &Mesh) -> Option<FileAttribute> {
    let mut rows = Vec::with_capacity(entries.len());
    for e in entries {
        let mut t = ["0"; 3];
        for k in 0..width {
            t[k] = std::str::from_utf8(e[k]).ok()?;
        }
        rows.push(t);
    }
    Some(FileAttribute::on_faces(
        width,
        super::text_values(&rows)?,
        faces,
    ))
}

/// What an OBJ file's walk needs to know before it starts.
struct Scan {
    /// The `vt` table's attribute (SPEC.md 11.3).
    uv: Option<usize>,
    /// The vertex colours' attribute.
    colour: Option<usize>,
    /// Whether every `vn` line is three plain decimals: then the `vn` values go to NRML
    /// (SPEC.md 11.2), so that its n-th entry is the corners' `vn` number n.
    normals: bool,
}

/// One pass over an OBJ file before its walk: whether its normals go to NRML, and its
/// attributes (SPEC.md 11.3), made in `b`: the `vt` table when every `vt` line is two
/// numbers (on the faces of the corners' `vt` numbers, where a face's corners all have
/// distinct ones), and the vertex colours when every `v` line is six numbers.
fn scan(bytes: &[u8], b: &mut Builder<'_>) -> Scan {
    let (mut vt, mut colours) = (Vec::new(), Vec::new());
    let (mut vt_ok, mut colours_ok, mut normals) = (true, true, true);
    let mut uv_faces = Mesh::new();
    let mut corners = Vec::new();
    for line in super::lines_with_ends(bytes) {
        let t = statement(line);
        match t.first().copied() {
            Some(b"vt") => {
                vt_ok &= t.len() == 3;
                vt.push(t[1..].to_vec());
            }
            Some(b"v") => {
                colours_ok &= t.len() == 7;
                colours.push(t[4.min(t.len())..].to_vec());
            }
            Some(b"vn") => {
                normals &= t.len() == 4 && t[1..].iter().all(|t| Component::parse(t).is_some());
            }
            Some(b"f" | b"fo") if t.len() >= 4 => {
                corners.clear();
                for c in &t[1..] {
                    let n = c
                        .split(|&x| x == b'/')
                        .nth(1)
                        .and_then(|n| std::str::from_utf8(n).ok()?.parse::<u32>().ok())
                        .filter(|&n| n >= 1);
                    match n {
                        Some(n) if !corners.contains(&(n - 1)) => corners.push(n - 1),
                        _ => break,
                    }
                }
                if corners.len() == t.len() - 1 && corners.iter().all(|&n| (n as usize) < vt.len())
                {
                    uv_faces.push_face(&corners);
                }
            }
            _ => {}
        }
    }
    let mut out = Scan {
        uv: None,
        colour: None,
        normals,
    };
    if vt_ok && !vt.is_empty() {
        out.uv = attribute_of(&vt, 2, &uv_faces).and_then(|a| b.attribute(a.named("uv")));
        b.corners_from(out.uv);
    }
    if colours_ok && !colours.is_empty() && colours.len() == b.mesh().vertex_count() {
        out.colour =
            attribute_of(&colours, 3, b.mesh()).and_then(|a| b.attribute(a.named("color")));
    }
    out
}

/// Walks an OBJ file for its template (SPEC.md 11): the three coordinates of every `v`
/// line and the vertex number of every `f` corner are the coded values; `None` for a
/// file with continued lines (the reader joins them).
pub(super) fn template(bytes: &[u8], b: &mut Builder<'_>) -> Option<()> {
    let Scan {
        uv,
        colour,
        normals,
    } = scan(bytes, b);
    for line in super::lines_with_ends(bytes) {
        let mut content = line.strip_suffix(b"\n").unwrap_or(line);
        content = content.strip_suffix(b"\r").unwrap_or(content);
        if content.trim_ascii_end().ends_with(b"\\") {
            return None;
        }
        let code = &content[..content
            .iter()
            .position(|&c| c == b'#')
            .unwrap_or(content.len())];
        let mut toks = tokens(code);
        let Some((s0, e0)) = toks.next() else {
            b.literal(line);
            continue;
        };
        let kw = &code[s0..e0];
        let mut at = 0;
        match kw {
            b"vn" if normals => {
                for (s, e) in toks.take(3) {
                    b.literal(&line[at..s]);
                    b.normal_text(Component::parse(&line[s..e])?);
                    at = e;
                }
            }
            b"v" => {
                for (i, (s, e)) in toks.enumerate() {
                    b.literal(&line[at..s]);
                    match (i, colour) {
                        (0..3, _) => b.coord_text(&line[s..e]),
                        (_, Some(g)) => b.attr_value(g, Form::Text, &line[s..e]),
                        _ => b.literal(&line[s..e]),
                    }
                    at = e;
                }
            }
            b"vt" if uv.is_some() => {
                for (s, e) in toks {
                    b.literal(&line[at..s]);
                    b.attr_value(uv?, Form::Text, &line[s..e]);
                    at = e;
                }
            }
            // As the reader: a face of fewer than 3 corners is not coded.
            b"f" | b"fo" if tokens(code).count() >= 4 => {
                for (s, e) in toks {
                    b.literal(&line[at..s]);
                    let slash = line[s..e]
                        .iter()
                        .position(|&c| c == b'/')
                        .map_or(e, |i| s + i);
                    b.index_text(&line[s..slash], 1);
                    // `/vt/vn`: channels 0 and 1 (SPEC.md 11.1).
                    let mut p = slash;
                    for k in 0..2 {
                        if p >= e {
                            break;
                        }
                        b.literal(b"/");
                        let end = line[p + 1..e]
                            .iter()
                            .position(|&c| c == b'/')
                            .map_or(e, |i| p + 1 + i);
                        if end > p + 1 {
                            b.channel_text(k, &line[p + 1..end]);
                        }
                        p = end;
                    }
                    at = p;
                }
            }
            _ => {}
        }
        b.literal(&line[at..]);
    }
    Some(())
}

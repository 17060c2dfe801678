//! Wavefront OBJ: `v` and `f` statements; everything else is reported as dropped.

use std::collections::BTreeSet;
use std::io::Write;

use super::template::{Attribute, Builder, Form};
use super::{coords_line, syntax, Format, RawMesh};
use crate::error::Result;
use crate::mesh::Mesh;
use crate::quant::{Quantization, TextCoords};
use crate::sections::nrml::Component;

/// The OBJ statements (Wavefront's specification and common extensions) besides those
/// read above, kept as dropped: a line that starts with none of them is not OBJ.
const OTHER_KEYWORDS: [&str; 27] = [
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
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
    while let Some((n, raw)) = lines.next() {
        let lineno = n + 1;
        let mut line: &str = raw;
        // A trailing backslash continues the statement on the next line.
        if line.trim_end().ends_with('\\') {
            join_continued(raw, &mut lines, &mut joined);
            line = &joined;
        }
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
                match tok.count() {
                    0 => {}
                    1 => {
                        dropped.insert("homogeneous w coordinates".to_string());
                    }
                    _ => {
                        dropped.insert("vertex colors".to_string());
                    }
                }
            }
            "f" | "fo" => {
                read_face(tok, lineno, coords.len(), &mut face, &mut dropped)?;
                if face.len() >= 3 {
                    topo.push_face(&face);
                } else {
                    // A face of one or two corners is a point or a line, not a polygon.
                    dropped.insert("faces of fewer than 3 corners".to_string());
                }
            }
            "vt" => {
                dropped.insert("texture coordinates".to_string());
            }
            "vn" => {
                dropped.insert("normals".to_string());
            }
            "vp" => {
                dropped.insert("parameter-space vertices".to_string());
            }
            "l" => {
                dropped.insert("line elements".to_string());
            }
            "p" => {
                dropped.insert("point elements".to_string());
            }
            "o" | "g" => {
                dropped.insert("object and group names".to_string());
            }
            "s" => {
                dropped.insert("smoothing groups".to_string());
            }
            "mtllib" | "usemtl" => {
                dropped.insert("materials".to_string());
            }
            other if OTHER_KEYWORDS.contains(&other) => {
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
    }
    let (coords, inexact) = coords.finish();
    Ok(RawMesh {
        coords,
        topology: topo,
        format: Format::Obj,
        dropped,
        inexact,
    })
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

/// An `f` statement's corners (`v`, `v/vt`, `v/vt/vn`, `v//vn`; negative numbers count
/// back from the `nv` vertices so far) into `face`, noting texture coordinates and
/// normals as dropped. The caller checks that there are at least 3.
fn read_face<'a>(
    tok: impl Iterator<Item = &'a str>,
    lineno: usize,
    nv: usize,
    face: &mut Vec<u32>,
    dropped: &mut BTreeSet<String>,
) -> Result<()> {
    face.clear();
    for t in tok {
        let mut parts = t.split('/');
        let vi = parts.next().unwrap_or("");
        if let Some(vt) = parts.next() {
            if !vt.is_empty() {
                dropped.insert("texture coordinates".to_string());
            }
        }
        if parts.next().is_some_and(|vn| !vn.is_empty()) {
            dropped.insert("normals".to_string());
        }
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

fn line_of(bytes: &[u8], offset: usize) -> usize {
    bytes[..offset].iter().filter(|&&b| b == b'\n').count() + 1
}

pub(crate) fn write<W: Write>(out: &mut W, mesh: &Mesh, q: &Quantization) -> Result<()> {
    let mut line = String::with_capacity(128);
    for v in 0..mesh.vertex_count() {
        coords_line("v", mesh, v, q, &mut line);
        out.write_all(line.as_bytes())?;
    }
    for face in mesh.iter_faces() {
        line.clear();
        line.push('f');
        for &i in face {
            use std::fmt::Write as _;
            let _ = write!(line, " {}", i as u64 + 1);
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
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
fn attribute_of(entries: &[Vec<&[u8]>], width: usize, faces: &Mesh) -> Option<Attribute> {
    let mut rows = Vec::with_capacity(entries.len());
    for e in entries {
        let mut t = ["0"; 3];
        for k in 0..width {
            t[k] = std::str::from_utf8(e[k]).ok()?;
        }
        rows.push(t);
    }
    Some(Attribute::on_faces(
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
        out.uv = attribute_of(&vt, 2, &uv_faces).and_then(|a| b.attribute(a));
        b.corners_from(out.uv);
    }
    if colours_ok && !colours.is_empty() && colours.len() == b.mesh().vertex_count() {
        out.colour = attribute_of(&colours, 3, b.mesh()).and_then(|a| b.attribute(a));
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

//! STL, binary and ASCII: a list of facets, each a normal and three (in ASCII, three or
//! more) corner positions. Corners with the same position (the same bits in binary, the
//! same text in ASCII) become one vertex, numbered in order of first appearance; facet
//! normals, the 80-byte header, attribute words and solid names are reported as dropped
//! (with `--keep-order` the file's template keeps them).

use std::collections::hash_map::Entry;
use std::collections::{BTreeSet, HashMap};
use std::io::Write;

use super::template::Builder;
use super::{format_coord, value_f32, Format, RawMesh};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::quant::{Quantization, RawCoords, TextCoords};

/// Bytes of a binary STL's header and facet count, and of each facet.
const HEAD: usize = 84;
const FACET: usize = 50;

fn err(what: impl std::fmt::Display) -> Error {
    Error::MeshFile(format!("STL: {what}"))
}

/// Whether `bytes` are a binary STL: an 84-byte head whose facet count accounts for
/// the rest of the file exactly.
pub(crate) fn is_binary(bytes: &[u8]) -> bool {
    bytes.len() >= HEAD && {
        let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as u64;
        HEAD as u64 + n * FACET as u64 == bytes.len() as u64
    }
}

/// Whether `bytes` start as an ASCII STL (`solid`, after any white space).
pub(crate) fn is_ascii(bytes: &[u8]) -> bool {
    let t = bytes.trim_ascii_start();
    t.len() >= 5 && t[..5].eq_ignore_ascii_case(b"solid")
}

pub(crate) fn read(bytes: &[u8]) -> Result<RawMesh> {
    if is_binary(bytes) {
        read_binary(bytes)
    } else {
        read_ascii(bytes)
    }
}

fn read_binary(bytes: &[u8]) -> Result<RawMesh> {
    let facets = bytes[HEAD..].chunks_exact(FACET);
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    let mut coords: Vec<[f32; 3]> = Vec::new();
    let mut topo = Mesh::new();
    let mut dropped = BTreeSet::new();
    dropped.insert("the STL header".to_string());
    let mut face = [0u32; 3];
    for (f, facet) in facets.enumerate() {
        if facet[..12].iter().any(|&b| b != 0) {
            dropped.insert("facet normals".to_string());
        }
        if facet[48..50] != [0, 0] {
            dropped.insert("facet attribute words".to_string());
        }
        for (c, slot) in face.iter_mut().enumerate() {
            let at = 12 + 12 * c;
            let p: [f32; 3] = std::array::from_fn(|k| {
                f32::from_le_bytes(facet[at + 4 * k..at + 4 * k + 4].try_into().unwrap())
            });
            if p.iter().any(|x| !x.is_finite()) {
                return Err(err(format!(
                    "facet {} has a corner that is not a finite number",
                    f + 1
                )));
            }
            *slot = match index.entry(p.map(f32::to_bits)) {
                Entry::Occupied(e) => *e.get(),
                Entry::Vacant(e) => {
                    coords.push(p);
                    *e.insert(coords.len() as u32 - 1)
                }
            };
        }
        topo.push_face(&face);
    }
    Ok(RawMesh {
        attributes: Vec::new(),
        coords: RawCoords::F32(coords),
        topology: topo,
        format: Format::StlBinary,
        dropped,
        inexact: None,
    })
}

fn read_ascii(bytes: &[u8]) -> Result<RawMesh> {
    let text = std::str::from_utf8(bytes).map_err(|_| {
        err("neither a binary STL (its length does not match its facet count) nor ASCII text")
    })?;
    let mut coords = TextCoords::default();
    let mut index: HashMap<[&str; 3], u32> = HashMap::new();
    let mut topo = Mesh::new();
    let mut dropped = BTreeSet::new();
    let mut face: Vec<u32> = Vec::new();
    let (mut in_solid, mut in_loop, mut solids) = (false, false, 0usize);
    for (n, line) in text.lines().enumerate() {
        let bad = |what: String| super::syntax("STL", n + 1, what);
        let mut t = line.split_ascii_whitespace();
        let Some(kw) = t.next() else { continue };
        match kw.to_ascii_lowercase().as_str() {
            "solid" if !in_solid => {
                in_solid = true;
                solids += 1;
                if t.next().is_some() {
                    dropped.insert("solid names".to_string());
                }
            }
            "endsolid" if in_solid && !in_loop => in_solid = false,
            "facet" if in_solid => {
                dropped.insert("facet normals".to_string());
            }
            "outer" if in_solid => {
                in_loop = true;
                face.clear();
            }
            "vertex" if in_loop => {
                let p: Vec<&str> = t.collect();
                if p.len() != 3 {
                    return Err(bad(format!("vertex has {} coordinates, needs 3", p.len())));
                }
                let p = [p[0], p[1], p[2]];
                let i = match index.entry(p) {
                    Entry::Occupied(e) => *e.get(),
                    Entry::Vacant(e) => {
                        coords.push(p).map_err(&bad)?;
                        *e.insert(coords.len() as u32 - 1)
                    }
                };
                face.push(i);
            }
            "endloop" if in_loop => {
                in_loop = false;
                if face.len() < 3 {
                    return Err(bad(format!(
                        "facet has {} corners; facets need at least 3",
                        face.len()
                    )));
                }
                topo.push_face(&face);
            }
            "endfacet" if in_solid && !in_loop => {}
            other => return Err(bad(format!("unexpected '{other}' in an ASCII STL"))),
        }
    }
    if solids == 0 || in_solid {
        return Err(err("the file ends inside a solid (no 'endsolid')"));
    }
    let (coords, inexact) = coords.finish();
    Ok(RawMesh {
        attributes: Vec::new(),
        coords,
        topology: topo,
        format: Format::StlAscii,
        dropped,
        inexact,
    })
}

/// Each face as triangles (a fan from its first corner), with its normal.
fn triangles<'m>(
    mesh: &'m Mesh,
    q: &'m Quantization,
) -> impl Iterator<Item = ([f32; 3], [usize; 3])> + 'm {
    mesh.iter_faces().flat_map(move |f| {
        (1..f.len() - 1).map(move |i| {
            let tri = [f[0] as usize, f[i] as usize, f[i + 1] as usize];
            let p = tri.map(|v| std::array::from_fn::<f32, 3, _>(|k| value_f32(mesh, v, k, q)));
            (normal(p), tri)
        })
    })
}

/// A triangle's unit normal (zero for a degenerate one).
fn normal(p: [[f32; 3]; 3]) -> [f32; 3] {
    let d = |a: [f32; 3], b: [f32; 3]| [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let (u, v) = (d(p[0], p[1]), d(p[0], p[2]));
    let c = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let len = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    if len > 0.0 && len.is_finite() {
        c.map(|x| x / len)
    } else {
        [0.0; 3]
    }
}

/// Writes `mesh` as STL (polygons as triangle fans; binary positions are binary32).
pub(crate) fn write<W: Write>(
    out: &mut W,
    mesh: &Mesh,
    q: &Quantization,
    binary: bool,
) -> Result<()> {
    if binary {
        let n: usize = mesh.iter_faces().map(|f| f.len() - 2).sum();
        let n = u32::try_from(n)
            .map_err(|_| err(format!("{n} triangles do not fit in a binary STL")))?;
        let mut head = [b' '; 80];
        let title = b"binary STL written by subwave";
        head[..title.len()].copy_from_slice(title);
        out.write_all(&head)?;
        out.write_all(&n.to_le_bytes())?;
        let mut buf = Vec::with_capacity(1 << 16);
        for (nrm, tri) in triangles(mesh, q) {
            for x in nrm {
                buf.extend_from_slice(&x.to_le_bytes());
            }
            for v in tri {
                for k in 0..3 {
                    buf.extend_from_slice(&value_f32(mesh, v, k, q).to_le_bytes());
                }
            }
            buf.extend_from_slice(&[0, 0]);
            if buf.len() > 60_000 {
                out.write_all(&buf)?;
                buf.clear();
            }
        }
        out.write_all(&buf)?;
        return Ok(());
    }
    writeln!(out, "solid subwave")?;
    let mut line = String::with_capacity(128);
    for face in mesh.iter_faces() {
        let p: Vec<[f32; 3]> = face
            .iter()
            .map(|&v| std::array::from_fn(|k| value_f32(mesh, v as usize, k, q)))
            .collect();
        let nrm = normal([p[0], p[1], p[2]]);
        writeln!(out, "facet normal {} {} {}", nrm[0], nrm[1], nrm[2])?;
        writeln!(out, "  outer loop")?;
        for &v in face {
            line.clear();
            line.push_str("    vertex");
            for k in 0..3 {
                line.push(' ');
                format_coord(mesh, v as usize, k, q, &mut line);
            }
            line.push('\n');
            out.write_all(line.as_bytes())?;
        }
        writeln!(out, "  endloop\nendfacet")?;
    }
    writeln!(out, "endsolid subwave")?;
    Ok(())
}

/// Walks a binary STL for its template (SPEC.md 11): each corner's three coordinates
/// are the corner's vertex's; the header, normals and attribute words stay as they are.
fn template_binary(bytes: &[u8], b: &mut Builder<'_>) -> Option<()> {
    b.literal(&bytes[..HEAD]);
    for facet in bytes[HEAD..].chunks_exact(FACET) {
        b.literal(&facet[..12]);
        for c in 0..3 {
            b.corner_f32(&facet[12 + 12 * c..24 + 12 * c]);
        }
        b.literal(&facet[48..]);
    }
    Some(())
}

/// Walks an ASCII STL for its template: the three numbers of each `vertex` line are its
/// corner's vertex's coordinates.
fn template_ascii(bytes: &[u8], b: &mut Builder<'_>) -> Option<()> {
    for line in super::lines_with_ends(bytes) {
        let toks: Vec<(usize, usize)> = super::obj::tokens(line).collect();
        let is_vertex = toks
            .first()
            .is_some_and(|&(s, e)| line[s..e].eq_ignore_ascii_case(b"vertex"));
        if !is_vertex || toks.len() != 4 {
            b.literal(line);
            continue;
        }
        let mut at = toks[0].1;
        b.literal(&line[..at]);
        let spans: Vec<(&[u8], &[u8])> = toks[1..]
            .iter()
            .map(|&(s, e)| {
                let gap = &line[at..s];
                at = e;
                (gap, &line[s..e])
            })
            .collect();
        b.corner_text([spans[0], spans[1], spans[2]]);
        b.literal(&line[at..]);
    }
    Some(())
}

/// Walks an STL file for its template.
pub(super) fn template(bytes: &[u8], b: &mut Builder<'_>) -> Option<()> {
    if is_binary(bytes) {
        template_binary(bytes, b)
    } else {
        template_ascii(bytes, b)
    }
}

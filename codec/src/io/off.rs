//! Object File Format, ASCII: `[ST][C][N]OFF`, counts, vertices, faces.

use std::collections::BTreeSet;
use std::io::Write;

use super::template::Builder;
use super::{syntax, write_counted_text, Format, RawMesh};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::quant::{Quantization, TextCoords};

pub(crate) fn read(bytes: &[u8]) -> Result<RawMesh> {
    let text = std::str::from_utf8(bytes).map_err(|_| {
        Error::MeshFile("OFF file is not UTF-8 text (binary OFF is not supported)".into())
    })?;
    // Statements, with comments and blank lines removed, keeping line numbers.
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(n, l)| (n + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());
    let (ln, first) = lines
        .next()
        .ok_or_else(|| Error::MeshFile("OFF file is empty".into()))?;
    let mut tok = first.split_ascii_whitespace();
    let mut dropped = BTreeSet::new();
    let extra_per_vertex = keyword(tok.next().unwrap_or(""), ln, &mut dropped)?;
    let mut header: Vec<&str> = tok.collect();
    if header.first() == Some(&"BINARY") {
        return Err(Error::Unsupported("binary OFF".into()));
    }
    let mut count_line = ln;
    if header.is_empty() {
        let (n, l) = lines
            .next()
            .ok_or_else(|| syntax("OFF", ln, "missing the vertex and face counts"))?;
        count_line = n;
        header = l.split_ascii_whitespace().collect();
    }
    let count = |i: usize, what: &str| -> Result<usize> {
        header
            .get(i)
            .and_then(|t| t.parse::<u64>().ok())
            .filter(|&c| c <= u32::MAX as u64)
            .map(|c| c as usize)
            .ok_or_else(|| syntax("OFF", count_line, format!("bad {what} count")))
    };
    let nv = count(0, "vertex")?;
    let nf = count(1, "face")?;
    // Each vertex needs at least 6 bytes of text and each face 8: refuse counts the file
    // cannot hold before reserving memory for them.
    if nv.saturating_mul(6).saturating_add(nf.saturating_mul(8)) > bytes.len() {
        return Err(syntax(
            "OFF",
            count_line,
            format!(
                "declares {nv} vertices and {nf} faces, more than the file's {} bytes can hold",
                bytes.len()
            ),
        ));
    }
    let mut coords = TextCoords::default();
    for i in 0..nv {
        let (n, l) = lines
            .next()
            .ok_or_else(|| Error::MeshFile(format!("OFF file ends after {i} of {nv} vertices")))?;
        let mut t = l.split_ascii_whitespace();
        let mut p = [""; 3];
        for (k, slot) in p.iter_mut().enumerate() {
            *slot = t
                .next()
                .ok_or_else(|| syntax("OFF", n, format!("vertex has {k} coordinates, needs 3")))?;
        }
        coords.push(p).map_err(|e| syntax("OFF", n, e))?;
        let extra = t.count();
        if extra > 0 && extra_per_vertex == 0 {
            dropped.insert("per-vertex extra values".to_string());
        }
    }
    let mut topo = Mesh::new();
    let mut face = Vec::new();
    for i in 0..nf {
        let (n, l) = lines
            .next()
            .ok_or_else(|| Error::MeshFile(format!("OFF file ends after {i} of {nf} faces")))?;
        read_face(l, n, nv, &mut face, &mut dropped)?;
        topo.push_face(&face);
    }
    let (coords, inexact) = coords.finish();
    Ok(RawMesh {
        coords,
        topology: topo,
        format: Format::Off,
        dropped,
        inexact,
    })
}

/// The OFF keyword (`[ST][C][N]OFF`): how many values each vertex line has after its
/// position, noting those attributes as dropped.
fn keyword(kw: &str, ln: usize, dropped: &mut BTreeSet<String>) -> Result<usize> {
    let prefix = kw
        .strip_suffix("OFF")
        .ok_or_else(|| syntax("OFF", ln, format!("expected an OFF keyword, found '{kw}'")))?;
    let mut extra_per_vertex = 0usize;
    let mut rest = prefix;
    for (p, n, what) in [
        ("ST", 2, "texture coordinates"),
        ("C", 4, "vertex colors"),
        ("N", 3, "normals"),
    ] {
        if let Some(r) = rest.strip_prefix(p) {
            rest = r;
            extra_per_vertex += n;
            dropped.insert(what.to_string());
        }
    }
    if !rest.is_empty() {
        return Err(Error::Unsupported(format!("OFF variant '{kw}'")));
    }
    Ok(extra_per_vertex)
}

/// One face line (`k v1 .. vk [colour]`), its vertices (below `nv`) into `face`.
fn read_face(
    l: &str,
    n: usize,
    nv: usize,
    face: &mut Vec<u32>,
    dropped: &mut BTreeSet<String>,
) -> Result<()> {
    let mut t = l.split_ascii_whitespace();
    let k: usize = t
        .next()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| syntax("OFF", n, "bad face corner count"))?;
    if k < 3 {
        return Err(syntax(
            "OFF",
            n,
            format!("face has {k} corners; faces need at least 3"),
        ));
    }
    face.clear();
    for _ in 0..k {
        let idx: u32 = t
            .next()
            .and_then(|s| s.parse().ok())
            .filter(|&x: &u32| (x as usize) < nv)
            .ok_or_else(|| {
                syntax(
                    "OFF",
                    n,
                    format!("face needs {k} vertex indices below {nv}"),
                )
            })?;
        face.push(idx);
    }
    if t.next().is_some() {
        dropped.insert("face colors".to_string());
    }
    Ok(())
}

pub(crate) fn write<W: Write>(out: &mut W, mesh: &Mesh, q: &Quantization) -> Result<()> {
    writeln!(out, "OFF")?;
    writeln!(out, "{} {} 0", mesh.vertex_count(), mesh.face_count())?;
    write_counted_text(out, mesh, q)
}

/// Walks an OFF file for its template (SPEC.md 11): the first three numbers of every
/// vertex line and the indices of every face line are the coded values.
pub(super) fn template(bytes: &[u8], b: &mut Builder<'_>) -> Option<()> {
    // Statements seen: the keyword, the counts, then vertices and faces.
    let (mut seen, mut counts_at, mut nv) = (0usize, None, 0usize);
    for line in super::lines_with_ends(bytes) {
        let code = &line[..line.iter().position(|&c| c == b'#').unwrap_or(line.len())];
        let toks: Vec<(usize, usize)> = super::obj::tokens(code).collect();
        if toks.is_empty() {
            b.literal(line);
            continue;
        }
        let stmt = seen;
        seen += 1;
        if stmt == 0 {
            // The keyword, with the counts on the same line or the next.
            counts_at = Some(if toks.len() > 1 { 0 } else { 1 });
        }
        let counts_stmt = counts_at?;
        if stmt == counts_stmt {
            let first = if stmt == 0 { 1 } else { 0 };
            let (s, e) = *toks.get(first)?;
            nv = std::str::from_utf8(&line[s..e]).ok()?.parse().ok()?;
        }
        let mut at = 0;
        if stmt > counts_stmt && stmt <= counts_stmt + nv {
            for &(s, e) in toks.iter().take(3) {
                b.literal(&line[at..s]);
                b.coord_text(&line[s..e]);
                at = e;
            }
        } else if stmt > counts_stmt + nv {
            let k: usize = std::str::from_utf8(&line[toks[0].0..toks[0].1])
                .ok()?
                .parse()
                .ok()?;
            for &(s, e) in toks.iter().skip(1).take(k) {
                b.literal(&line[at..s]);
                b.index_text(&line[s..e], 0);
                at = e;
            }
        }
        b.literal(&line[at..]);
    }
    Some(())
}

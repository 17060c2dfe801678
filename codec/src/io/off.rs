//! Object File Format, ASCII: `[ST][C][N]OFF`, counts, vertices, faces.

use std::collections::BTreeSet;
use std::io::Write;

use super::template::Builder;
use super::{syntax, write_counted_text, Format, RawMesh};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::quant::{Quantization, TextCoords};

/// An OFF body's statements: lines without comments, blank ones skipped, with their
/// 1-based numbers. A record (the counts, a vertex, a face) is one line, or several
/// where a line holds fewer values than the record needs (libigl writes faces so).
struct Records<'a, I: Iterator<Item = (usize, &'a str)>> {
    lines: I,
}

impl<'a, I: Iterator<Item = (usize, &'a str)>> Records<'a, I> {
    /// The next record of at least `need` values (the first one's count read by
    /// `need_of`, when given): its tokens and its first line's number; `None` at the end.
    fn next(
        &mut self,
        need: usize,
        need_of: Option<fn(&str) -> usize>,
        tokens: &mut Vec<&'a str>,
    ) -> Option<usize> {
        tokens.clear();
        let (n, l) = self.lines.next()?;
        tokens.extend(l.split_ascii_whitespace());
        loop {
            let want = match (need_of, tokens.first()) {
                (Some(f), Some(t)) => 1 + f(t),
                _ => need,
            };
            if tokens.len() >= want {
                return Some(n);
            }
            match self.lines.next() {
                Some((_, l)) => tokens.extend(l.split_ascii_whitespace()),
                None => return Some(n),
            }
        }
    }
}

pub(crate) fn read(bytes: &[u8]) -> Result<RawMesh> {
    let text = std::str::from_utf8(bytes).map_err(|_| {
        Error::MeshFile("OFF file is not UTF-8 text (binary OFF is not supported)".into())
    })?;
    // Statements, with comments and blank lines removed, keeping line numbers.
    let mut records = Records {
        lines: text
            .lines()
            .enumerate()
            .map(|(n, l)| (n + 1, l.split('#').next().unwrap_or("").trim()))
            .filter(|(_, l)| !l.is_empty()),
    };
    let mut toks = Vec::new();
    let ln = records
        .next(1, None, &mut toks)
        .ok_or_else(|| Error::MeshFile("OFF file is empty".into()))?;
    let mut dropped = BTreeSet::new();
    // The keyword, with the counts after it on its line, or glued to it (`OFF8 6 12`).
    let (kw, glued) = split_keyword(toks[0]);
    let extra_per_vertex = keyword(kw, ln, &mut dropped)?;
    let mut header: Vec<&str> = glued.into_iter().chain(toks[1..].iter().copied()).collect();
    if header.first() == Some(&"BINARY") {
        return Err(Error::Unsupported("binary OFF".into()));
    }
    let mut count_line = ln;
    if header.is_empty() {
        count_line = records
            .next(2, None, &mut toks)
            .ok_or_else(|| syntax("OFF", ln, "missing the vertex and face counts"))?;
        header = toks.clone();
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
        let n = records
            .next(3, None, &mut toks)
            .ok_or_else(|| Error::MeshFile(format!("OFF file ends after {i} of {nv} vertices")))?;
        if toks.len() < 3 {
            let k = toks.len();
            return Err(syntax(
                "OFF",
                n,
                format!("vertex has {k} coordinates, needs 3"),
            ));
        }
        coords
            .push([toks[0], toks[1], toks[2]])
            .map_err(|e| syntax("OFF", n, e))?;
        if toks.len() > 3 && extra_per_vertex == 0 {
            dropped.insert("per-vertex extra values".to_string());
        }
    }
    let mut topo = Mesh::new();
    let mut face = Vec::new();
    // A face's corner count; a bad one is reported by read_face.
    let corners: fn(&str) -> usize = |t| t.parse::<usize>().unwrap_or(0);
    for i in 0..nf {
        let n = records
            .next(1, Some(corners), &mut toks)
            .ok_or_else(|| Error::MeshFile(format!("OFF file ends after {i} of {nf} faces")))?;
        read_face(&toks, n, nv, &mut face, &mut dropped)?;
        topo.push_face(&face);
    }
    let (coords, inexact) = coords.finish();
    Ok(RawMesh {
        attributes: Vec::new(),
        coords,
        topology: topo,
        format: Format::Off,
        dropped,
        inexact,
    })
}

/// A first token split into the keyword and, where the counts follow it without a
/// space (`OFF8`), the first count.
fn split_keyword(t: &str) -> (&str, Option<&str>) {
    match t.find("OFF") {
        Some(i) if i + 3 < t.len() && t.as_bytes()[i + 3].is_ascii_digit() => {
            (&t[..i + 3], Some(&t[i + 3..]))
        }
        _ => (t, None),
    }
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

/// One face record (`k v1 .. vk [colour]`), its vertices (below `nv`) into `face`.
fn read_face(
    toks: &[&str],
    n: usize,
    nv: usize,
    face: &mut Vec<u32>,
    dropped: &mut BTreeSet<String>,
) -> Result<()> {
    let mut t = toks.iter();
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

//! Zero-level coding: a mesh without subdivision structure, as connectivity plus
//! predicted positions in one entropy-coded stream (SPEC.md 6).

use std::collections::HashMap;

use crate::entropy::{class_of, AdaptiveModel, Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::topology::gates::{Gates, CANDIDATES};
use crate::topology::PairMap;

const SECTION: &str = "BASE";
/// Recently used vertices a corner can name by position (SPEC.md 6.2).
const MRU: usize = 32;
/// Corner symbols: 0 = next new vertex, 1..=32 = recently used, 33 = escape.
const CORNER_SYMBOLS: usize = MRU + 2;
const ESCAPE: usize = MRU + 1;
/// Degree symbols: d - 3 for d in 3..=17, 15 = larger (escape).
const DEGREE_SYMBOLS: usize = 16;

/// Renumbers vertices by first use in the face list; unreferenced vertices follow in
/// their original order. Returns `order[new] = old`.
pub fn canonical_order(mesh: &Mesh) -> Vec<u32> {
    let n = mesh.vertex_count();
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    for &v in &mesh.faces {
        if !seen[v as usize] {
            seen[v as usize] = true;
            order.push(v);
        }
    }
    order.extend((0..n as u32).filter(|&v| !seen[v as usize]));
    order
}

/// Applies `order[new] = old` to a mesh.
pub fn permute(mesh: &Mesh, order: &[u32]) -> Mesh {
    let mut inv = vec![0u32; order.len()];
    for (new, &old) in order.iter().enumerate() {
        inv[old as usize] = new as u32;
    }
    Mesh {
        positions: order.iter().map(|&o| mesh.positions[o as usize]).collect(),
        face_starts: mesh.face_starts.clone(),
        faces: mesh.faces.iter().map(|&v| inv[v as usize]).collect(),
        floats: Vec::new(),
        attributes: Vec::new(),
    }
}

/// Format 5 on, encoder only: faces in breadth-first order over shared edges (each
/// component from its first face in input order; neighbours in order of edge, then face
/// number), so that a face's neighbours are coded near it whatever the input's order.
/// Returns `order[new] = old`.
pub fn face_order(mesh: &Mesh) -> Vec<u32> {
    let nf = mesh.face_count();
    let mut entries: Vec<(u64, u32)> = Vec::with_capacity(mesh.corner_count());
    for f in 0..nf {
        let face = mesh.face(f);
        let k = face.len();
        for i in 0..k {
            let (a, b) = (face[i], face[(i + 1) % k]);
            entries.push(((a.min(b) as u64) << 32 | a.max(b) as u64, f as u32));
        }
    }
    entries.sort_unstable();
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    let mut i = 0;
    while i < entries.len() {
        let mut j = i + 1;
        while j < entries.len() && entries[j].0 == entries[i].0 {
            j += 1;
        }
        for x in i..j {
            for y in i..j {
                if entries[x].1 != entries[y].1 {
                    pairs.push((entries[x].1, entries[y].1));
                }
            }
        }
        i = j;
    }
    let mut starts = vec![0u32; nf + 1];
    for &(a, _) in &pairs {
        starts[a as usize + 1] += 1;
    }
    for f in 0..nf {
        starts[f + 1] += starts[f];
    }
    let mut fill = starts.clone();
    let mut adj = vec![0u32; pairs.len()];
    for &(a, b) in &pairs {
        adj[fill[a as usize] as usize] = b;
        fill[a as usize] += 1;
    }
    let mut seen = vec![false; nf];
    let mut order = Vec::with_capacity(nf);
    let mut queue = std::collections::VecDeque::new();
    for root in 0..nf {
        if seen[root] {
            continue;
        }
        seen[root] = true;
        queue.push_back(root as u32);
        while let Some(f) = queue.pop_front() {
            order.push(f);
            for &g in &adj[starts[f as usize] as usize..starts[f as usize + 1] as usize] {
                if !seen[g as usize] {
                    seen[g as usize] = true;
                    queue.push_back(g);
                }
            }
        }
    }
    order
}

/// Reorders faces, `order[new] = old`, and starts new face `i` at its corner `rot[i]`.
pub fn permute_faces_rotated(mesh: &Mesh, order: &[u32], rot: &[u32]) -> Mesh {
    let mut out = Mesh::new();
    out.positions = mesh.positions.clone();
    out.faces.reserve(mesh.corner_count());
    let mut buf = Vec::new();
    for (&f, &r) in order.iter().zip(rot) {
        let face = mesh.face(f as usize);
        buf.clear();
        buf.extend((0..face.len()).map(|i| face[(r as usize + i) % face.len()]));
        out.push_face(&buf);
    }
    out
}

struct Mru {
    items: [u32; MRU],
    len: usize,
}

impl Mru {
    fn new() -> Self {
        Mru {
            items: [0; MRU],
            len: 0,
        }
    }

    fn find(&self, v: u32) -> Option<usize> {
        self.items[..self.len].iter().position(|&x| x == v)
    }

    /// Moves `v`, found at `at` (or new), to the front.
    fn touch(&mut self, v: u32, at: Option<usize>) {
        let end = match at {
            Some(i) => i,
            None => {
                if self.len < MRU {
                    self.len += 1;
                }
                self.len - 1
            }
        };
        self.items.copy_within(0..end, 1);
        self.items[0] = v;
    }
}

struct ConnModels {
    degree: Vec<AdaptiveModel>,
    big_degree: IntModel,
    corner: [AdaptiveModel; 2],
    distance: IntModel,
}

impl ConnModels {
    fn new() -> Self {
        ConnModels {
            degree: (0..DEGREE_SYMBOLS)
                .map(|_| AdaptiveModel::new(DEGREE_SYMBOLS))
                .collect(),
            big_degree: IntModel::new(),
            corner: [
                AdaptiveModel::new(CORNER_SYMBOLS),
                AdaptiveModel::new(CORNER_SYMBOLS),
            ],
            distance: IntModel::new(),
        }
    }
}

/// Prediction kinds, each with its own residual models (SPEC.md 6.3).
const KINDS: usize = 5;

struct PosModels {
    res: Vec<IntModel>,
}

impl PosModels {
    fn new() -> Self {
        PosModels {
            res: (0..KINDS * 3 * 3).map(|_| IntModel::new()).collect(),
        }
    }

    fn ctx(kind: usize, axis: usize, prev_class: usize) -> usize {
        let bin = match prev_class {
            0..=2 => 0,
            3..=6 => 1,
            _ => 2,
        };
        (kind * 3 + axis) * 3 + if axis == 0 { 0 } else { bin }
    }
}

/// Per vertex: the face where it first occurs and the corner there (`u32::MAX` for
/// unreferenced vertices).
fn first_uses(mesh: &Mesh) -> Vec<(u32, u32)> {
    first_uses_n(mesh, mesh.vertex_count())
}

/// For every edge: the (up to two) first faces, in face order, that list it; with
/// `triangles_only` only triangles are listed (the triangle edge table of SPEC.md 6.3),
/// else faces of any degree (the edge table of format 5).
fn edge_table(mesh: &Mesh, triangles_only: bool) -> HashMap<(u32, u32), [u32; 2]> {
    let mut map: HashMap<(u32, u32), [u32; 2]> = HashMap::new();
    for f in 0..mesh.face_count() {
        let face = mesh.face(f);
        let k = face.len();
        if triangles_only && k != 3 {
            continue;
        }
        for i in 0..k {
            let (a, b) = (face[i], face[(i + 1) % k]);
            let e = map.entry((a.min(b), a.max(b))).or_insert([u32::MAX; 2]);
            if e[0] == u32::MAX {
                e[0] = f as u32;
            } else if e[1] == u32::MAX {
                e[1] = f as u32;
            }
        }
    }
    map
}

/// Format 5 "strip" prediction for quad corner `v` whose known neighbour `s` and the
/// known corner `o` opposite `v` form an edge shared with an earlier face g: continue g
/// across `s`, `P = 2 s - p` with p the neighbour of s in g that is not o.
fn strip(
    mesh: &Mesh,
    pos: &[[i64; 3]],
    v: usize,
    f: u32,
    s: u32,
    o: u32,
    all: &HashMap<(u32, u32), [u32; 2]>,
) -> Option<[i64; 3]> {
    let faces = all.get(&(s.min(o), s.max(o)))?;
    for &g in faces {
        if g == u32::MAX || g == f {
            continue;
        }
        let gf = mesh.face(g as usize);
        let k = gf.len();
        let i = gf.iter().position(|&x| x == s)?;
        let (prev, next) = (gf[(i + k - 1) % k], gf[(i + 1) % k]);
        let p = if prev == o { next } else { prev };
        if p != o && (p as usize) < v {
            let (ps, pp) = (pos[s as usize], pos[p as usize]);
            return Some([0, 1, 2].map(|d| 2 * ps[d] - pp[d]));
        }
    }
    None
}

/// Predicts vertex `v` from vertices `< v` only (SPEC.md 6.3). Returns (kind, prediction).
fn predict(
    mesh: &Mesh,
    pos: &[[i64; 3]],
    v: usize,
    first: (u32, u32),
    tri: &HashMap<(u32, u32), [u32; 2]>,
    all: &HashMap<(u32, u32), [u32; 2]>,
) -> (usize, [i64; 3]) {
    let fallback = if v > 0 { pos[v - 1] } else { [0; 3] };
    if first.0 == u32::MAX {
        return (3, fallback);
    }
    let face = mesh.face(first.0 as usize);
    let n = face.len();
    let c = first.1 as usize;
    let known = |u: u32| (u as usize) < v;
    let at = |k: usize| face[(c + k) % n];
    if n == 4 && known(at(1)) && known(at(2)) && known(at(3)) {
        let (a, b, o) = (
            pos[at(3) as usize],
            pos[at(1) as usize],
            pos[at(2) as usize],
        );
        return (0, [0, 1, 2].map(|k| a[k] + b[k] - o[k]));
    }
    if n == 4 {
        let p = if known(at(1)) && known(at(2)) && !known(at(3)) {
            strip(mesh, pos, v, first.0, at(1), at(2), all)
        } else if known(at(3)) && known(at(2)) && !known(at(1)) {
            strip(mesh, pos, v, first.0, at(3), at(2), all)
        } else {
            None
        };
        if let Some(p) = p {
            return (4, p);
        }
    }
    if n == 3 && known(at(1)) && known(at(2)) {
        let (a, b) = (at(1), at(2));
        if let Some(faces) = tri.get(&(a.min(b), a.max(b))) {
            for &g in faces {
                if g == u32::MAX || g == first.0 {
                    continue;
                }
                if let Some(&x) = mesh.face(g as usize).iter().find(|&&x| x != a && x != b) {
                    if known(x) {
                        let (pa, pb, px) = (pos[a as usize], pos[b as usize], pos[x as usize]);
                        return (1, [0, 1, 2].map(|k| pa[k] + pb[k] - px[k]));
                    }
                }
            }
        }
    }
    let mut sum = [0i64; 3];
    let mut cnt = 0i64;
    for &u in face {
        if known(u) {
            for k in 0..3 {
                sum[k] += pos[u as usize][k];
            }
            cnt += 1;
        }
    }
    if cnt > 0 {
        return (2, sum.map(|s| s.div_euclid(cnt)));
    }
    (3, fallback)
}

/// Codes a mesh already in canonical order (see [`canonical_order`]).
pub fn encode(mesh: &Mesh) -> Vec<u8> {
    let mut e = Encoder::new();
    encode_gated(&mut e, mesh);
    encode_positions(&mut e, mesh);
    e.finish()
}

fn encode_positions(e: &mut Encoder, mesh: &Mesh) {
    let first = first_uses(mesh);
    let tri = edge_table(mesh, true);
    let all = edge_table(mesh, false);
    let mut m = PosModels::new();
    for v in 0..mesh.vertex_count() {
        let (kind, p) = predict(mesh, &mesh.positions, v, first[v], &tri, &all);
        let mut prev_class = 0;
        for k in 0..3 {
            let r = mesh.positions[v][k] - p[k];
            e.int(&mut m.res[PosModels::ctx(kind, k, prev_class)], r);
            prev_class = class_of(r);
        }
    }
}

/// Decodes `vertices` vertices and `faces` faces with `corners` corners in all; the
/// counts were checked against the limits when the header was read.
/// Decoded coordinates must satisfy `|x| <= max_abs`.
pub fn decode(
    payload: &[u8],
    vertices: u64,
    faces: u64,
    corners: u64,
    max_abs: i64,
) -> Result<Mesh> {
    // Density bounds (SPEC.md 2.6): no conforming stream carries more per byte.
    let room = payload.len() as u64 + 8;
    if vertices > 2048 * room || faces > 32768 * room || corners > 131072 * room {
        return Err(Error::corrupt(
            SECTION,
            format!(
                "{} bytes cannot hold {vertices} vertices and {faces} faces",
                payload.len()
            ),
        ));
    }
    let mut d = Decoder::new(payload, SECTION)?;
    let mut mesh = decode_faces(&mut d, vertices, faces, corners)?;
    mesh.positions = decode_positions(&mut d, &mesh, vertices as usize, max_abs)?;
    Ok(mesh)
}

fn decode_positions(d: &mut Decoder, topo: &Mesh, n: usize, max_abs: i64) -> Result<Vec<[i64; 3]>> {
    let first = first_uses_n(topo, n);
    let tri = edge_table(topo, true);
    let all = edge_table(topo, false);
    let mut m = PosModels::new();
    let mut pos: Vec<[i64; 3]> = Vec::with_capacity(n.min(1 << 16));
    for v in 0..n {
        let (kind, p) = predict(topo, &pos, v, first[v], &tri, &all);
        let mut q = [0i64; 3];
        let mut prev_class = 0;
        for k in 0..3 {
            let r = d.int(&mut m.res[PosModels::ctx(kind, k, prev_class)])?;
            prev_class = class_of(r);
            q[k] = p[k]
                .checked_add(r)
                .filter(|x| x.abs() <= max_abs)
                .ok_or_else(|| Error::corrupt(SECTION, "coordinate out of range"))?;
        }
        pos.push(q);
    }
    Ok(pos)
}

fn first_uses_n(topo: &Mesh, n: usize) -> Vec<(u32, u32)> {
    let mut first = vec![(u32::MAX, 0u32); n];
    for f in 0..topo.face_count() {
        for (c, &v) in topo.face(f).iter().enumerate() {
            if let Some(slot) = first.get_mut(v as usize) {
                if slot.0 == u32::MAX {
                    *slot = (f as u32, c as u32);
                }
            }
        }
    }
    first
}

// Connectivity by gates (SPEC.md 6.2): faces attach to an open half-edge of the faces
// decoded so far, taken first in, first out; their further corners are mostly a new
// vertex or a vertex of the border next to them.
/// Gated corner symbols: 0 = next new vertex, 1..=4 = candidate, 5 = named as a fresh corner.
const GATED_SYMBOLS: usize = CANDIDATES + 2;
const NAMED: usize = CANDIDATES + 1;
/// Gate operations: attach a face across the gate, drop the gate (a border), or code a
/// face without a gate.
const OP_ATTACH: usize = 0;
const OP_DROP: usize = 1;
const OP_FRESH: usize = 2;

fn degree_symbol(d: usize) -> usize {
    (d - 3).min(DEGREE_SYMBOLS - 1)
}

/// The models of gated connectivity.
struct GatedModels {
    op: AdaptiveModel,
    /// Degree of a gated face; context: the degree symbol of the gate's face.
    degree: Vec<AdaptiveModel>,
    /// Context: last corner or not, times the number of candidates (0, 1, 2 or more).
    corner: Vec<AdaptiveModel>,
}

impl GatedModels {
    fn new() -> Self {
        GatedModels {
            op: AdaptiveModel::new(3),
            degree: (0..DEGREE_SYMBOLS)
                .map(|_| AdaptiveModel::new(DEGREE_SYMBOLS))
                .collect(),
            corner: (0..6).map(|_| AdaptiveModel::new(GATED_SYMBOLS)).collect(),
        }
    }
}

/// A corner named outright (SPEC.md 6.2): the next new vertex, a recently used one, or
/// a distance back from the next new one.
fn put_named(
    e: &mut Encoder,
    m: &mut ConnModels,
    model: usize,
    v: u32,
    at: Option<usize>,
    next_new: &mut u32,
) {
    let model = &mut m.corner[model];
    if v == *next_new {
        e.symbol(model, 0);
        *next_new += 1;
    } else if let Some(i) = at {
        e.symbol(model, 1 + i);
    } else {
        e.symbol(model, ESCAPE);
        e.int(&mut m.distance, (*next_new - 1 - v) as i64);
    }
}

fn encode_gated(e: &mut Encoder, mesh: &Mesh) {
    let mut m = ConnModels::new();
    let mut g = GatedModels::new();
    let mut all = PairMap::with_capacity(mesh.corner_count());
    for face in mesh.iter_faces() {
        let k = face.len();
        for i in 0..k {
            all.insert(face[i], face[(i + 1) % k], 0);
        }
    }
    let mut gates = Gates::new();
    let mut mru = Mru::new();
    let mut next_new = 0u32;
    let mut prev_deg = 0usize;
    for face in mesh.iter_faces() {
        let d = face.len();
        let sym = degree_symbol(d);
        let mut gated = None;
        while let Some((u, v, gd)) = gates.gate() {
            if face[0] == v && face[1] == u {
                e.symbol(&mut g.op, OP_ATTACH);
                gated = Some(gd);
                break;
            }
            if all.get(v, u).is_none() {
                e.symbol(&mut g.op, OP_DROP);
                gates.pop();
                continue;
            }
            e.symbol(&mut g.op, OP_FRESH);
            break;
        }
        match gated {
            Some(gd) => e.symbol(&mut g.degree[degree_symbol(gd)], sym),
            None => e.symbol(&mut m.degree[prev_deg], sym),
        }
        if sym == DEGREE_SYMBOLS - 1 {
            e.int(&mut m.big_degree, (d - 3 - (DEGREE_SYMBOLS - 1)) as i64);
        }
        prev_deg = sym;
        for (c, &v) in face.iter().enumerate() {
            let at = mru.find(v);
            match (gated, c) {
                (Some(_), 0 | 1) => {}
                (Some(_), _) => {
                    let last = c == d - 1;
                    let (cands, n) = gates.candidates(face[c - 1], face[0], last);
                    let ctx = last as usize * 3 + n.min(2);
                    if v == next_new {
                        e.symbol(&mut g.corner[ctx], 0);
                        next_new += 1;
                    } else if let Some(i) = cands[..n].iter().position(|&x| x == v) {
                        e.symbol(&mut g.corner[ctx], 1 + i);
                    } else {
                        e.symbol(&mut g.corner[ctx], NAMED);
                        put_named(e, &mut m, 1, v, at, &mut next_new);
                    }
                }
                (None, _) => put_named(e, &mut m, (c > 0) as usize, v, at, &mut next_new),
            }
            mru.touch(v, at);
        }
        gates.add(face);
    }
}

/// Reads a corner named outright (see [`put_named`]); returns the vertex and
/// its place in the recent list.
fn get_named(
    d: &mut Decoder,
    m: &mut ConnModels,
    model: usize,
    mru: &Mru,
    next_new: &mut u64,
    vertices: u64,
) -> Result<(u32, Option<usize>)> {
    let s = d.symbol(&mut m.corner[model])?;
    if s == 0 {
        new_vertex(next_new, vertices)
    } else if s <= MRU {
        if s > mru.len {
            return Err(Error::corrupt(
                SECTION,
                "reference to an empty history slot",
            ));
        }
        Ok((mru.items[s - 1], Some(s - 1)))
    } else {
        let dist = d.int(&mut m.distance)?;
        if dist < 0 || dist as u64 >= *next_new {
            return Err(Error::corrupt(SECTION, "vertex reference out of range"));
        }
        let v = (*next_new - 1 - dist as u64) as u32;
        Ok((v, mru.find(v)))
    }
}

fn new_vertex(next_new: &mut u64, vertices: u64) -> Result<(u32, Option<usize>)> {
    if *next_new >= vertices {
        return Err(Error::corrupt(
            SECTION,
            "more vertices than the header says",
        ));
    }
    *next_new += 1;
    Ok(((*next_new - 1) as u32, None))
}

/// Decodes the connectivity (SPEC.md 6.2) of `faces` faces with `corners` corners over
/// `vertices` vertices.
fn decode_faces(d: &mut Decoder, vertices: u64, faces: u64, corners: u64) -> Result<Mesh> {
    let mut m = ConnModels::new();
    let (mut gm, mut gates) = (GatedModels::new(), Gates::new());
    let mut mru = Mru::new();
    let mut next_new = 0u64;
    let mut prev_deg = 0usize;
    let mut mesh = Mesh::new();
    let mut face: Vec<u32> = Vec::new();
    // Corners decoded so far, face by face.
    let mut total = 0u64;
    for _ in 0..faces {
        let mut gated = None;
        while let Some((u, v, gd)) = gates.gate() {
            match d.symbol(&mut gm.op)? {
                OP_ATTACH => {
                    gated = Some((u, v, gd));
                    break;
                }
                OP_DROP => {
                    gates.pop();
                }
                _ => break,
            }
        }
        let sym = match gated {
            Some((_, _, gd)) => d.symbol(&mut gm.degree[degree_symbol(gd)])?,
            None => d.symbol(&mut m.degree[prev_deg])?,
        };
        let mut deg = sym as u64 + 3;
        if sym == DEGREE_SYMBOLS - 1 {
            let extra = d.int(&mut m.big_degree)?;
            if extra < 0 {
                return Err(Error::corrupt(SECTION, "negative face degree"));
            }
            deg = deg.saturating_add(extra as u64);
        }
        prev_deg = sym;
        total = total.saturating_add(deg);
        if total > corners {
            return Err(Error::corrupt(
                SECTION,
                "faces have more corners than the header says",
            ));
        }
        face.clear();
        for c in 0..deg as usize {
            let (v, at) = match gated {
                Some((u, v, _)) if c < 2 => {
                    let x = if c == 0 { v } else { u };
                    (x, mru.find(x))
                }
                Some(_) => {
                    let last = c as u64 == deg - 1;
                    let (cands, n) = gates.candidates(face[c - 1], face[0], last);
                    let ctx = last as usize * 3 + n.min(2);
                    match d.symbol(&mut gm.corner[ctx])? {
                        0 => new_vertex(&mut next_new, vertices)?,
                        NAMED => get_named(d, &mut m, 1, &mru, &mut next_new, vertices)?,
                        s if s <= n => (cands[s - 1], mru.find(cands[s - 1])),
                        _ => {
                            return Err(Error::corrupt(
                                SECTION,
                                "reference to a missing border vertex",
                            ))
                        }
                    }
                }
                _ => get_named(d, &mut m, (c > 0) as usize, &mru, &mut next_new, vertices)?,
            };
            mru.touch(v, at);
            face.push(v);
        }
        // The faces are kept in the gates' record (taken over below).
        gates.add(&face);
    }
    mesh.faces = gates.corners;
    mesh.face_starts = gates.starts;
    if mesh.faces.len() as u64 != corners {
        return Err(Error::corrupt(
            SECTION,
            "faces have fewer corners than the header says",
        ));
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::gates::gate_order;

    /// An n x n grid of quads (with every third one split into two triangles when
    /// `mixed`), positions on a gentle bump, vertices in row order.
    fn grid(n: u32, mixed: bool) -> Mesh {
        let mut m = Mesh::new();
        for y in 0..=n as i64 {
            for x in 0..=n as i64 {
                m.positions.push([x * 100, y * 100, (x * y) % 7]);
            }
        }
        let id = |x: u32, y: u32| y * (n + 1) + x;
        for y in 0..n {
            for x in 0..n {
                let (a, b, c, d) = (id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1));
                if mixed && (x + y) % 3 == 0 {
                    m.push_face(&[a, b, c]);
                    m.push_face(&[a, c, d]);
                } else {
                    m.push_face(&[a, b, c, d]);
                }
            }
        }
        m
    }

    /// Canonical order as the encoder prepares a flat mesh: faces as `forder` / `rot`
    /// say, vertices by first use.
    fn prepared(mesh: &Mesh, forder: &[u32], rot: &[u32]) -> Mesh {
        let by_faces = permute_faces_rotated(mesh, forder, rot);
        let order = canonical_order(&by_faces);
        permute(&by_faces, &order)
    }

    fn round_trip(mesh: &Mesh) -> usize {
        let bytes = encode(mesh);
        let back = decode(
            &bytes,
            mesh.vertex_count() as u64,
            mesh.face_count() as u64,
            mesh.corner_count() as u64,
            1 << 40,
        )
        .expect("own output decodes");
        assert_eq!(&back, mesh, "round trip differs");
        bytes.len()
    }

    #[test]
    fn gates_code_a_regular_mesh_in_a_fraction_of_the_bytes() {
        // At most bits per face, quads and mixed (outright named corners cost over three
        // times as much: measured before the format kept only gates).
        for (mixed, most) in [(false, 2.0), (true, 4.5)] {
            let mesh = grid(24, mixed);
            let (forder, rot) = gate_order(&mesh.face_starts, &mesh.faces);
            let gated = prepared(&mesh, &forder, &rot);
            // Connectivity alone: the same faces with every position zero.
            let mut topo = gated.clone();
            topo.positions.iter_mut().for_each(|p| *p = [0; 3]);
            let with_gates = round_trip(&topo);
            // Every face after the first attaches to a gate and names its other corners
            // among the border's: a few bits per face.
            let bits_per_face = with_gates as f64 * 8.0 / topo.face_count() as f64;
            assert!(bits_per_face < most, "mixed {mixed}: {bits_per_face}");
            // Positions too.
            round_trip(&gated);
        }
    }

    #[test]
    fn any_face_order_and_odd_faces_round_trip_with_gates() {
        let mut mesh = grid(6, true);
        // Faces reversed, rotated, one with a repeated corner, one flipped, a duplicate.
        let nf = mesh.face_count() as u32;
        let forder: Vec<u32> = (0..nf).rev().collect();
        let rot: Vec<u32> = (0..nf).map(|f| f % 3).collect();
        mesh = permute_faces_rotated(&mesh, &forder, &rot);
        mesh.push_face(&[3, 3, 9]);
        mesh.push_face(&[10, 9, 2]);
        mesh.push_face(&[0, 1, 8, 7]);
        mesh.push_face(&[0, 1, 8, 7]);
        let order = canonical_order(&mesh);
        let mesh = permute(&mesh, &order);
        round_trip(&mesh);
        // And in the gates' own order.
        let (forder, rot) = gate_order(&mesh.face_starts, &mesh.faces);
        round_trip(&prepared(&mesh, &forder, &rot));
    }

    /// Gated faces can cost very little, so the density bound admits up to 32768 faces
    /// per byte (n + 8) before refusing a section as too dense (SPEC.md 2.6).
    #[test]
    fn density_bounds_admit_gated_faces_only() {
        let payload = [0u8; 8];
        let faces = 4096 * 16 + 1;
        let e = decode(&payload, 3, faces, 3 * faces, 1 << 40)
            .expect_err("no mesh in 8 zero bytes")
            .to_string();
        assert!(!e.contains("cannot hold"), "{e}");
        let too_many = 32768 * 16 + 1;
        assert!(decode(&payload, 3, too_many, 3 * too_many, 1 << 40)
            .expect_err("too dense")
            .to_string()
            .contains("cannot hold"));
    }

    #[test]
    fn gate_order_visits_every_face_once_and_keeps_each_face() {
        let mesh = grid(9, true);
        let (forder, rot) = gate_order(&mesh.face_starts, &mesh.faces);
        let mut seen = forder.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..mesh.face_count() as u32).collect::<Vec<_>>());
        let out = permute_faces_rotated(&mesh, &forder, &rot);
        for (i, &f) in forder.iter().enumerate() {
            let (a, b) = (mesh.face(f as usize), out.face(i));
            let r = rot[i] as usize;
            assert!(r < a.len());
            assert!((0..a.len()).all(|k| b[k] == a[(k + r) % a.len()]));
        }
        // After the first face, every face of this connected mesh attaches to a gate:
        // its first two corners are a coded half-edge, reversed.
        let mut half = std::collections::HashSet::new();
        for i in 0..out.face_count() {
            let f = out.face(i);
            if i > 0 {
                assert!(half.contains(&(f[1], f[0])), "face {i} is not gated");
            }
            for k in 0..f.len() {
                half.insert((f[k], f[(k + 1) % f.len()]));
            }
        }
    }
}

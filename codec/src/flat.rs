//! Zero-level coding: a mesh without subdivision structure, as connectivity plus
//! predicted positions in one range-coded stream (SPEC.md 6).

use std::collections::HashMap;

use crate::coder::{class_of, AdaptiveModel, Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use crate::mesh::Mesh;

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

/// Reorders faces: `order[new] = old` (corners and their order unchanged).
pub fn permute_faces(mesh: &Mesh, order: &[u32]) -> Mesh {
    let mut out = Mesh::new();
    out.positions = mesh.positions.clone();
    out.faces.reserve(mesh.corner_count());
    for &f in order {
        out.push_face(mesh.face(f as usize));
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
    fn new(version: u16) -> Self {
        ConnModels {
            degree: (0..DEGREE_SYMBOLS)
                .map(|_| AdaptiveModel::for_version(DEGREE_SYMBOLS, version))
                .collect(),
            big_degree: IntModel::for_version(version),
            corner: [
                AdaptiveModel::for_version(CORNER_SYMBOLS, version),
                AdaptiveModel::for_version(CORNER_SYMBOLS, version),
            ],
            distance: IntModel::for_version(version),
        }
    }
}

/// Prediction kinds, each with its own residual models (SPEC.md 6.3).
const KINDS: usize = 5;

struct PosModels {
    res: Vec<IntModel>,
}

impl PosModels {
    fn new(version: u16) -> Self {
        PosModels {
            res: (0..KINDS * 3 * 3)
                .map(|_| IntModel::for_version(version))
                .collect(),
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
    all: Option<&HashMap<(u32, u32), [u32; 2]>>,
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
    if let (4, Some(all)) = (n, all) {
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

/// Codes a mesh already in canonical order (see [`canonical_order`]) as format
/// `version` defines it.
pub fn encode(mesh: &Mesh, version: u16) -> Vec<u8> {
    let mut e = Encoder::new();
    let mut m = ConnModels::new(version);
    let mut mru = Mru::new();
    let mut next_new = 0u32;
    let mut prev_deg = 0usize;
    for face in mesh.iter_faces() {
        let d = face.len();
        let sym = (d - 3).min(DEGREE_SYMBOLS - 1);
        e.symbol(&mut m.degree[prev_deg], sym);
        if sym == DEGREE_SYMBOLS - 1 {
            e.int(&mut m.big_degree, (d - 3 - (DEGREE_SYMBOLS - 1)) as i64);
        }
        prev_deg = sym;
        for (c, &v) in face.iter().enumerate() {
            let model = &mut m.corner[(c > 0) as usize];
            let at = mru.find(v);
            if v == next_new {
                e.symbol(model, 0);
                next_new += 1;
            } else if let Some(i) = at {
                e.symbol(model, 1 + i);
            } else {
                e.symbol(model, ESCAPE);
                e.int(&mut m.distance, (next_new - 1 - v) as i64);
            }
            mru.touch(v, at);
        }
    }
    encode_positions(&mut e, mesh, version);
    e.finish()
}

fn encode_positions(e: &mut Encoder, mesh: &Mesh, version: u16) {
    let first = first_uses(mesh);
    let tri = edge_table(mesh, true);
    let all = (version >= 5).then(|| edge_table(mesh, false));
    let mut m = PosModels::new(version);
    for v in 0..mesh.vertex_count() {
        let (kind, p) = predict(mesh, &mesh.positions, v, first[v], &tri, all.as_ref());
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
    version: u16,
) -> Result<Mesh> {
    // Density bounds (SPEC.md 2.6): no conforming stream carries more per byte.
    let room = payload.len() as u64 + 8;
    if vertices > 2048 * room || faces > 4096 * room || corners > 16384 * room {
        return Err(Error::corrupt(
            SECTION,
            format!(
                "{} bytes cannot hold {vertices} vertices and {faces} faces",
                payload.len()
            ),
        ));
    }
    let mut d = Decoder::new(payload, SECTION)?;
    let mut m = ConnModels::new(version);
    let mut mru = Mru::new();
    let mut next_new = 0u64;
    let mut prev_deg = 0usize;
    let mut mesh = Mesh::new();
    // Grow with what is decoded rather than trusting the counts up front.
    mesh.face_starts.reserve(faces.min(1 << 16) as usize);
    mesh.faces.reserve(corners.min(1 << 18) as usize);
    for _ in 0..faces {
        let sym = d.symbol(&mut m.degree[prev_deg])?;
        let mut deg = sym as u64 + 3;
        if sym == DEGREE_SYMBOLS - 1 {
            let extra = d.int(&mut m.big_degree)?;
            if extra < 0 {
                return Err(Error::corrupt(SECTION, "negative face degree"));
            }
            deg = deg.saturating_add(extra as u64);
        }
        prev_deg = sym;
        if (mesh.faces.len() as u64).saturating_add(deg) > corners {
            return Err(Error::corrupt(
                SECTION,
                "faces have more corners than the header says",
            ));
        }
        for c in 0..deg {
            let s = d.symbol(&mut m.corner[(c > 0) as usize])?;
            let (v, at) = if s == 0 {
                if next_new >= vertices {
                    return Err(Error::corrupt(
                        SECTION,
                        "more vertices than the header says",
                    ));
                }
                next_new += 1;
                ((next_new - 1) as u32, None)
            } else if s <= MRU {
                if s > mru.len {
                    return Err(Error::corrupt(
                        SECTION,
                        "reference to an empty history slot",
                    ));
                }
                (mru.items[s - 1], Some(s - 1))
            } else {
                let dist = d.int(&mut m.distance)?;
                if dist < 0 || dist as u64 >= next_new {
                    return Err(Error::corrupt(SECTION, "vertex reference out of range"));
                }
                ((next_new - 1 - dist as u64) as u32, None)
            };
            let at = if s == ESCAPE { mru.find(v) } else { at };
            mru.touch(v, at);
            mesh.faces.push(v);
        }
        mesh.face_starts.push(mesh.faces.len() as u32);
    }
    if mesh.faces.len() as u64 != corners {
        return Err(Error::corrupt(
            SECTION,
            "faces have fewer corners than the header says",
        ));
    }
    mesh.positions = decode_positions(&mut d, &mesh, vertices as usize, max_abs, version)?;
    Ok(mesh)
}

fn decode_positions(
    d: &mut Decoder,
    topo: &Mesh,
    n: usize,
    max_abs: i64,
    version: u16,
) -> Result<Vec<[i64; 3]>> {
    let first = first_uses_n(topo, n);
    let tri = edge_table(topo, true);
    let all = (version >= 5).then(|| edge_table(topo, false));
    let mut m = PosModels::new(version);
    let mut pos: Vec<[i64; 3]> = Vec::with_capacity(n.min(1 << 16));
    for v in 0..n {
        let (kind, p) = predict(topo, &pos, v, first[v], &tri, all.as_ref());
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

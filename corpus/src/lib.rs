//! Synthetic meshes for subwave's tests and benchmarks, made here so the project needs
//! no outside data: Catmull-Clark refinements of small polygon base meshes (with
//! triangles, pentagons, boundaries, several components), height grids, and meshes
//! without structure. Floating point is fine here: these only *make* inputs.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// Numeric kernels index several arrays (axes, positions, weights) in lockstep.
#![allow(clippy::needless_range_loop)]

use std::collections::{HashMap, HashSet};
use std::fmt::Write;

/// A polygon mesh with `f64` positions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PolyMesh {
    /// Positions.
    pub positions: Vec<[f64; 3]>,
    /// Faces as vertex index lists.
    pub faces: Vec<Vec<u32>>,
}

/// A tiny deterministic generator (xorshift64*), so meshes are the same everywhere.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// Seeded generator.
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }
}

impl PolyMesh {
    /// One Catmull-Clark step: each k-gon becomes k quads (old vertex, edge point, face
    /// point, edge point). Vertex order: old vertices, then one edge point per edge in
    /// order of first appearance walking the faces, then one face point per face.
    /// Positions follow the Catmull-Clark rules (boundary edges and vertices use the
    /// cubic B-spline curve rules).
    pub fn catmull_clark(&self) -> PolyMesh {
        self.catmull_clark_creased(&Creases::default(), Kept::Nothing)
            .0
    }

    /// One Catmull-Clark step with creases, by OpenSubdiv's rules (uniform creasing):
    /// an edge of sharpness `s >= 1` (boundary edges are infinitely sharp) gets its
    /// midpoint, of `0 < s < 1` the point `s` of the way from the smooth point to it; a
    /// vertex with two sharp edges takes the curve rule along them, one with more or a
    /// vertex sharpness keeps its place, and so do the boundary vertices `kept` names;
    /// where a vertex's rule one level down differs, the two are blended by the mean
    /// sharpness of the vertex and its edges that are sharp at most 1.
    /// Also returns the creases of the result (both halves of each creased edge and
    /// each old vertex one less sharp; 10 is infinite and stays).
    pub fn catmull_clark_creased(&self, creases: &Creases, kept: Kept) -> (PolyMesh, Creases) {
        let nv = self.positions.len();
        let mut edge_id: HashMap<(u32, u32), usize> = HashMap::new();
        let mut edges: Vec<(u32, u32)> = Vec::new();
        let mut edge_faces: Vec<Vec<usize>> = Vec::new();
        for (fi, f) in self.faces.iter().enumerate() {
            for i in 0..f.len() {
                let (a, b) = (f[i], f[(i + 1) % f.len()]);
                let key = (a.min(b), a.max(b));
                let id = *edge_id.entry(key).or_insert_with(|| {
                    edges.push(key);
                    edge_faces.push(Vec::new());
                    edges.len() - 1
                });
                edge_faces[id].push(fi);
            }
        }
        let ne = edges.len();
        let face_pt: Vec<[f64; 3]> = self
            .faces
            .iter()
            .map(|f| mean(f.iter().map(|&v| self.positions[v as usize])))
            .collect();
        let mut pos = vec![[0.0; 3]; nv + ne + self.faces.len()];
        let boundary_edge = |e: usize| edge_faces[e].len() < 2;
        let sharpness = |e: usize| {
            if boundary_edge(e) || kept == Kept::Everything {
                INFINITELY_SHARP
            } else {
                creases.edges.get(&edges[e]).copied().unwrap_or(0.0)
            }
        };
        for (e, &(a, b)) in edges.iter().enumerate() {
            let pa = self.positions[a as usize];
            let pb = self.positions[b as usize];
            let s = sharpness(e);
            let mid = mean([pa, pb].into_iter());
            pos[nv + e] = if s >= 1.0 {
                mid
            } else {
                let smooth = mean(
                    [pa, pb, face_pt[edge_faces[e][0]], face_pt[edge_faces[e][1]]].into_iter(),
                );
                if s > 0.0 {
                    [0, 1, 2].map(|k| s * mid[k] + (1.0 - s) * smooth[k])
                } else {
                    smooth
                }
            };
        }
        // Old vertices.
        let mut v_faces: Vec<Vec<usize>> = vec![Vec::new(); nv];
        for (fi, f) in self.faces.iter().enumerate() {
            for &v in f {
                v_faces[v as usize].push(fi);
            }
        }
        let mut v_edges: Vec<Vec<usize>> = vec![Vec::new(); nv];
        for (e, &(a, b)) in edges.iter().enumerate() {
            v_edges[a as usize].push(e);
            v_edges[b as usize].push(e);
        }
        #[derive(Clone, PartialEq)]
        enum Rule {
            Keep,
            Crease(Vec<usize>),
            Smooth,
        }
        for v in 0..nv {
            let p = self.positions[v];
            let on_boundary = v_edges[v].iter().any(|&e| boundary_edge(e));
            let corner = creases.vertices.get(&(v as u32)).copied().unwrap_or(0.0);
            let rule = |now: &dyn Fn(f64) -> f64| {
                let hard: Vec<usize> = v_edges[v]
                    .iter()
                    .copied()
                    .filter(|&e| now(sharpness(e)) > 0.0)
                    .collect();
                if v_edges[v].is_empty()
                    || kept.keeps(on_boundary, v_faces[v].len())
                    || now(corner) > 0.0
                {
                    Rule::Keep
                } else if on_boundary || hard.len() >= 2 {
                    if hard.len() == 2 {
                        Rule::Crease(hard)
                    } else {
                        Rule::Keep
                    }
                } else {
                    Rule::Smooth
                }
            };
            let value = |r: &Rule| match r {
                Rule::Keep => p,
                Rule::Crease(hard) => {
                    let mut s = [0.0; 3];
                    for &e in hard {
                        let (a, b) = edges[e];
                        let o = if a as usize == v { b } else { a };
                        for k in 0..3 {
                            s[k] += self.positions[o as usize][k] / 8.0;
                        }
                    }
                    [0, 1, 2].map(|k| p[k] * 0.75 + s[k])
                }
                Rule::Smooth => {
                    let n = v_edges[v].len() as f64;
                    let q = mean(v_faces[v].iter().map(|&f| face_pt[f]));
                    let r = mean(v_edges[v].iter().map(|&e| {
                        let (a, b) = edges[e];
                        mean([self.positions[a as usize], self.positions[b as usize]].into_iter())
                    }));
                    [0, 1, 2].map(|k| (q[k] + 2.0 * r[k] + (n - 3.0) * p[k]) / n)
                }
            };
            let parent = rule(&|s| s);
            let child = rule(&|s| one_less(s));
            pos[v] = if parent == Rule::Smooth || parent == child {
                value(&parent)
            } else {
                let sharp: Vec<f64> = std::iter::once(corner)
                    .chain(v_edges[v].iter().map(|&e| sharpness(e)))
                    .filter(|&s| s > 0.0 && s <= 1.0)
                    .collect();
                if sharp.is_empty() {
                    value(&child)
                } else {
                    let w = (sharp.iter().sum::<f64>() / sharp.len() as f64).min(1.0);
                    let (a, b) = (value(&parent), value(&child));
                    [0, 1, 2].map(|k| w * a[k] + (1.0 - w) * b[k])
                }
            };
        }
        for (fi, fp) in face_pt.iter().enumerate() {
            pos[nv + ne + fi] = *fp;
        }
        let mut faces = Vec::with_capacity(self.faces.len() * 4);
        for (fi, f) in self.faces.iter().enumerate() {
            let k = f.len();
            let e_of = |i: usize| {
                let (a, b) = (f[i], f[(i + 1) % k]);
                (nv + edge_id[&(a.min(b), a.max(b))]) as u32
            };
            let fp = (nv + ne + fi) as u32;
            for i in 0..k {
                faces.push(vec![f[i], e_of(i), fp, e_of((i + k - 1) % k)]);
            }
        }
        let below = Creases {
            edges: creases
                .edges
                .iter()
                .filter(|&(_, &s)| one_less(s) > 0.0)
                .flat_map(|(&(a, b), &s)| {
                    let mid = (nv + edge_id[&(a, b)]) as u32;
                    let s = one_less(s);
                    [((a.min(mid), a.max(mid)), s), ((b.min(mid), b.max(mid)), s)]
                })
                .collect(),
            vertices: creases
                .vertices
                .iter()
                .filter(|&(_, &s)| one_less(s) > 0.0)
                .map(|(&v, &s)| (v, one_less(s)))
                .collect(),
        };
        (
            PolyMesh {
                positions: pos,
                faces,
            },
            below,
        )
    }

    /// The subdivision surface as modelling tools write it: `levels` Catmull-Clark
    /// steps with the infinitely sharp `creases` (vertex pairs of this mesh), then,
    /// when `limit`, every vertex moved to the limit surface: inside, with `n` edges,
    /// `(n^2 v + 4 sum of neighbours + sum of the opposite corners of its quads) /
    /// (n (n + 5))`; on a crease or boundary (two hard edges to `a`, `b`) `(a + 4 v +
    /// b) / 6`; elsewhere kept. A float reference for the codec's integer rules.
    pub fn subdivision_surface(&self, levels: u32, creases: &[[u32; 2]], limit: bool) -> PolyMesh {
        self.subdivision_surface_with(levels, creases, limit, Kept::Nothing)
    }

    /// [`PolyMesh::subdivision_surface`], with the boundary vertices `kept` names kept
    /// where they are (Blender's "Keep Corners", or its UV rule "Keep Boundaries").
    pub fn subdivision_surface_with(
        &self,
        levels: u32,
        creases: &[[u32; 2]],
        limit: bool,
        kept: Kept,
    ) -> PolyMesh {
        let edges: Vec<([u32; 2], f64)> = creases.iter().map(|&e| (e, INFINITELY_SHARP)).collect();
        self.subdivision_surface_sharp(levels, &edges, &[], limit, kept)
    }

    /// [`PolyMesh::subdivision_surface_with`] with semi-sharp creases: `edges` as
    /// vertex pairs with their sharpness (Blender's edge crease `c` is `10 c^2`; 10 is
    /// infinitely sharp), `vertices` with theirs (vertex creases). On the limit, an
    /// edge or vertex with sharpness left after the last step is sharp.
    pub fn subdivision_surface_sharp(
        &self,
        levels: u32,
        edges: &[([u32; 2], f64)],
        vertices: &[(u32, f64)],
        limit: bool,
        kept: Kept,
    ) -> PolyMesh {
        let (mut m, sharp) = self.creased(levels, edges, vertices, kept);
        if limit {
            m.positions = m.limit_positions(&sharp, kept);
        }
        m
    }

    /// `levels` Catmull-Clark steps with the creases `edges` and `vertices` (as
    /// [`PolyMesh::subdivision_surface_sharp`] takes them), and the creases left.
    fn creased(
        &self,
        levels: u32,
        edges: &[([u32; 2], f64)],
        vertices: &[(u32, f64)],
        kept: Kept,
    ) -> (PolyMesh, Creases) {
        let mut sharp = Creases {
            edges: edges
                .iter()
                .map(|&([a, b], s)| ((a.min(b), a.max(b)), s))
                .collect(),
            vertices: vertices.iter().copied().collect(),
        };
        let mut m = self.clone();
        for _ in 0..levels {
            (m, sharp) = m.catmull_clark_creased(&sharp, kept);
        }
        (m, sharp)
    }

    /// [`PolyMesh::subdivision_surface_sharp`] on the limit as OpenSubdiv evaluates it
    /// past its isolation level (Blender's Quality) over fewer levels: `extra` more
    /// steps with the creases, then the limit with a finite sharpness left smooth (an
    /// infinite one sharp); the mesh of `levels` steps, its vertices placed there.
    pub fn subdivision_surface_isolated(
        &self,
        levels: u32,
        extra: u32,
        edges: &[([u32; 2], f64)],
        vertices: &[(u32, f64)],
        kept: Kept,
    ) -> PolyMesh {
        let (mut out, _) = self.creased(levels, edges, vertices, kept);
        let (m, mut sharp) = self.creased(levels + extra, edges, vertices, kept);
        sharp.edges.retain(|_, s| *s >= INFINITELY_SHARP);
        sharp.vertices.retain(|_, s| *s >= INFINITELY_SHARP);
        let placed = m.limit_positions(&sharp, kept);
        let n = out.positions.len();
        out.positions.copy_from_slice(&placed[..n]);
        out
    }

    /// The limit positions of [`PolyMesh::subdivision_surface`].
    fn limit_positions(&self, creases: &Creases, kept: Kept) -> Vec<[f64; 3]> {
        let nv = self.positions.len();
        let mut edge_faces: HashMap<(u32, u32), usize> = HashMap::new();
        let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); nv];
        let mut opposite: Vec<Vec<Option<u32>>> = vec![Vec::new(); nv];
        for f in &self.faces {
            let k = f.len();
            for i in 0..k {
                let (a, b) = (f[i], f[(i + 1) % k]);
                let n = edge_faces.entry((a.min(b), a.max(b))).or_insert(0);
                if *n == 0 {
                    neighbours[a as usize].push(b);
                    neighbours[b as usize].push(a);
                }
                *n += 1;
                opposite[f[i] as usize].push((k == 4).then(|| f[(i + 2) % 4]));
            }
        }
        (0..nv)
            .map(|v| {
                let p = self.positions[v];
                let key = |o: u32| (o.min(v as u32), o.max(v as u32));
                let boundary = neighbours[v].iter().any(|&o| edge_faces[&key(o)] < 2);
                let hard: Vec<u32> = neighbours[v]
                    .iter()
                    .copied()
                    .filter(|&o| edge_faces[&key(o)] < 2 || creases.edges.contains_key(&key(o)))
                    .collect();
                let n = neighbours[v].len();
                if kept.keeps_at_limit(boundary, opposite[v].len())
                    || creases.vertices.contains_key(&(v as u32))
                {
                    p
                } else if hard.len() == 2 {
                    let (a, b) = (
                        self.positions[hard[0] as usize],
                        self.positions[hard[1] as usize],
                    );
                    [0, 1, 2].map(|k| (a[k] + 4.0 * p[k] + b[k]) / 6.0)
                } else if hard.len() <= 1
                    && !boundary
                    && n >= 2
                    && opposite[v].len() == n
                    && opposite[v].iter().all(Option::is_some)
                {
                    let nf = n as f64;
                    let mut s = [0.0; 3];
                    for k in 0..3 {
                        s[k] = nf * nf * p[k];
                    }
                    for &o in &neighbours[v] {
                        for k in 0..3 {
                            s[k] += 4.0 * self.positions[o as usize][k];
                        }
                    }
                    for d in opposite[v].iter().flatten() {
                        for k in 0..3 {
                            s[k] += self.positions[*d as usize][k];
                        }
                    }
                    s.map(|x| x / (nf * (nf + 5.0)))
                } else {
                    p
                }
            })
            .collect()
    }

    /// One sqrt(2) step of a closed mesh: every vertex kept, a face point at each face's
    /// centroid, and per edge a-b the quad (a, f2, b, f1), f1 the face with the directed
    /// edge a -> b. New vertices follow the old ones, in face order.
    pub fn sqrt2_step(&self) -> PolyMesh {
        let nv = self.positions.len() as u32;
        let mut positions = self.positions.clone();
        let mut by_edge: HashMap<(u32, u32), u32> = HashMap::new();
        for (fi, f) in self.faces.iter().enumerate() {
            positions.push(mean(f.iter().map(|&v| self.positions[v as usize])));
            for i in 0..f.len() {
                by_edge.insert((f[i], f[(i + 1) % f.len()]), nv + fi as u32);
            }
        }
        let mut faces = Vec::new();
        for f in &self.faces {
            for i in 0..f.len() {
                let (a, b) = (f[i], f[(i + 1) % f.len()]);
                if a < b {
                    let f1 = by_edge[&(a, b)];
                    let f2 = *by_edge.get(&(b, a)).expect("a closed mesh");
                    faces.push(vec![a, f2, b, f1]);
                }
            }
        }
        PolyMesh { positions, faces }
    }

    /// `steps` sqrt(2) steps.
    pub fn sqrt2_refined(&self, steps: u32) -> PolyMesh {
        let mut m = self.clone();
        for _ in 0..steps {
            m = m.sqrt2_step();
        }
        m
    }

    /// One polar step (SPEC.md 8.6): a Catmull-Clark step in which, at each corner of a
    /// triangle that is one of `poles`, the quad (pole, edge point, face point, edge
    /// point) is split along (pole, face point) into two triangles. Positions follow the
    /// Catmull-Clark rules.
    pub fn polar_step(&self, poles: &[u32]) -> PolyMesh {
        let mut m = self.catmull_clark();
        let mut quads = std::mem::take(&mut m.faces).into_iter();
        for f in &self.faces {
            for c in f {
                let q = quads.next().expect("one quad per corner");
                if f.len() == 3 && poles.contains(c) {
                    m.faces.push(vec![q[0], q[1], q[2]]);
                    m.faces.push(vec![q[0], q[2], q[3]]);
                } else {
                    m.faces.push(q);
                }
            }
        }
        m
    }

    /// `levels` polar steps with the same poles.
    pub fn polar_refined(&self, poles: &[u32], levels: u32) -> PolyMesh {
        let mut m = self.clone();
        for _ in 0..levels {
            m = m.polar_step(poles);
        }
        m
    }

    /// `levels` Catmull-Clark steps.
    pub fn refined(&self, levels: u32) -> PolyMesh {
        let mut m = self.clone();
        for _ in 0..levels {
            m = m.catmull_clark();
        }
        m
    }

    /// Adds a smooth bump field and uniform noise of amplitude `noise` along each axis.
    pub fn displace(&mut self, bump: f64, noise: f64, rng: &mut Rng) {
        for p in &mut self.positions {
            let s = (3.1 * p[0]).sin() * (2.3 * p[1]).cos() * (1.7 * p[2] + 0.5).sin();
            for k in 0..3 {
                p[k] += bump * s * (1.0 + 0.3 * k as f64) + noise * (rng.unit() - 0.5);
            }
        }
    }

    /// Randomly renumbers vertices, reorders faces and rotates each face's start
    /// (orientation kept), like the shared corpus's `.shuffled.obj` copies.
    pub fn shuffled(&self, rng: &mut Rng) -> PolyMesh {
        let n = self.positions.len();
        let mut perm: Vec<u32> = (0..n as u32).collect();
        for i in (1..n).rev() {
            perm.swap(i, rng.below(i + 1));
        }
        let mut positions = vec![[0.0; 3]; n];
        for (old, &new) in perm.iter().enumerate() {
            positions[new as usize] = self.positions[old];
        }
        let mut faces: Vec<Vec<u32>> = self
            .faces
            .iter()
            .map(|f| {
                let r = rng.below(f.len());
                (0..f.len())
                    .map(|i| perm[f[(i + r) % f.len()] as usize])
                    .collect()
            })
            .collect();
        for i in (1..faces.len()).rev() {
            faces.swap(i, rng.below(i + 1));
        }
        PolyMesh { positions, faces }
    }

    /// Binary little-endian PLY with float32 positions, the first coordinates set to
    /// `special` (values the codec must keep bit for bit).
    pub fn to_ply_f32(&self, special: &[f32]) -> Vec<u8> {
        let mut out = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
             property float y\nproperty float z\nelement face {}\n\
             property list uchar int vertex_indices\nend_header\n",
            self.positions.len(),
            self.faces.len()
        )
        .into_bytes();
        for (i, p) in self.positions.iter().enumerate() {
            for (k, &x) in p.iter().enumerate() {
                let x = special.get(3 * i + k).copied().unwrap_or(x as f32);
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        for f in &self.faces {
            out.push(f.len() as u8);
            for &v in f {
                out.extend_from_slice(&(v as i32).to_le_bytes());
            }
        }
        out
    }

    /// Writes a binary STL: each face as a fan of triangles, positions and facet normals
    /// in binary32, a zero attribute word.
    pub fn to_stl(&self) -> Vec<u8> {
        let tris: Vec<[u32; 3]> = self
            .faces
            .iter()
            .flat_map(|f| (1..f.len() - 1).map(move |i| [f[0], f[i], f[i + 1]]))
            .collect();
        let mut out = vec![b' '; 80];
        out[..24].copy_from_slice(b"subwave corpus generator");
        out.extend_from_slice(&(tris.len() as u32).to_le_bytes());
        for t in &tris {
            let p = t.map(|v| self.positions[v as usize].map(|x| x as f32));
            let (u, w) = (
                [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]],
                [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]],
            );
            let n = [
                u[1] * w[2] - u[2] * w[1],
                u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0],
            ];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
                .sqrt()
                .max(f32::MIN_POSITIVE);
            for x in n.iter().map(|x| x / len).chain(p.into_iter().flatten()) {
                out.extend_from_slice(&x.to_le_bytes());
            }
            out.extend_from_slice(&[0, 0]);
        }
        out
    }

    /// Writes OBJ text as modelling tools do, with attributes: two comment lines,
    /// `mtllib`, `o`, the `v` lines, smooth `vn` lines (4 decimals, deduplicated on
    /// their text, in vertex order), `vt` lines (a box projection: each face's chart is
    /// the axis its normal leans on most, a vertex has one `vt` per chart it touches,
    /// numbered by first use), `s 1`, a `usemtl` per chart, the faces grouped by chart
    /// as `f v/vt/vn`. Positions with 6 decimals.
    pub fn to_obj_textured(&self) -> String {
        let n = self.positions.len();
        let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let mut vnorm = vec![[0.0f64; 3]; n];
        let mut chart = Vec::with_capacity(self.faces.len());
        for f in &self.faces {
            let mut fnorm = [0.0; 3];
            for i in 0..f.len() {
                let p = self.positions[f[i] as usize];
                let q = self.positions[f[(i + 1) % f.len()] as usize];
                let c = cross(p, sub(q, p));
                for k in 0..3 {
                    fnorm[k] += c[k];
                }
            }
            for &v in f {
                for k in 0..3 {
                    vnorm[v as usize][k] += fnorm[k];
                }
            }
            let axis = (0..3)
                .max_by(|&a, &b| fnorm[a].abs().total_cmp(&fnorm[b].abs()))
                .unwrap_or(0);
            chart.push(axis * 2 + (fnorm[axis] < 0.0) as usize);
        }
        let mut s = String::with_capacity(n * 120 + self.faces.len() * 40);
        s.push_str("# subwave-corpus OBJ File\n# made by to_obj_textured\n");
        s.push_str("mtllib textured.mtl\no Cube\n");
        for p in &self.positions {
            let _ = writeln!(s, "v {:.6} {:.6} {:.6}", p[0], p[1], p[2]);
        }
        let mut vn_of = vec![0u32; n];
        let mut vn_table: HashMap<String, u32> = HashMap::new();
        for (v, nrm) in vnorm.iter().enumerate() {
            let len = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2])
                .sqrt()
                .max(1e-12);
            let text = format!(
                "vn {:.4} {:.4} {:.4}",
                nrm[0] / len,
                nrm[1] / len,
                nrm[2] / len
            );
            let next = vn_table.len() as u32 + 1;
            let id = *vn_table.entry(text.clone()).or_insert_with(|| {
                s.push_str(&text);
                s.push('\n');
                next
            });
            vn_of[v] = id;
        }
        let mut order: Vec<usize> = (0..self.faces.len()).collect();
        order.sort_by_key(|&f| chart[f]);
        let mut vt_of: HashMap<(usize, u32), u32> = HashMap::new();
        let mut vt_lines = String::new();
        let mut f_lines = String::new();
        let mut last_chart = usize::MAX;
        for &f in &order {
            let c = chart[f];
            if c != last_chart {
                let _ = writeln!(f_lines, "usemtl Side{c}");
                last_chart = c;
            }
            f_lines.push('f');
            for &v in &self.faces[f] {
                let next = vt_of.len() as u32 + 1;
                let id = *vt_of.entry((c, v)).or_insert_with(|| {
                    let p = self.positions[v as usize];
                    let (a, b) = match c / 2 {
                        0 => (p[1], p[2]),
                        1 => (p[2], p[0]),
                        _ => (p[0], p[1]),
                    };
                    let _ = writeln!(
                        vt_lines,
                        "vt {:.6} {:.6}",
                        (a + 1.0) / 6.0 + (c % 3) as f64 / 3.0,
                        (b + 1.0) / 4.0 + (c / 3) as f64 / 2.0
                    );
                    next
                });
                let _ = write!(f_lines, " {}/{}/{}", v + 1, id, vn_of[v as usize]);
            }
            f_lines.push('\n');
        }
        s.push_str(&vt_lines);
        s.push_str("s 1\n");
        s.push_str(&f_lines);
        s
    }

    /// Writes OBJ text with `decimals` decimals.
    pub fn to_obj(&self, decimals: usize) -> String {
        let mut s = String::with_capacity(self.positions.len() * 40 + self.faces.len() * 30);
        for p in &self.positions {
            let _ = writeln!(s, "v {:.d$} {:.d$} {:.d$}", p[0], p[1], p[2], d = decimals);
        }
        for f in &self.faces {
            s.push('f');
            for &v in f {
                let _ = write!(s, " {}", v + 1);
            }
            s.push('\n');
        }
        s
    }
}

fn mean(it: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
    let mut s = [0.0; 3];
    let mut n = 0.0;
    for p in it {
        for k in 0..3 {
            s[k] += p[k];
        }
        n += 1.0;
    }
    if n == 0.0 {
        return s;
    }
    s.map(|x| x / n)
}

/// The unit cube as six quads.
pub fn cube() -> PolyMesh {
    let positions = (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64].map(|c| c - 0.5))
        .collect();
    let faces = vec![
        vec![0, 2, 3, 1],
        vec![4, 5, 7, 6],
        vec![0, 1, 5, 4],
        vec![2, 6, 7, 3],
        vec![0, 4, 6, 2],
        vec![1, 3, 7, 5],
    ];
    PolyMesh { positions, faces }
}

/// A latitude-longitude sphere: poles 0 (top) and 1 (bottom), each with a fan of `n`
/// triangles, and `rings` rings of `n` vertices joined by quads.
pub fn polar_sphere(n: u32, rings: u32) -> PolyMesh {
    let mut positions = vec![[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];
    for r in 0..rings {
        let lat = std::f64::consts::PI * (r + 1) as f64 / (rings + 1) as f64;
        for j in 0..n {
            let lon = std::f64::consts::TAU * j as f64 / n as f64;
            positions.push([lat.sin() * lon.cos(), lat.sin() * lon.sin(), lat.cos()]);
        }
    }
    let v = |r: u32, j: u32| 2 + r * n + j % n;
    let mut faces = Vec::new();
    for j in 0..n {
        faces.push(vec![0, v(0, j), v(0, j + 1)]);
        faces.push(vec![1, v(rings - 1, j + 1), v(rings - 1, j)]);
        for r in 0..rings - 1 {
            faces.push(vec![v(r, j), v(r + 1, j), v(r + 1, j + 1), v(r, j + 1)]);
        }
    }
    PolyMesh { positions, faces }
}

/// A closed base mesh with triangles, quads and pentagons and vertices of valence
/// 3, 4 and 5: a pentagonal prism capped by pyramids on its two pentagons would be all
/// triangles, so instead: a pentagonal prism (two pentagons, five quads) with one quad
/// split into two triangles.
pub fn mixed_polygons() -> PolyMesh {
    let mut positions = Vec::new();
    for z in [-0.5, 0.5] {
        for i in 0..5 {
            let a = i as f64 * std::f64::consts::TAU / 5.0;
            positions.push([a.cos(), a.sin(), z]);
        }
    }
    let mut faces = vec![vec![4, 3, 2, 1, 0], vec![5, 6, 7, 8, 9]];
    for i in 0..5u32 {
        let j = (i + 1) % 5;
        if i == 0 {
            faces.push(vec![i, j, j + 5]);
            faces.push(vec![i, j + 5, i + 5]);
        } else {
            faces.push(vec![i, j, j + 5, i + 5]);
        }
    }
    PolyMesh { positions, faces }
}

/// A folded sheet as a modeller makes one: a 5 x 4 grid of quads bent into a tent along
/// its third column of vertices, and that fold's four edges (to crease).
pub fn folded_sheet() -> (PolyMesh, Vec<[u32; 2]>) {
    let mut control = open_grid(5, 4);
    for p in &mut control.positions {
        p[2] = 0.5 * (p[0] - 0.4).abs() + 0.1 * (3.0 * p[1]).sin();
    }
    let fold = (0..4u32).map(|y| [y * 6 + 2, (y + 1) * 6 + 2]).collect();
    (control, fold)
}

/// An open quad strip with a boundary: `w x h` quads.
pub fn open_grid(w: u32, h: u32) -> PolyMesh {
    let mut positions = Vec::new();
    for y in 0..=h {
        for x in 0..=w {
            positions.push([x as f64 / w as f64, y as f64 / h as f64, 0.0]);
        }
    }
    let mut faces = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * (w + 1) + x;
            faces.push(vec![i, i + 1, i + w + 2, i + w + 1]);
        }
    }
    PolyMesh { positions, faces }
}

/// A `(2^k + 1)^2` height grid (row-major) over a 1 km square, heights from a few
/// octaves of smooth noise plus measurement noise.
pub fn terrain(k: u32, seed: u64) -> PolyMesh {
    let n = (1u32 << k) + 1;
    let mut rng = Rng::new(seed);
    let phases: Vec<f64> = (0..12)
        .map(|_| rng.unit() * std::f64::consts::TAU)
        .collect();
    let mut positions = Vec::with_capacity((n * n) as usize);
    for y in 0..n {
        for x in 0..n {
            let (u, v) = (x as f64 / (n - 1) as f64, y as f64 / (n - 1) as f64);
            let mut h = 300.0;
            for o in 0..4 {
                let f = (1 << o) as f64 * 2.0;
                h += 60.0 / (1 << o) as f64
                    * (f * u * 3.0 + phases[3 * o]).sin()
                    * (f * v * 2.0 + phases[3 * o + 1]).cos();
            }
            h += 0.3 * (rng.unit() - 0.5);
            positions.push([u * 1000.0, v * 1000.0, h]);
        }
    }
    let mut faces = Vec::new();
    for y in 0..n - 1 {
        for x in 0..n - 1 {
            let i = y * n + x;
            faces.push(vec![i, i + 1, i + n + 1, i + n]);
        }
    }
    PolyMesh { positions, faces }
}

/// Concatenates meshes into one with several components.
pub fn union(parts: &[PolyMesh]) -> PolyMesh {
    let mut m = PolyMesh::default();
    for p in parts {
        let off = m.positions.len() as u32;
        m.positions.extend_from_slice(&p.positions);
        m.faces
            .extend(p.faces.iter().map(|f| f.iter().map(|&v| v + off).collect()));
    }
    m
}

/// Moves every vertex by `d`.
pub fn translate(mut m: PolyMesh, d: [f64; 3]) -> PolyMesh {
    for p in &mut m.positions {
        for k in 0..3 {
            p[k] += d[k];
        }
    }
    m
}

/// A triangle soup-like unstructured mesh: a jittered triangulated grid, with a few
/// unreferenced vertices appended.
pub fn unstructured(n: u32, seed: u64) -> PolyMesh {
    let mut rng = Rng::new(seed);
    let mut m = open_grid(n, n);
    let mut faces = Vec::new();
    for f in &m.faces {
        if rng.below(2) == 0 {
            faces.push(vec![f[0], f[1], f[2]]);
            faces.push(vec![f[0], f[2], f[3]]);
        } else {
            faces.push(vec![f[0], f[1], f[3]]);
            faces.push(vec![f[1], f[2], f[3]]);
        }
    }
    m.faces = faces;
    for p in &mut m.positions {
        p[2] = 0.1 * (p[0] * 7.0).sin() + 0.01 * rng.unit();
    }
    for _ in 0..3 {
        m.positions.push([rng.unit(), rng.unit(), rng.unit()]);
    }
    m
}

/// The small meshes committed in `corpus/`, by file name.
pub fn small_corpus() -> Vec<(&'static str, Vec<u8>)> {
    let mut rng = Rng::new(7);
    let mut cube4 = cube().refined(4);
    cube4.displace(0.05, 0.002, &mut rng);
    let mut mixed2 = mixed_polygons().refined(2);
    mixed2.displace(0.03, 0.001, &mut rng);
    let mut open2 = open_grid(3, 2).refined(2);
    open2.displace(0.02, 0.001, &mut rng);
    let two = union(&[
        cube().refined(2),
        translate(mixed_polygons().refined(1), [3.0, 0.0, 0.0]),
    ]);
    let shuffled = cube4.shuffled(&mut rng);
    let mut prism = mixed_polygons().sqrt2_refined(5);
    prism.displace(0.03, 0.002, &mut rng);
    let mut polar = polar_sphere(5, 3).polar_refined(&[0, 1], 3);
    polar.displace(0.03, 0.002, &mut rng);
    // Subdivided models: a displaced control mesh refined by plain Catmull-Clark, no
    // detail added (the subdivision fit's case, SPEC.md 9.10), closed and with a border.
    let mut control = mixed_polygons();
    control.displace(0.2, 0.05, &mut rng);
    let mut open_control = open_grid(4, 3);
    open_control.displace(0.2, 0.05, &mut rng);
    // Binary floats beyond one grid: a refined mixed mesh in float32, with a coordinate
    // of -0.0, tiny and subnormal ones (the FBIT section's case, SPEC.md 3.2).
    let mut floats = mixed_polygons().refined(2);
    floats.displace(0.03, 0.001, &mut rng);
    let text = vec![
        ("cube_cc4.obj", cube4.to_obj(6)),
        ("cube_cc4.shuffled.obj", shuffled.to_obj(6)),
        ("mixed_cc2.obj", mixed2.to_obj(6)),
        ("open_cc2.obj", open2.to_obj(5)),
        ("two_components_cc2.obj", two.to_obj(4)),
        ("terrain_grid33.obj", terrain(5, 3).to_obj(3)),
        ("unstructured.obj", unstructured(12, 5).to_obj(6)),
        ("prism_sqrt2_5.obj", prism.to_obj(6)),
        ("sphere_polar3.obj", polar.to_obj(6)),
        ("subdivided_cc3.obj", control.refined(3).to_obj(6)),
        ("subdivided_open_cc3.obj", open_control.refined(3).to_obj(6)),
    ];
    let mut out: Vec<(&'static str, Vec<u8>)> =
        text.into_iter().map(|(n, t)| (n, t.into_bytes())).collect();
    out.push((
        "floats_cc2.ply",
        floats.to_ply_f32(&[-0.0, 2.3283064e-10, 1e-40]),
    ));
    // STL: triangles, each corner a copy of its position (a refined cube's quads split).
    let mut tris = cube().refined(2);
    tris.displace(0.05, 0.002, &mut rng);
    out.push(("cube_cc2.stl", tris.to_stl()));
    // An OBJ with attributes as modelling tools write them: vt (seams), vn, materials.
    let mut textured = cube().refined(3);
    textured.displace(0.05, 0.002, &mut rng);
    out.push(("textured_cc3.obj", textured.to_obj_textured().into_bytes()));
    // A subdivision surface as modelling tools write it: the folded sheet's fold
    // creased, three levels, every vertex on the limit surface (SPEC.md 9.10).
    let (sheet, fold) = folded_sheet();
    let surface = sheet.subdivision_surface(3, &fold, true);
    out.push(("limit_creased_cc3.obj", surface.to_obj(6).into_bytes()));
    // The same cut at a seam as a PLY exporter writes it (its right two columns of
    // faces a piece of their own), in binary32 (SPEC.md 9.10's seams).
    let right: Vec<usize> = (0..20).filter(|f| f % 5 >= 3).collect();
    out.push((
        "limit_seams_cc3.ply",
        cut_off(&sheet, &right, &surface, 3).to_ply_f32(&[]),
    ));
    out
}

/// `surface`, made from `control` by `levels` Catmull-Clark steps (as
/// [`PolyMesh::subdivision_surface`] or [`PolyMesh::refined`] number it), cut as an
/// exporter cuts a mesh at its UV seams: control faces `piece` become a piece of their
/// own (each corner they share with the other faces doubled), so every vertex along the
/// cut is written twice with the same position. The cut refinement's faces and corners
/// correspond one to one with the surface's (the cut only renames corners), so each
/// corner takes the surface's value.
pub fn cut_off(control: &PolyMesh, piece: &[usize], surface: &PolyMesh, levels: u32) -> PolyMesh {
    let inside: HashSet<usize> = piece.iter().copied().collect();
    let used_outside: HashSet<u32> = (0..control.faces.len())
        .filter(|f| !inside.contains(f))
        .flat_map(|f| control.faces[f].iter().copied())
        .collect();
    let mut cut = control.clone();
    let mut copy: HashMap<u32, u32> = HashMap::new();
    for &f in piece {
        for i in 0..cut.faces[f].len() {
            let v = cut.faces[f][i];
            if used_outside.contains(&v) {
                let c = *copy.entry(v).or_insert_with(|| {
                    cut.positions.push(control.positions[v as usize]);
                    cut.positions.len() as u32 - 1
                });
                cut.faces[f][i] = c;
            }
        }
    }
    let mut cut = cut.refined(levels);
    for (f, g) in cut.faces.iter().zip(&surface.faces) {
        for (&c, &s) in f.iter().zip(g) {
            cut.positions[c as usize] = surface.positions[s as usize];
        }
    }
    cut
}

/// A large polar mesh for benchmarks: a displaced latitude-longitude sphere (two poles
/// of valence 8, 7 rings) refined `levels` times by the polar rule (`levels = 6` gives
/// 261,634 vertices, `levels = 8` 4,185,602).
pub fn large_polar(levels: u32) -> PolyMesh {
    let mut rng = Rng::new(5);
    let mut m = polar_sphere(8, 7).polar_refined(&[0, 1], levels);
    m.displace(0.02, 0.001, &mut rng);
    m
}

/// The sharpness of an infinitely sharp crease (OpenSubdiv's 10).
pub const INFINITELY_SHARP: f64 = 10.0;

/// A sharpness one subdivision step down: one less, at least 0; infinite stays.
fn one_less(s: f64) -> f64 {
    if s >= INFINITELY_SHARP {
        INFINITELY_SHARP
    } else {
        (s - 1.0).max(0.0)
    }
}

/// Creases of a mesh: sharpness per edge (as an ordered vertex pair) and per vertex;
/// absent ones are smooth.
#[derive(Clone, Debug, Default)]
pub struct Creases {
    /// Edge `(min, max)` to its sharpness.
    pub edges: HashMap<(u32, u32), f64>,
    /// Vertex to its sharpness.
    pub vertices: HashMap<u32, f64>,
}

/// Which vertices a subdivision keeps where they are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kept {
    /// None: boundaries follow the cubic B-spline curve rules.
    Nothing,
    /// Boundary vertices of one face (Blender's "Keep Corners").
    Corners,
    /// Every boundary vertex: boundaries stay piecewise linear (Blender's UV rule
    /// "Keep Boundaries", on a UV map's charts).
    Boundary,
    /// Every vertex, and every edge sharp: linear everywhere (Blender's UV rule
    /// "None" and its "Simple" subdivision).
    Everything,
    /// None while refining, but boundary vertices of one face keep their place on the
    /// limit (what Blender writes for UV charts with its UV rule "All").
    LimitCorners,
}

impl Kept {
    /// Whether a vertex (on a boundary or not, with `faces` faces) keeps its place.
    fn keeps(self, on_boundary: bool, faces: usize) -> bool {
        self == Kept::Everything
            || on_boundary
                && match self {
                    Kept::Nothing | Kept::LimitCorners | Kept::Everything => false,
                    Kept::Corners => faces == 1,
                    Kept::Boundary => true,
                }
    }

    /// Whether such a vertex keeps its place on the limit.
    fn keeps_at_limit(self, on_boundary: bool, faces: usize) -> bool {
        self.keeps(on_boundary, faces) || self == Kept::LimitCorners && on_boundary && faces == 1
    }
}

/// A large mesh for benchmarks: a displaced cube refined `levels` times
/// (`levels = 9` gives 1,572,866 vertices).
pub fn large_cube(levels: u32) -> PolyMesh {
    let mut rng = Rng::new(11);
    let mut m = cube().refined(levels);
    m.displace(0.05, 0.0005, &mut rng);
    m
}

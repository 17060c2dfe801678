//! Gates (SPEC.md 6.2): the record of the faces coded so far, their open half-edges
//! taken first in, first out, and the order in which the gates visit a mesh's faces.
//! The BASE section codes its connectivity over them (`sections::base`); the encoder
//! orders base meshes by [`gate_order`].

use super::PairMap;

/// Border vertices a gated corner can name (SPEC.md 6.2).
pub const CANDIDATES: usize = 4;
/// How many of a vertex's most recent half-edges a candidate search reads.
const SCAN: usize = 32;
const NIL: u32 = u32::MAX;

/// The decoder's (and the encoder's) record of the faces coded so far: the faces
/// themselves (the queue of gates is a cursor over their half-edges in the order
/// recorded), their directed half-edges, and each vertex's incoming and outgoing ones
/// (most recent first).
pub struct Gates {
    /// The recorded faces' corners, as a mesh's `faces`.
    pub corners: Vec<u32>,
    /// Where each recorded face starts in `corners`, as a mesh's `face_starts`.
    pub starts: Vec<u32>,
    /// The queue's head: a face and one of its corners (the half-edge from it).
    head_face: usize,
    head: usize,
    present: PairMap,
    into: Vec<u32>,
    from: Vec<u32>,
    /// Linked list cells: (other vertex, next cell).
    cells: Vec<(u32, u32)>,
}

impl Default for Gates {
    fn default() -> Self {
        Self::new()
    }
}

impl Gates {
    /// No face recorded yet.
    pub fn new() -> Self {
        Gates {
            corners: Vec::new(),
            starts: vec![0],
            head_face: 0,
            head: 0,
            present: PairMap::with_capacity(64),
            into: Vec::new(),
            from: Vec::new(),
            cells: Vec::new(),
        }
    }

    /// Removes the queue's first gate.
    pub fn pop(&mut self) {
        self.head += 1;
    }

    fn has(&self, a: u32, b: u32) -> bool {
        self.present.get(a, b).is_some()
    }

    /// Half-edge a -> b is coded and its twin is not.
    fn open(&self, a: u32, b: u32) -> bool {
        self.has(a, b) && !self.has(b, a)
    }

    fn grow(&mut self, v: u32) {
        let n = v as usize + 1;
        if self.into.len() < n {
            self.into.resize(n, NIL);
            self.from.resize(n, NIL);
        }
    }

    /// Records a coded face (every corner a known vertex); its half-edges join the
    /// queue.
    pub fn add(&mut self, face: &[u32]) {
        let k = face.len();
        for i in 0..k {
            let (a, b) = (face[i], face[(i + 1) % k]);
            self.grow(a.max(b));
            self.present.insert(a, b, 0);
            let c = self.cells.len() as u32;
            self.cells.push((a, self.into[b as usize]));
            self.into[b as usize] = c;
            self.cells.push((b, self.from[a as usize]));
            self.from[a as usize] = c + 1;
        }
        self.corners.extend_from_slice(face);
        self.starts.push(self.corners.len() as u32);
    }

    /// The first gate in the queue that is still open, dropping closed ones, with the
    /// degree of its face.
    pub fn gate(&mut self) -> Option<(u32, u32, usize)> {
        while self.head < self.corners.len() {
            while self.head >= self.starts[self.head_face + 1] as usize {
                self.head_face += 1;
            }
            let (s, e) = (
                self.starts[self.head_face] as usize,
                self.starts[self.head_face + 1] as usize,
            );
            let a = self.corners[self.head];
            let b = self.corners[if self.head + 1 < e { self.head + 1 } else { s }];
            if self.has(b, a) {
                self.head += 1;
            } else {
                return Some((a, b, e - s));
            }
        }
        None
    }

    /// Candidates for the corner after `prev` of a face attached at gate vertex `v`
    /// (the face's first corner): vertices x with x -> prev open, most recent first, then
    /// on the last corner vertices y with v -> y open; each once, at most [`CANDIDATES`].
    pub fn candidates(&self, prev: u32, v: u32, last: bool) -> ([u32; CANDIDATES], usize) {
        let mut out = [NIL; CANDIDATES];
        let mut n = 0;
        let mut push = |x: u32, out: &mut [u32; CANDIDATES]| {
            if n < CANDIDATES && !out[..n].contains(&x) {
                out[n] = x;
                n += 1;
            }
        };
        let mut walk = |head: &[u32], at: u32, incoming: bool, out: &mut [u32; CANDIDATES]| {
            let mut c = head.get(at as usize).copied().unwrap_or(NIL);
            let mut seen = 0;
            while c != NIL && seen < SCAN {
                let (x, next) = self.cells[c as usize];
                let open = if incoming {
                    self.open(x, at)
                } else {
                    self.open(at, x)
                };
                if open {
                    push(x, out);
                }
                c = next;
                seen += 1;
            }
        };
        walk(&self.into, prev, true, &mut out);
        if last {
            walk(&self.from, v, false, &mut out);
        }
        let n = out.iter().position(|&x| x == NIL).unwrap_or(CANDIDATES);
        (out, n)
    }
}

/// Encoder only: the order in which the gates visit the faces (SPEC.md 6.2, informative):
/// from the first face not yet visited, each open gate in turn takes the first unvisited
/// face that has the gate's twin, rotated to start at the twin. Returns `order[new] =
/// old` and each face's rotation (the corner it now starts at).
pub fn gate_order(starts: &[u32], idx: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let nf = starts.len() - 1;
    let face = |f: usize| &idx[starts[f] as usize..starts[f + 1] as usize];
    // Directed half-edge -> first face (and corner) listing it, then a chain of others.
    let mut first = PairMap::with_capacity(idx.len());
    let mut more: Vec<(u32, u32, u32)> = Vec::new(); // (face, corner, next)
    for f in (0..nf).rev() {
        let fc = face(f);
        let k = fc.len();
        for i in 0..k {
            let (a, b) = (fc[i], fc[(i + 1) % k]);
            let c = more.len() as u32;
            let (head, fresh) = first.get_or_insert(a, b, || c);
            more.push((f as u32, i as u32, if fresh { NIL } else { head }));
            if !fresh {
                first.insert(a, b, c);
            }
        }
    }
    let mut coded = vec![false; nf];
    let mut gates = Gates::new();
    let mut order = Vec::with_capacity(nf);
    let mut rot = Vec::with_capacity(nf);
    let mut root = 0;
    let mut buf: Vec<u32> = Vec::new();
    while order.len() < nf {
        let mut pick = None;
        while let Some((u, v, _)) = gates.gate() {
            let mut c = first.get(v, u).unwrap_or(NIL);
            while c != NIL {
                let (f, i, next) = more[c as usize];
                if !coded[f as usize] {
                    pick = Some((f as usize, i as usize));
                    break;
                }
                c = next;
            }
            if pick.is_some() {
                break;
            }
            gates.pop();
        }
        let (f, r) = match pick {
            Some(p) => p,
            None => {
                while coded[root] {
                    root += 1;
                }
                (root, 0)
            }
        };
        coded[f] = true;
        order.push(f as u32);
        rot.push(r as u32);
        let fc = face(f);
        buf.clear();
        buf.extend((0..fc.len()).map(|i| fc[(r + i) % fc.len()]));
        gates.add(&buf);
    }
    (order, rot)
}

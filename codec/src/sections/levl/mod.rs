//! Coding one refinement level's details (SPEC.md 10): the edge points' details, then the
//! face points', each as x, y, z with integer models chosen by class, axis, the previous
//! axis's magnitude and the activity of the coarser neighbours.

pub mod fit;

use crate::entropy::{class_of, Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use crate::topology::Level;
use crate::transform::phase::{phase, Phases, FRAC_DIV};

/// Largest magnitude of a lifted value or detail (SPEC.md 9.3).
pub const MAX_LIFTED: i64 = (1 << 52) - 1;

/// Magnitude of a vertex with no detail (base vertices).
pub const UNKNOWN: u8 = 255;

fn prev_bin(c: usize) -> usize {
    match c {
        0..=2 => 0,
        3..=6 => 1,
        _ => 2,
    }
}

#[derive(Clone)]
struct Models {
    m: Vec<IntModel>,
    /// Per class and slot, a model of every value coded there; a context model starts
    /// from it (reseeded) at its first use.
    parents: Vec<IntModel>,
    used: Vec<bool>,
    /// Mode 6's models, [`PHASE_BINS`] per context of `m` (`None` until
    /// first used), and their shared models (per class, slot and phase bin); empty until a
    /// level is coded in mode 6, when the shared ones start from `parents` (SPEC.md
    /// 10.6).
    ph: Vec<Option<IntModel>>,
    ph_parents: Vec<IntModel>,
}

/// Phase bins: the size of a prediction's remainder in sixths of its divisor, 0..=2.
const PHASE_BINS: usize = 3;

/// Detail `i`'s phases on the three axes.
fn phases_at(p: &Phases, i: usize) -> [u8; 3] {
    [p.codes[0][i], p.codes[1][i], p.codes[2][i]]
}

/// Detail `i`'s fractions on the three axes (SPEC.md 10.9).
fn fracs_at(p: &Phases, i: usize) -> [i16; 3] {
    [p.fracs[0][i], p.fracs[1][i], p.fracs[2][i]]
}

/// Mode 9's mask bit for joint rounding: each correction rounded together with the
/// prediction's fraction, the value phased by that sum's remainder (SPEC.md 10.9).
const JOINT: u8 = 0x40;

/// How mode 9 rounds its corrections (SPEC.md 10.9).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Rounding {
    /// Apart from the prediction, the value phased by the prediction's phase.
    Apart,
    /// With the prediction's fraction, the value phased by their sum's phase.
    Joint,
}

/// The mode byte's unbinned flag: every value of the level is coded with the shared
/// model of its class and slot (or phase bin) rather than a model of its neighbour bin
/// (SPEC.md 10.1), for levels whose details hardly depend on their neighbours' sizes.
const UNBINNED: u8 = 0x80;

/// The mode byte's zero-slot flags, slot s at bit `ZERO_SHIFT + s`: the slots whose
/// coded values are all 0 at the level and left out of its stream (SPEC.md 10.1), as a
/// terrain grid's x and y, a flat mesh's z.
const ZERO_SLOTS: u8 = 0x70;
const ZERO_SHIFT: u32 = 4;

/// A LEVL payload's mode (SPEC.md 10.1): its first byte, without the unbinned flag and
/// the zero-slot flags; `None` for an empty payload.
pub fn mode_of(payload: &[u8]) -> Option<u8> {
    payload.first().map(|b| b & !(UNBINNED | ZERO_SLOTS))
}

/// A LEVL payload's zero-slot flags (SPEC.md 10.1): bit s set when slot s's values are
/// all 0 and not coded.
pub fn zero_slots(payload: &[u8]) -> u8 {
    payload
        .first()
        .map_or(0, |&b| (b & ZERO_SLOTS) >> ZERO_SHIFT)
}

/// Whether a LEVL payload is unbinned (SPEC.md 10.1).
pub fn unbinned(payload: &[u8]) -> bool {
    payload.first().is_some_and(|b| b & UNBINNED != 0)
}

/// Whether a LEVL payload is in mode 9 with joint rounding (SPEC.md 10.9).
pub fn joint(payload: &[u8]) -> bool {
    mode_of(payload) == Some(9) && payload.get(1).is_some_and(|m| m & JOINT != 0)
}

/// Mode 8's weights are in 32nds, at most 2 in magnitude.
const CORR_DIV: i128 = 32;
const CORR_MAX: i8 = 64;
/// Mode 8's features per detail (SPEC.md 10.8).
const NFEAT: usize = 2;

/// Mode 8's weights: per class (edge points, face points) and axis, those of the
/// features of [`corr_features`].
type Weights = [[[i8; NFEAT]; 3]; 2];

/// Mode 8's (and 9's) features of detail `i` of a Catmull-Clark level, per axis, from
/// the details `x[k][nv + j]` of the details `j < i` (SPEC.md 10.8). An edge point: the
/// sum of its ends' earlier edges that share no face with it (the edge's continuation on
/// a regular grid), and of the earlier edges opposite it in its quadrilateral faces. A
/// face point: the sum of the earlier faces beside its edges, and of its own edge
/// points.
fn corr_features(level: &Level, x: &[Vec<i64>; 3], i: usize) -> [[i128; 3]; NFEAT] {
    use crate::topology::NONE;
    let nv = level.nv;
    let mut f = [[0i128; 3]; NFEAT];
    let mut add = |which: usize, j: usize| {
        for k in 0..3 {
            f[which][k] += x[k][nv + j] as i128;
        }
    };
    let ne = level.ne();
    if i < ne {
        let faces = level.edge_faces[i];
        let beside = |g: u32| {
            let gf = level.edge_faces[g as usize];
            gf.iter().any(|&h| h != NONE && faces.contains(&h))
        };
        for v in level.edges[i] {
            for &g in level.v_edges(v as usize) {
                if (g as usize) < i && !beside(g) {
                    add(0, g as usize);
                }
            }
        }
        for h in faces {
            if h == NONE {
                continue;
            }
            let fe = level.f_edges(h as usize);
            if fe.len() == 4 {
                if let Some(p) = fe.iter().position(|&g| g as usize == i) {
                    let g = fe[(p + 2) % 4] as usize;
                    if g < i {
                        add(1, g);
                    }
                }
            }
        }
    } else {
        let fi = i - ne;
        for &g in level.f_edges(fi) {
            for h in level.edge_faces[g as usize] {
                if h != NONE && (h as usize) < fi {
                    add(0, ne + h as usize);
                }
            }
            add(1, g as usize);
        }
    }
    f
}

/// Mode 8's correction numerators of detail `i`: per axis `sum w_j F_j` (SPEC.md 10.8).
fn correction_sums(level: &Level, x: &[Vec<i64>; 3], w: &Weights, i: usize) -> [i128; 3] {
    let class = (i >= level.ne()) as usize;
    let f = corr_features(level, x, i);
    std::array::from_fn(|k| match w[class][k] {
        [0, 0] => 0,
        wk => (0..NFEAT).map(|j| wk[j] as i128 * f[j][k]).sum(),
    })
}

/// Mode 8's correction from its numerators: per axis `[n / 32]`; `None` beyond the
/// bound of a detail.
fn correction(n: [i128; 3]) -> Option<[i64; 3]> {
    let mut c = [0i64; 3];
    for k in 0..3 {
        // (Floor division by a power of two: an arithmetic shift.)
        let q = (2 * n[k] + CORR_DIV) >> (2 * CORR_DIV).trailing_zeros();
        c[k] = i64::try_from(q).ok().filter(|q| q.abs() <= MAX_LIFTED)?;
    }
    Some(c)
}

/// Mode 9's joint correction (SPEC.md 10.9), from mode 8's numerators `n` and
/// the predictions' fractions: per axis `[(frac + 16 n) / 512]` and the phase of its
/// remainder; `None` beyond the bound of a detail.
fn joint_correction(n: [i128; 3], frac: [i16; 3]) -> Option<([i64; 3], [u8; 3])> {
    let mut c = [0i64; 3];
    let mut q = [0u8; 3];
    for k in 0..3 {
        let a = frac[k] as i128 + (FRAC_DIV / CORR_DIV) * n[k];
        let v = (2 * a + FRAC_DIV) >> (2 * FRAC_DIV).trailing_zeros();
        c[k] = i64::try_from(v).ok().filter(|v| v.abs() <= MAX_LIFTED)?;
        q[k] = phase(a - FRAC_DIV * v, FRAC_DIV);
    }
    Some((c, q))
}

/// Modes 8 and 9's correction numerators of every detail of the level whose details are
/// `x[k][nv..]`; `None` if a correction (mode 8's) is beyond the bound of a detail (the
/// numerators then fit 64 bits).
fn corrections(level: &Level, x: &[Vec<i64>; 3], w: &Weights) -> Option<Vec<[i64; 3]>> {
    (0..level.ne() + level.nf())
        .map(|i| {
            let n = correction_sums(level, x, w, i);
            correction(n)?;
            Some(n.map(|v| v as i64))
        })
        .collect()
}

/// What [`encode`] makes once per level for the modes that read it.
#[derive(Default)]
struct Prepared {
    /// The coarse faces' normals, for the normal-frame and rotated modes.
    normals: Vec<[i128; 3]>,
    /// The rotated modes' frames (normals included), per detail.
    frames: Vec<Option<RotFrame>>,
    /// Modes 8 and 9's correction numerators, per detail (from the level's one set of
    /// weights).
    corrections: Vec<[i64; 3]>,
}

/// Modes 8 and 9's weights after the mode byte (SPEC.md 10.8), whether the mask's joint
/// flag is set (mode 9 only, 10.9: open where `joint_open`), and the stream after
/// them.
fn read_weights(rest: &[u8], joint_open: bool) -> Result<(Weights, Rounding, &[u8])> {
    let bad = || Error::corrupt("LEVL", "bad correction weights");
    let (&mask, mut rest) = rest.split_first().ok_or_else(bad)?;
    let rounding = match mask >> 6 {
        0 => Rounding::Apart,
        1 if joint_open => Rounding::Joint,
        _ => return Err(bad()),
    };
    let mut w: Weights = [[[0; NFEAT]; 3]; 2];
    for (j, p) in w.iter_mut().flatten().enumerate() {
        if mask >> j & 1 == 1 {
            let (c, r) = rest.split_first_chunk::<NFEAT>().ok_or_else(bad)?;
            *p = c.map(|v| v as i8);
            // (unsigned_abs: -128's abs overflows an i8.)
            if p.iter().any(|v| v.unsigned_abs() > CORR_MAX as u8) {
                return Err(bad());
            }
            rest = r;
        }
    }
    Ok((w, rounding, rest))
}

/// The encoder's mode 8 weights for a level whose details are `x[k][nv..]`: per class and
/// axis, the least-squares fit of the details by their features, in 32nds; `None` when
/// every weight rounds to 0.
fn corr_weights(level: &Level, x: &[Vec<i64>; 3]) -> Option<Weights> {
    let nd = level.ne() + level.nf();
    // Per class and axis: the normal equations, F^T F and F^T y.
    let mut a = [[[[0f64; NFEAT]; NFEAT]; 3]; 2];
    let mut b = [[[0f64; NFEAT]; 3]; 2];
    for i in 0..nd {
        let class = (i >= level.ne()) as usize;
        let f = corr_features(level, x, i);
        for k in 0..3 {
            let y = x[k][level.nv + i] as f64;
            for p in 0..NFEAT {
                let fp = f[p][k] as f64;
                b[class][k][p] += fp * y;
                for q in 0..NFEAT {
                    a[class][k][p][q] += fp * f[q][k] as f64;
                }
            }
        }
    }
    let mut w: Weights = [[[0; NFEAT]; 3]; 2];
    for c in 0..2 {
        for k in 0..3 {
            if let Some(sol) = solve(a[c][k], b[c][k]) {
                w[c][k] = sol.map(|v| {
                    (v * CORR_DIV as f64)
                        .round()
                        .clamp(-(CORR_MAX as f64), CORR_MAX as f64) as i8
                });
            }
        }
    }
    (w != [[[0; NFEAT]; 3]; 2]).then_some(w)
}

/// The least-squares solution of `a w = b` by Gaussian elimination, with a small ridge
/// that keeps a feature that is (nearly) always 0 out of the fit.
fn solve(mut a: [[f64; NFEAT]; NFEAT], mut b: [f64; NFEAT]) -> Option<[f64; NFEAT]> {
    for (p, row) in a.iter_mut().enumerate() {
        row[p] = row[p] * 1.0001 + 1.0;
    }
    for p in 0..NFEAT {
        let piv = (p..NFEAT).max_by(|&i, &j| a[i][p].abs().total_cmp(&a[j][p].abs()))?;
        a.swap(p, piv);
        b.swap(p, piv);
        if a[p][p].abs() < 1e-12 || !a[p][p].is_finite() {
            return None;
        }
        for r in p + 1..NFEAT {
            let m = a[r][p] / a[p][p];
            for q in p..NFEAT {
                a[r][q] -= m * a[p][q];
            }
            b[r] -= m * b[p];
        }
    }
    let mut w = [0f64; NFEAT];
    for p in (0..NFEAT).rev() {
        let s: f64 = (p + 1..NFEAT).map(|q| a[p][q] * w[q]).sum();
        w[p] = (b[p] - s) / a[p][p];
    }
    w.iter().all(|v| v.is_finite()).then_some(w)
}

/// Context models start from their class and slot's shared model, counts halved until
/// they sum to at most this (SPEC.md 10.1).
const SHARED_SEED: u32 = 256;

/// Every component has its own neighbour context: the magnitudes of the same component
/// at the coarse neighbours and at the level's earlier details (SPEC.md 10.1), in six
/// bins and one for no neighbour.
const SLOT_BINS: usize = 7;

/// A level's models start from the previous level's, counts halved until they sum to at
/// most this (SPEC.md 10.1).
const SEED_TOTAL: u32 = 1024;

/// The detail models carried from level to level (SPEC.md 10.1): each level starts from
/// what the previous level learnt.
pub struct LevelModels {
    last: Option<Models>,
    /// Per vertex, the magnitude classes of its coded components (base vertices
    /// `UNKNOWN`).
    mags: Vec<[u8; 3]>,
    /// Whether the encoder tries the rotated modes (not part of the format).
    pub rotated: bool,
    /// The encoder's mode for each coming level (not part of the format): where given,
    /// a level is coded in that mode only (mode 5 with its own weights; every open mode
    /// if that one is not open to the level).
    pub only: Option<std::vec::IntoIter<u8>>,
    /// The mode the encoder chose for the previous level (not part of the format).
    prev_mode: Option<u8>,
    /// Whether the previous level was coded in a phased mode (6, 7 or 9): only such a
    /// level hands its phased models on (SPEC.md 10.6).
    last_phased: bool,
}

impl LevelModels {
    /// Models for a hierarchy's first level.
    pub fn new() -> Self {
        LevelModels {
            last: None,
            mags: Vec::new(),
            rotated: true,
            only: None,
            prev_mode: None,
            last_phased: false,
        }
    }

    /// A phased level after one that was not starts its phased models afresh, from the
    /// shared models as they are then (SPEC.md 10.6): `start`, the models from
    /// [`Self::start`], made ready for a level in `mode`.
    fn ready(&self, mut start: Models, mode: Mode<'_>) -> Models {
        if mode.phased() && !self.last_phased {
            start.ph.clear();
            start.ph_parents.clear();
        }
        start
    }

    fn start(&self) -> Models {
        match &self.last {
            Some(m) => {
                let mut m = m.clone();
                for im in
                    m.m.iter_mut()
                        .chain(&mut m.parents)
                        .chain(m.ph.iter_mut().flatten())
                        .chain(&mut m.ph_parents)
                {
                    im.reseed(SEED_TOTAL);
                }
                m
            }
            None => Models::new(),
        }
    }
}

impl Default for LevelModels {
    fn default() -> Self {
        Self::new()
    }
}

impl Models {
    fn new() -> Self {
        let n = 2 * 3 * 3 * SLOT_BINS;
        Models {
            m: (0..n).map(|_| IntModel::new()).collect(),
            parents: (0..6).map(|_| IntModel::new()).collect(),
            used: vec![false; n],
            ph: Vec::new(),
            ph_parents: Vec::new(),
        }
    }

    /// The model of mode 6 for a value of `class` in `slot` with phase bin `bin`
    /// (SPEC.md 10.6); at its first use a copy of its shared model, reseeded.
    fn get_phased(
        &mut self,
        class: usize,
        slot: usize,
        prev: usize,
        nbr: usize,
        bin: usize,
    ) -> &mut IntModel {
        let j = self.phased_shared(class, slot, bin);
        let i = self.context(class, slot, prev, nbr) * PHASE_BINS + bin;
        let shared = &self.ph_parents[j];
        self.ph[i].get_or_insert_with(|| seeded(shared))
    }

    /// The index in `ph_parents` of the phased shared model of `class`, `slot` and phase
    /// bin `bin`; at the first phased value, the phased models are made (SPEC.md 10.6).
    fn phased_shared(&mut self, class: usize, slot: usize, bin: usize) -> usize {
        if self.ph.is_empty() {
            self.ph = vec![None; self.m.len() * PHASE_BINS];
            self.ph_parents = (0..6 * PHASE_BINS)
                .map(|j| seeded(&self.parents[j / PHASE_BINS]))
                .collect();
        }
        (class * 3 + slot) * PHASE_BINS + bin
    }

    /// The shared model of `class`, `slot` and phase bin `bin` learns `v`.
    fn observe_phased(&mut self, class: usize, slot: usize, bin: usize, v: i64) {
        if let Some(p) = self
            .ph_parents
            .get_mut((class * 3 + slot) * PHASE_BINS + bin)
        {
            p.observe(v);
        }
    }

    /// The index in `m` of the context of a value of `class` in `slot` after a value of
    /// class `prev`, with neighbour bin `nbr`.
    fn context(&self, class: usize, slot: usize, prev: usize, nbr: usize) -> usize {
        let p = if slot == 0 { 0 } else { prev_bin(prev) };
        ((class * 3 + slot) * 3 + p) * SLOT_BINS + nbr
    }

    fn get(&mut self, class: usize, axis: usize, prev: usize, nbr: usize) -> &mut IntModel {
        let i = self.context(class, axis, prev, nbr);
        if !self.used[i] {
            self.used[i] = true;
            self.m[i] = seeded(&self.parents[class * 3 + axis]);
        }
        &mut self.m[i]
    }

    /// The model a value in context `c` is coded with (SPEC.md 10.1, 10.6): its context
    /// model, or in an unbinned level its shared model.
    fn model(&mut self, c: Ctx) -> &mut IntModel {
        match (c.unbinned, c.bin) {
            (true, Some(b)) => {
                let j = self.phased_shared(c.class, c.slot, b);
                &mut self.ph_parents[j]
            }
            (true, None) => &mut self.parents[c.class * 3 + c.slot],
            (false, Some(b)) => self.get_phased(c.class, c.slot, c.prev, c.nbr, b),
            (false, None) => self.get(c.class, c.slot, c.prev, c.nbr),
        }
    }

    /// After `v` was coded with [`Self::model`]: in a binned level its shared model
    /// learns it, in an unbinned one its context model.
    fn learn(&mut self, c: Ctx, v: i64) {
        match (c.unbinned, c.bin) {
            (true, Some(b)) => self
                .get_phased(c.class, c.slot, c.prev, c.nbr, b)
                .observe(v),
            (true, None) => self.get(c.class, c.slot, c.prev, c.nbr).observe(v),
            (false, Some(b)) => self.observe_phased(c.class, c.slot, b, v),
            (false, None) => self.observe(c.class, c.slot, v),
        }
    }

    /// The shared model of `class` and `slot` learns `v`.
    fn observe(&mut self, class: usize, slot: usize, v: i64) {
        if let Some(p) = self.parents.get_mut(class * 3 + slot) {
            p.observe(v);
        }
    }
}

/// A coded value's context: class, slot, the previous value's class, neighbour bin,
/// phase bin (modes 6, 7 and 9) and whether its level is unbinned.
#[derive(Clone, Copy)]
struct Ctx {
    class: usize,
    slot: usize,
    prev: usize,
    nbr: usize,
    bin: Option<usize>,
    unbinned: bool,
}

/// A context model's start from its shared model (SPEC.md 10.1): a copy, reseeded.
fn seeded(shared: &IntModel) -> IntModel {
    let mut m = shared.clone();
    m.reseed(SHARED_SEED);
    m
}

/// The neighbour bin of each component of detail `i` (SPEC.md 10.1) from the
/// per-component magnitudes `mags`: the coarse neighbours (an edge's ends, a face's
/// edge points, a sqrt(2) face's corners) count twice, an edge's earlier edges at its
/// ends once; the bin is the weighted mean magnitude, doubled and rounded, at most 14,
/// or 15 with no neighbour.
fn slot_bins(level: &Level, mags: &[[u8; 3]], sqrt2: bool, i: usize) -> [usize; 3] {
    let nv = level.nv;
    let mut sum = [0u32; 3];
    let mut w = 0u32;
    let mut add = |m: [u8; 3], weight: u32| {
        if m[0] != UNKNOWN {
            for k in 0..3 {
                sum[k] += weight * m[k] as u32;
            }
            w += weight;
        }
    };
    if sqrt2 {
        for &v in level.coarse.face(i) {
            add(mags[v as usize], 2);
        }
    } else if i < level.ne() {
        let [a, b] = level.edges[i];
        add(mags[a as usize], 2);
        add(mags[b as usize], 2);
        for v in [a, b] {
            for &e in level.v_edges(v as usize) {
                if (e as usize) < i {
                    add(mags[nv + e as usize], 1);
                }
            }
        }
    } else {
        for &e in level.f_edges(i - level.ne()) {
            add(mags[nv + e as usize], 2);
        }
    }
    if w == 0 {
        return [SLOT_BINS - 1; 3];
    }
    sum.map(|s| match (s + w / 2) / w {
        0 => 0,
        1..=2 => 1,
        3..=4 => 2,
        5..=6 => 3,
        7..=9 => 4,
        _ => 5,
    })
}

/// The details of a level, in coding order: `(count, first fine index)`; Catmull-Clark
/// levels code their edge points, then their face points, sqrt(2) levels their face
/// points (SPEC.md 10.1).
fn details(level: &Level, sqrt2: bool) -> usize {
    if sqrt2 {
        level.nf()
    } else {
        level.ne() + level.nf()
    }
}

/// Detail `i`'s class, the neighbour bins of its three coded values ([`slot_bins`]) and
/// its detail number for [`frame`].
#[inline(always)]
fn contexts(level: &Level, mags: &[[u8; 3]], sqrt2: bool, i: usize) -> (usize, [usize; 3], usize) {
    let ne = level.ne();
    let (class, fd) = match (sqrt2, i < ne) {
        (true, _) => (1, ne + i),
        (false, edge) => (!edge as usize, i),
    };
    (class, slot_bins(level, mags, sqrt2, i), fd)
}

/// Newell's normal of coarse face `f`, in 128-bit integers (computed in 64 bits when
/// every product and sum fits, as they do for coordinates below about 2^30).
fn face_normal(level: &Level, coarse: &[Vec<i64>; 3], f: usize) -> [i128; 3] {
    if let Some(n) = face_normal_64(level, coarse, f) {
        return n.map(|v| v as i128);
    }
    let c = level.coarse.face(f);
    let k = c.len();
    let mut n = [0i128; 3];
    for i in 0..k {
        let (a, b) = (c[i] as usize, c[(i + 1) % k] as usize);
        let (px, py, pz) = (
            coarse[0][a] as i128,
            coarse[1][a] as i128,
            coarse[2][a] as i128,
        );
        let (qx, qy, qz) = (
            coarse[0][b] as i128,
            coarse[1][b] as i128,
            coarse[2][b] as i128,
        );
        n[0] += (py - qy) * (pz + qz);
        n[1] += (pz - qz) * (px + qx);
        n[2] += (px - qx) * (py + qy);
    }
    n
}

/// [`face_normal`] in 64-bit integers, or `None` if a product or sum would overflow.
fn face_normal_64(level: &Level, coarse: &[Vec<i64>; 3], f: usize) -> Option<[i64; 3]> {
    let c = level.coarse.face(f);
    let k = c.len();
    let mut n = [0i64; 3];
    // |values| <= 2^52, so their sums and differences fit; the products may not.
    let term = |d: i64, s: i64, acc: i64| acc.checked_add(d.checked_mul(s)?);
    let [x, y, z] = coarse;
    // Edges (c[k - 1], c[0]), (c[0], c[1]), ...: the same terms as in corner order.
    let mut a = *c.get(k.wrapping_sub(1))? as usize;
    for &b in c {
        let b = b as usize;
        let (px, py, pz) = (x[a], y[a], z[a]);
        let (qx, qy, qz) = (x[b], y[b], z[b]);
        n[0] = term(py - qy, pz + qz, n[0])?;
        n[1] = term(pz - qz, px + qx, n[1])?;
        n[2] = term(px - qx, py + qy, n[2])?;
        a = b;
    }
    Some(n)
}

/// Every coarse face's normal, once per level.
fn face_normals(level: &Level, coarse: &[Vec<i64>; 3]) -> Vec<[i128; 3]> {
    (0..level.nf())
        .map(|f| face_normal(level, coarse, f))
        .collect()
}

/// The coding frame of a detail (SPEC.md 10.2): the axis where the coarse normal is
/// largest (coded first) and the normal reduced to at most 24 bits, or `None` when the
/// normal is zero.
fn frame(level: &Level, normals: &[[i128; 3]], detail: usize) -> Option<(usize, [i64; 3])> {
    let mut n = [0i128; 3];
    if detail < level.ne() {
        for &f in &level.edge_faces[detail] {
            if f != crate::topology::NONE {
                let m = normals[f as usize];
                for d in 0..3 {
                    n[d] += m[d];
                }
            }
        }
    } else {
        n = normals[detail - level.ne()];
    }
    let big = n.iter().map(|v| v.unsigned_abs()).max().unwrap_or(0);
    if big == 0 {
        return None;
    }
    let bits = 128 - big.leading_zeros();
    let shift = bits.saturating_sub(24);
    let r = n.map(|v| (v >> shift) as i64);
    // The first axis of largest magnitude (after reduction it is still non-zero).
    let mut k = 0;
    for d in 1..3 {
        if r[d].abs() > r[k].abs() {
            k = d;
        }
    }
    Some((k, r))
}

/// Order of the coded components and their predictions from the first one.
fn plan(fr: Option<(usize, [i64; 3])>) -> ([usize; 3], Option<[i64; 3]>) {
    match fr {
        None => ([0, 1, 2], None),
        // The first component, then the other two in axis order.
        Some((k, n)) => ([[0, 1, 2], [1, 0, 2], [2, 0, 1]][k], Some(n)),
    }
}

/// The part of target `g` tangent to the plane of normal `n` (SPEC.md 10.3):
/// `g - [(g . n) n / |n|^2]`, every component rounded alone.
fn tangential(g: [i64; 3], n: [i64; 3]) -> [i64; 3] {
    let n2: i128 = n.iter().map(|&v| v as i128 * v as i128).sum();
    let gn: i128 = (0..3).map(|k| g[k] as i128 * n[k] as i128).sum();
    std::array::from_fn(|k| g[k] - crate::transform::round_div(gn * n[k] as i128, n2))
}

/// Prediction of component `j` from the first component's value `dk`: `[dk n_j / n_k]`.
fn predict(dk: i64, n: [i64; 3], k: usize, j: usize) -> i64 {
    let (mut num, mut den) = (dk as i128 * n[j] as i128, n[k] as i128);
    if den < 0 {
        num = -num;
        den = -den;
    }
    crate::transform::round_div(num, den)
}

// A level may code its details in an orthonormal frame: the coarse normal, a tangent
// along the detail's coarse edge (or face diagonal) and their cross product, reached by
// exact integer rotations (SPEC.md 10.5).

/// Fixed-point bits of the rotations' lifting factors.
const ROT_BITS: u32 = 30;

/// `[p y / 2^30]`, rounded half up.
#[inline]
fn mul_q(p: i64, y: i64) -> i64 {
    ((p as i128 * y as i128 + (1 << (ROT_BITS - 1))) >> ROT_BITS) as i64
}

/// `SQRT_TABLE[m] = floor(sqrt(m 2^16))`: square roots of 8-bit mantissas to 12 bits.
const SQRT_TABLE: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut m = 0;
    while m < 256 {
        let v = (m as u32) << 16;
        let mut r = 0u32;
        while (r + 1) * (r + 1) <= v {
            r += 1;
        }
        t[m] = r;
        m += 1;
    }
    t
};

/// Floor of the square root of `v`: a first guess from [`SQRT_TABLE`] good to about
/// 1 %, two Newton steps (each at least the floor after the first, the error squared
/// each time), then exact correction.
fn isqrt(v: u64) -> u64 {
    debug_assert!(v < 1 << 60, "the correction steps square the root");
    if v < 256 {
        return (SQRT_TABLE[v as usize] >> 8) as u64;
    }
    // An even shift leaving 7 or 8 significant bits: v = m 2^sh, sqrt(v) = sqrt(m) 2^(sh/2).
    let len = 64 - v.leading_zeros();
    let sh = (len - 7) & !1;
    let m = (v >> sh) as usize;
    let mut x = ((SQRT_TABLE[m] as u64) << (sh / 2)) >> 8;
    x = x.max(1);
    for _ in 0..2 {
        x = (x + v / x) >> 1;
    }
    while x * x > v {
        x -= 1;
    }
    while (x + 1) * (x + 1) <= v {
        x += 1;
    }
    x
}

/// One plane rotation of components `i` and `j` as three lifting steps (SPEC.md 10.5),
/// after negating both when `flip`: exactly invertible on integers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Givens {
    i: u8,
    j: u8,
    flip: bool,
    /// The lifting factors, `|p|, |u| <= 2^30`.
    p: i32,
    u: i32,
}

impl Givens {
    /// The rotation that turns `(a, b)` (components `i`, `j`) onto the positive `i` axis,
    /// and the length it leaves there.
    fn towards(i: u8, j: u8, a: i64, b: i64) -> (Givens, i64) {
        let flip = a < 0;
        let (a, b) = if flip { (-a, -b) } else { (a, b) };
        // |a|, |b| < 2^26 (24-bit normals and tangents, rotated), so the squares fit.
        let r = isqrt((a * a + b * b) as u64) as i64;
        // cos = a / r, sin = -b / r; p = (cos - 1) / sin = b / (r + a), u = sin.
        let (p, u) = if r == 0 {
            (0, 0)
        } else {
            // `transform::round_div` in 64 bits (|b| 2^31 + d < 2^58): its 128-bit checks
            // cost 2.5 % of a rotated level's decode instructions.
            let div = |n: i64, d: i64| ((2 * (n << ROT_BITS) + d).div_euclid(2 * d)) as i32;
            (div(b, r + a), div(-b, r))
        };
        (Givens { i, j, flip, p, u }, r)
    }

    fn forward(&self, v: &mut [i64; 3]) {
        let (i, j, p, u) = (
            self.i as usize,
            self.j as usize,
            self.p as i64,
            self.u as i64,
        );
        if self.flip {
            v[i] = -v[i];
            v[j] = -v[j];
        }
        v[i] += mul_q(p, v[j]);
        v[j] += mul_q(u, v[i]);
        v[i] += mul_q(p, v[j]);
    }

    fn inverse(&self, v: &mut [i64; 3]) {
        let (i, j, p, u) = (
            self.i as usize,
            self.j as usize,
            self.p as i64,
            self.u as i64,
        );
        v[i] -= mul_q(p, v[j]);
        v[j] -= mul_q(u, v[i]);
        v[i] -= mul_q(p, v[j]);
        if self.flip {
            v[i] = -v[i];
            v[j] = -v[j];
        }
    }
}

/// `v` shifted so that its largest magnitude has 24 bits (unchanged when zero).
fn to_24_bits(v: [i128; 3]) -> [i64; 3] {
    let big = v.iter().map(|x| x.unsigned_abs()).max().unwrap_or(0);
    if big == 0 {
        return [0; 3];
    }
    let bits = 128 - big.leading_zeros() as i32;
    let shift = bits - 24;
    if shift >= 0 {
        v.map(|x| (x >> shift) as i64)
    } else {
        v.map(|x| (x << -shift) as i64)
    }
}

/// The rotation of a detail into its orthonormal frame (SPEC.md 10.5): normal `n` onto
/// the first component, then the tangent reference `t` onto the second.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Rotation([Givens; 3]);

impl Rotation {
    fn new(n: [i64; 3], t: [i128; 3]) -> Rotation {
        let (g0, r1) = Givens::towards(0, 1, n[0], n[1]);
        let (g1, _) = Givens::towards(0, 2, r1, n[2]);
        let mut t = to_24_bits(t);
        g0.forward(&mut t);
        g1.forward(&mut t);
        let (g2, _) = Givens::towards(1, 2, t[1], t[2]);
        Rotation([g0, g1, g2])
    }

    fn forward(&self, mut v: [i64; 3]) -> [i64; 3] {
        self.0.iter().for_each(|g| g.forward(&mut v));
        v
    }

    fn inverse(&self, mut v: [i64; 3]) -> [i64; 3] {
        self.0.iter().rev().for_each(|g| g.inverse(&mut v));
        v
    }
}

/// The tangent reference of detail `fd` (SPEC.md 10.5): an edge point's coarse edge,
/// from its first end to its second; a face point's diagonal from its face's first
/// corner to its third (to the second for a triangle).
fn tangent_ref(level: &Level, coarse: &[Vec<i64>; 3], fd: usize) -> [i128; 3] {
    let (a, b) = if fd < level.ne() {
        let [a, b] = level.edges[fd];
        (a, b)
    } else {
        let c = level.coarse.face(fd - level.ne());
        (c[0], if c.len() >= 4 { c[2] } else { c[1] })
    };
    std::array::from_fn(|k| coarse[k][b as usize] as i128 - coarse[k][a as usize] as i128)
}

/// Format 17's along-edge offset (SPEC.md 10.5): sixteen times the offset of the mean of
/// an interior edge's two coarse face centroids from the edge's midpoint, rounded; `None`
/// for a boundary edge or a component above 2^52.
fn edge_offset(level: &Level, coarse: &[Vec<i64>; 3], e: usize) -> Option<[i64; 3]> {
    let [f1, f2] = level.edge_faces[e];
    if f1 == crate::topology::NONE || f2 == crate::topology::NONE {
        return None;
    }
    let (c1, c2) = (
        level.coarse.face(f1 as usize),
        level.coarse.face(f2 as usize),
    );
    let (k1, k2) = (c1.len() as i128, c2.len() as i128);
    let [a, b] = level.edges[e];
    let mut out = [0i64; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let x = &coarse[k];
        let sum = |c: &[u32]| c.iter().map(|&v| x[v as usize] as i128).sum::<i128>();
        let ends = x[a as usize] as i128 + x[b as usize] as i128;
        let num = 16 * (k2 * sum(c1) + k1 * sum(c2) - k1 * k2 * ends);
        let v = crate::transform::round_div(num, 2 * k1 * k2);
        if v.abs() > 1 << 52 {
            return None;
        }
        *o = v;
    }
    Some(out)
}

/// A detail's rotation into its frame (SPEC.md 10.5) and, for an interior edge point,
/// its rotated edge offset (see [`edge_offset`]).
#[derive(Clone, Copy)]
struct RotFrame {
    rot: Rotation,
    offset: Option<[i64; 3]>,
}

impl RotFrame {
    /// The frame of detail `fd` with coarse normal `n`; without an edge point's offset
    /// unless `offset` (only [`Mode::Shifted`] reads it).
    fn new(
        level: &Level,
        coarse: &[Vec<i64>; 3],
        sqrt2: bool,
        fd: usize,
        n: [i64; 3],
        offset: bool,
    ) -> Self {
        let rot = Rotation::new(n, tangent_ref(level, coarse, fd));
        let offset = if offset && !sqrt2 && fd < level.ne() {
            edge_offset(level, coarse, fd).map(|v| rot.forward(v))
        } else {
            None
        };
        RotFrame { rot, offset }
    }

    /// What mode `mode` subtracts from the rotated values: eighths `(a, b)` of the
    /// offset's tangential values with [`Mode::Shifted`], else nothing.
    fn pred(&self, mode: Mode<'_>) -> [i64; 3] {
        match (mode, self.offset) {
            (Mode::Shifted(a, b), Some(w)) => [
                0,
                crate::transform::round_div(a as i128 * w[1] as i128, 128),
                crate::transform::round_div(b as i128 * w[2] as i128, 128),
            ],
            _ => [0; 3],
        }
    }
}

/// Every detail's [`RotFrame`] (`None` where the coarse normal is zero), computed once
/// per level for all the encoder's rotated modes, from the coarse faces' `normals`.
fn rot_frames(
    level: &Level,
    coarse: &[Vec<i64>; 3],
    normals: &[[i128; 3]],
    sqrt2: bool,
) -> Vec<Option<RotFrame>> {
    let ne = if sqrt2 { level.ne() } else { 0 };
    (0..details(level, sqrt2))
        .map(|i| {
            let fd = ne + i;
            frame(level, normals, fd).map(|(_, n)| RotFrame::new(level, coarse, sqrt2, fd, n, true))
        })
        .collect()
}

/// The encoder's choice of mode 5's shift weights for a level (not normative): for
/// each tangential value the eighth in 0..=8 whose residuals have the fewest bits.
fn shift_weights(level: &Level, x: &[Vec<i64>; 3], frames: &[Option<RotFrame>]) -> (u8, u8) {
    let mut cost = [[0u64; 9]; 2];
    for (i, f) in frames.iter().enumerate() {
        let Some(RotFrame {
            rot,
            offset: Some(w),
        }) = f
        else {
            continue;
        };
        let d = rot.forward([x[0][level.nv + i], x[1][level.nv + i], x[2][level.nv + i]]);
        for (slot, c) in cost.iter_mut().enumerate() {
            for (q, cq) in c.iter_mut().enumerate() {
                let p = crate::transform::round_div(q as i128 * w[slot + 1] as i128, 128);
                *cq += class_of(d[slot + 1].saturating_sub(p)) as u64;
            }
        }
    }
    let best = |c: &[u64; 9]| (0..9).min_by_key(|&q| (c[q], q)).unwrap_or(0) as u8;
    (best(&cost[0]), best(&cost[1]))
}

/// How a detail's values are phased (SPEC.md 10.6, 10.7).
#[derive(Clone, Copy)]
enum Phased {
    /// Not at all (modes 0 to 5).
    No,
    /// Mode 6: every value signed and modelled by the phase of its axis.
    Axes([u8; 3]),
    /// Mode 7: the values after the first shifted by their expected part and phased.
    Tangent(TanTerms),
}

/// Mode 7's terms of a detail (SPEC.md 10.7): `u_d = rho_d + c Q_d` per axis, with `rho`
/// the remainders of its face's centroid, `Q` the normal part of its tangent target, `c`
/// its face's corner count.
#[derive(Clone, Copy)]
struct TanTerms {
    u: [i128; 3],
    c: i128,
}

impl TanTerms {
    /// The terms of the face point of face `f` whose tangent target `g` has the
    /// tangential part `t` (so `Q = g - t`), from the coarse values.
    fn new(level: &Level, coarse: &[Vec<i64>; 3], f: usize, g: [i64; 3], t: [i64; 3]) -> Self {
        let face = level.coarse.face(f);
        let c = face.len() as i128;
        let mut u = [0i128; 3];
        for (k, uk) in u.iter_mut().enumerate() {
            let x = &coarse[k];
            // Values below 2^52 (9.3): a face of up to 2^10 corners sums in 64 bits.
            let s = if face.len() <= 1 << 10 {
                face.iter().map(|&v| x[v as usize]).sum::<i64>() as i128
            } else {
                face.iter().map(|&v| x[v as usize] as i128).sum()
            };
            let rho = s - c * crate::transform::round_div(s, c) as i128;
            *uk = rho + c * (g[k] as i128 - t[k] as i128);
        }
        TanTerms { u, c }
    }

    /// The shift and phase of the value at axis `j` (not the first, `k`) given the first
    /// value `rk` and the value's prediction `pred = [rk n_j / n_k]`: `A / D` with
    /// `A = n_k u_j - n_j u_k + c (rk n_j - n_k pred)`, `D = c n_k` (both negated when
    /// `n_k < 0`) is its expected value; the shift is `[A / D]`, the phase that of the
    /// remainder. `None` when the shift's magnitude passes 2^52.
    fn shift(&self, n: [i64; 3], k: usize, j: usize, rk: i64, pred: i64) -> Option<(i64, u8)> {
        self.shift_64(n, k, j, rk, pred)
            .unwrap_or_else(|| self.shift_128(n, k, j, rk, pred))
    }

    /// [`TanTerms::shift`] in 128-bit arithmetic.
    fn shift_128(&self, n: [i64; 3], k: usize, j: usize, rk: i64, pred: i64) -> Option<(i64, u8)> {
        let (nk, nj) = (n[k] as i128, n[j] as i128);
        let mut a =
            nk * self.u[j] - nj * self.u[k] + self.c * (rk as i128 * nj - nk * pred as i128);
        let mut d = self.c * nk;
        if d < 0 {
            a = -a;
            d = -d;
        }
        // 9.1's rounding, in 64 bits when it fits (a 128-bit division is slow).
        let q = match (i64::try_from(2 * a + d), i64::try_from(2 * d)) {
            (Ok(t), Ok(dd)) => t.div_euclid(dd) as i128,
            _ => (2 * a + d).div_euclid(2 * d),
        };
        if q.abs() > MAX_LIFTED as i128 {
            return None;
        }
        Some((q as i64, phase(a - q * d, d)))
    }

    /// [`TanTerms::shift`] in 64-bit arithmetic, the same integers exactly; `None`
    /// when a term would overflow (then 128 bits decide).
    #[inline]
    fn shift_64(
        &self,
        n: [i64; 3],
        k: usize,
        j: usize,
        rk: i64,
        pred: i64,
    ) -> Option<Option<(i64, u8)>> {
        let (nk, nj) = (n[k], n[j]);
        let (uj, uk, c) = (
            i64::try_from(self.u[j]).ok()?,
            i64::try_from(self.u[k]).ok()?,
            i64::try_from(self.c).ok()?,
        );
        let inner = rk.checked_mul(nj)?.checked_sub(nk.checked_mul(pred)?)?;
        let mut a = nk
            .checked_mul(uj)?
            .checked_sub(nj.checked_mul(uk)?)?
            .checked_add(c.checked_mul(inner)?)?;
        let mut d = c.checked_mul(nk)?;
        if d < 0 {
            a = a.checked_neg()?;
            d = d.checked_neg()?;
        }
        let q = a
            .checked_mul(2)?
            .checked_add(d)?
            .div_euclid(d.checked_mul(2)?);
        if q.abs() > MAX_LIFTED {
            return Some(None);
        }
        let r = a.checked_sub(q.checked_mul(d)?)?;
        Some(Some((q, phase(r as i128, d as i128))))
    }
}

/// Codes detail `d` (components in the order of frame `fr`, each with its neighbour bin
/// `nbr[slot]`; phased as `ph` says); returns the magnitude classes of the coded values,
/// or `None` when mode 7's shift is out of range.
#[allow(clippy::too_many_arguments)]
fn put(
    enc: &mut Encoder,
    m: &mut Models,
    class: usize,
    nbr: [usize; 3],
    d: [i64; 3],
    fr: Option<(usize, [i64; 3])>,
    ph: Phased,
    unbinned: bool,
    zero: u8,
) -> Option<[u8; 3]> {
    let (order, n) = plan(fr);
    let mut prev = 0;
    let mut mags = [0u8; 3];
    for (slot, &axis) in order.iter().enumerate() {
        let pred = match (slot, n) {
            (1 | 2, Some(n)) => predict(d[order[0]], n, order[0], axis),
            _ => 0,
        };
        let mut v = d[axis] - pred;
        let q = match (ph, n) {
            (Phased::Axes(p), _) => Some(p[axis]),
            (Phased::Tangent(t), Some(n)) if slot > 0 => {
                let (s, q) = t.shift(n, order[0], axis, d[order[0]], pred)?;
                v = v.checked_sub(s).filter(|v| v.abs() <= MAX_LIFTED)?;
                Some(q)
            }
            _ => None,
        };
        if q.is_some_and(|q| q & 4 != 0) {
            v = -v;
        }
        // A zero slot's values are left out: all 0, else not this coding.
        if zero >> slot & 1 == 1 {
            if v != 0 {
                return None;
            }
            prev = 0;
            continue;
        }
        let c = Ctx {
            class,
            slot,
            prev,
            nbr: nbr[slot],
            bin: q.map(|q| (q & 3) as usize),
            unbinned,
        };
        enc.int(m.model(c), v);
        m.learn(c, v);
        prev = class_of(v);
        mags[slot] = prev as u8;
    }
    Some(mags)
}

#[allow(clippy::too_many_arguments)]
fn get(
    dec: &mut Decoder,
    m: &mut Models,
    class: usize,
    nbr: [usize; 3],
    fr: Option<(usize, [i64; 3])>,
    ph: Phased,
    unbinned: bool,
    zero: u8,
) -> Result<([i64; 3], [u8; 3])> {
    let (order, n) = plan(fr);
    let mut d = [0i64; 3];
    let mut prev = 0;
    let mut mags = [0u8; 3];
    let bad = || Error::corrupt("LEVL", "detail out of range");
    for (slot, &axis) in order.iter().enumerate() {
        let pred = match (slot, n) {
            (1 | 2, Some(n)) => predict(d[order[0]], n, order[0], axis),
            _ => 0,
        };
        let q = match (ph, n) {
            (Phased::Axes(p), _) => Some((0, p[axis])),
            (Phased::Tangent(t), Some(n)) if slot > 0 => Some(
                t.shift(n, order[0], axis, d[order[0]], pred)
                    .ok_or_else(bad)?,
            ),
            _ => None,
        };
        let c = Ctx {
            class,
            slot,
            prev,
            nbr: nbr[slot],
            bin: q.map(|(_, q)| (q & 3) as usize),
            unbinned,
        };
        // A zero slot's values are not in the stream, and no model learns
        // them.
        let v = if zero >> slot & 1 == 1 {
            0
        } else {
            let v = dec.int(m.model(c))?;
            m.learn(c, v);
            v
        };
        prev = class_of(v);
        let v = match q {
            Some((s, q)) => {
                // (|v| < 2^62: the negation cannot overflow.)
                let v = if q & 4 != 0 { -v } else { v };
                v.checked_add(s).ok_or_else(bad)?
            }
            None => v,
        };
        mags[slot] = prev as u8;
        let x = v.checked_add(pred).filter(|x| x.abs() <= MAX_LIFTED);
        d[axis] = x.ok_or_else(bad)?;
    }
    Ok((d, mags))
}

/// Codes the details `x[k][nv..]` of one level (a sqrt(2) step when `sqrt2`). `coarse`
/// holds the level's coarse values (what the decoder has when it reads this level).
/// The payload starts with a mode byte, and the encoder keeps the mode that codes
/// smallest (SPEC.md 10.2, 10.5). `None` (`models` then unusable) when the payload would
/// take more than `limit` bytes in every mode: a caller that only wants a smaller coding
/// than one it has stops early.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    level: &Level,
    sqrt2: bool,
    x: &[Vec<i64>; 3],
    coarse: &[Vec<i64>; 3],
    models: &mut LevelModels,
    targets: Option<&[[i64; 3]]>,
    phases: Option<&Phases>,
    limit: usize,
) -> Option<Vec<u8>> {
    // The mode asked for this level, if any. Plain axes with or without phases (modes 0
    // and 6) count as one: a plan made with a transform without phases leaves a
    // transform with them free to use them, and the other way round. (Modes 2 and 7 are
    // open to the same levels: a plan names the one to use.)
    let only = models.only.as_mut().and_then(Iterator::next);
    // A plan's unbinned flag is followed; without a plan the level's best mode is tried
    // unbinned as well.
    let plan_unbinned = only.map(|o| unbinned(&[o]));
    let only = only.and_then(|o| mode_of(&[o]));
    let plain = |m: u8| matches!(m, 0 | 6);
    let open = |m: u8| only.is_none_or(|o| o == m || (plain(o) && plain(m)));
    let mut modes = vec![Mode::Plain, Mode::Framed];
    if let Some(t) = targets {
        modes.push(Mode::Tangent(t));
        modes.push(Mode::TangentPhased(t));
    }
    if phases.is_some() {
        modes.push(Mode::Phased);
    }
    let mut prep = Prepared::default();
    if !sqrt2 && (open(8) || open(9)) {
        let made = corr_weights(level, x).and_then(|w| Some((w, corrections(level, x, &w)?)));
        if let Some((w, c)) = made {
            modes.push(Mode::Corrected(w));
            if phases.is_some() {
                modes.push(Mode::CorrectedPhased(w, Rounding::Apart));
                modes.push(Mode::CorrectedPhased(w, Rounding::Joint));
            }
            prep.corrections = c;
        }
    }
    let rotated = models.rotated && (open(4) || open(5));
    if rotated {
        modes.push(Mode::Rotated);
        prep.normals = face_normals(level, coarse);
        prep.frames = rot_frames(level, coarse, &prep.normals, sqrt2);
        match shift_weights(level, x, &prep.frames) {
            (0, 0) => {}
            (a, b) => modes.push(Mode::Shifted(a, b)),
        }
    }
    if modes.iter().any(|m| open(m.byte())) {
        modes.retain(|m| open(m.byte()));
    }
    // The normals, once for every mode that reads them.
    if prep.normals.is_empty() && modes.iter().any(|m| m.framed()) {
        prep.normals = face_normals(level, coarse);
    }
    let start = models.start();
    // The smallest mode's payload, with the magnitudes and models it leaves.
    struct Tried {
        mode: Vec<u8>,
        body: Vec<u8>,
        mags: Vec<[u8; 3]>,
        models: Models,
    }
    // The previous level's mode is tried first: a mode is abandoned once its stream
    // passes the best size so far, and the best is often the previous level's. Ties go
    // to the first mode in `modes`' order whatever the order of trying.
    let mut order: Vec<usize> = (0..modes.len()).collect();
    if let Some(i) = modes
        .iter()
        .position(|m| Some(m.byte()) == models.prev_mode)
    {
        order.remove(i);
        order.insert(0, i);
    }
    // Codes the level in mode `i` (unbinned or not) and keeps it in `best` if smaller.
    // A stream longer than `cap` or than the best so far is abandoned; ties go to the
    // first mode in `modes`' order whatever the order of trying.
    let attempt = |best: &mut Option<(usize, Tried)>, i: usize, unbinned: bool, cap: usize| {
        let mode = modes[i];
        let mut bytes = mode.bytes();
        if unbinned {
            bytes[0] |= UNBINNED;
        }
        let head = bytes.len();
        let room = best
            .as_ref()
            .map_or(cap, |(_, b)| (b.body.len() + b.mode.len()).min(cap))
            .saturating_sub(head);
        // Codes the level in this mode with zero slots `zero`.
        let code = |zero: u8| {
            let mut mg = models.mags.clone();
            let mut m = models.ready(start.clone(), mode);
            let body = encode_mode(
                level, sqrt2, x, coarse, &prep, phases, &mut mg, mode, unbinned, &mut m, room, zero,
            )?;
            let mut mode_bytes = bytes.clone();
            mode_bytes[0] |= zero << ZERO_SHIFT;
            Some(Tried {
                mode: mode_bytes,
                body,
                mags: mg,
                models: m,
            })
        };
        let Some(mut tried) = code(axis_zero_slots(level, sqrt2, x, mode, &prep, phases)) else {
            return;
        };
        // A mode whose slots are not the axes (a frame's) shows its zero slots once coded,
        // as a flat mesh's normal part: coded again without them, kept if smaller.
        if mode.framed() {
            let fine = &tried.mags[level.nv..];
            let zero = (0..3)
                .filter(|&s| fine.iter().all(|g| g[s] == 0))
                .fold(0, |z, s| z | 1 << s);
            if zero != 0 && !fine.is_empty() {
                if let Some(t) = code(zero).filter(|t| t.body.len() <= tried.body.len()) {
                    tried = t;
                }
            }
        }
        let size = tried.body.len() + head;
        if best.as_ref().is_none_or(|(j, b)| {
            let bs = b.body.len() + b.mode.len();
            size < bs || (size == bs && i < *j)
        }) {
            *best = Some((i, tried));
        }
    };
    // Without a plan, the open modes binned, then the best of them unbinned (kept only
    // if strictly smaller). While that trial is to come, the binned ones are not cut at
    // the limit: their best is the mode tried unbinned, which may fit where they do not.
    let unbinned_trial = plan_unbinned.is_none();
    let cap = if unbinned_trial { usize::MAX } else { limit };
    let mut best: Option<(usize, Tried)> = None;
    for i in order {
        attempt(&mut best, i, plan_unbinned.unwrap_or(false), cap);
    }
    if let Some(j) = best.as_ref().map(|(j, _)| *j).filter(|_| unbinned_trial) {
        attempt(&mut best, j, true, limit);
    }
    let best = best.map(|(i, t)| {
        models.prev_mode = Some(modes[i].byte());
        models.last_phased = modes[i].phased();
        t
    });
    let Tried {
        mode,
        body,
        mags,
        models: m,
    } = best?;
    if mode.len() + body.len() > limit {
        return None;
    }
    models.mags = mags;
    models.last = Some(m);
    let mut out = Vec::with_capacity(body.len() + 2);
    out.extend_from_slice(&mode);
    out.extend_from_slice(&body);
    Some(out)
}

/// How a level's details are coded (SPEC.md 10.2, 10.3).
#[derive(Clone, Copy)]
enum Mode<'a> {
    /// x, y, z as they are.
    Plain,
    /// In the coarse normal's frame.
    Framed,
    /// In the normal's frame, less each detail's target's tangential part.
    Tangent(&'a [[i64; 3]]),
    /// Rotated into the orthonormal frame of the normal and the coarse edge or face
    /// diagonal.
    Rotated,
    /// Rotated, and an interior edge point's tangential values less eighths `(a, b)` of
    /// its faces' offset.
    Shifted(u8, u8),
    /// x, y, z signed and modelled by their predictions' phases.
    Phased,
    /// Mode 2 with the values after the first shifted by their expected parts and
    /// phased.
    TangentPhased(&'a [[i64; 3]]),
    /// x, y, z less weighted sums of the level's earlier details nearby (Catmull-Clark
    /// levels).
    Corrected(Weights),
    /// Mode 8's values, phased as mode 6's; with the joint flag, each correction
    /// rounded with the prediction's fraction and the value phased by their sum.
    CorrectedPhased(Weights, Rounding),
}

/// Where a level's phases come from in the decoder (SPEC.md 10.6).
pub enum Phasing<'a> {
    /// Every detail's, known before the level is read (sqrt2-lazy: from the coarse
    /// values).
    Ready(&'a Phases),
    /// A Catmull-Clark level of a predict-only transform: the edge points' from the
    /// coarse values, the face points' once the edge points are read. The decoder then
    /// synthesises the level as it reads it: [`decode`] leaves the fine values, not the
    /// details.
    Cc(&'a crate::transform::Phaser<'a>),
}

impl Mode<'_> {
    /// The level's mode bytes: the mode, and mode 5's shift weights or mode 8 and 9's
    /// weights.
    fn bytes(self) -> Vec<u8> {
        match self {
            Mode::Shifted(a, b) => vec![5, a << 4 | b],
            Mode::Corrected(w) | Mode::CorrectedPhased(w, _) => {
                let joint = matches!(self, Mode::CorrectedPhased(_, Rounding::Joint));
                let mut out = vec![self.byte(), if joint { JOINT } else { 0 }];
                for (j, p) in w.iter().flatten().enumerate() {
                    if *p != [0; NFEAT] {
                        out[1] |= 1 << j;
                        out.extend(p.map(|v| v as u8));
                    }
                }
                out
            }
            _ => vec![self.byte()],
        }
    }

    fn byte(self) -> u8 {
        match self {
            Mode::Plain => 0,
            Mode::Framed => 1,
            Mode::Tangent(_) => 2,
            Mode::Rotated => 4,
            Mode::Shifted(..) => 5,
            Mode::Phased => 6,
            Mode::TangentPhased(_) => 7,
            Mode::Corrected(_) => 8,
            Mode::CorrectedPhased(..) => 9,
        }
    }

    /// Modes 6, 7 and 9, whose values are modelled by their phases.
    fn phased(self) -> bool {
        matches!(
            self,
            Mode::Phased | Mode::TangentPhased(_) | Mode::CorrectedPhased(..)
        )
    }

    fn framed(self) -> bool {
        !matches!(
            self,
            Mode::Plain | Mode::Phased | Mode::Corrected(_) | Mode::CorrectedPhased(..)
        )
    }

    /// What is subtracted from detail `i` before coding it in frame `fr`.
    fn offset(self, i: usize, fr: Option<(usize, [i64; 3])>) -> Option<[i64; 3]> {
        match (self, fr) {
            (Mode::Tangent(t) | Mode::TangentPhased(t), Some((_, n))) => Some(tangential(t[i], n)),
            _ => None,
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn encode_mode(
    level: &Level,
    sqrt2: bool,
    x: &[Vec<i64>; 3],
    coarse: &[Vec<i64>; 3],
    prep: &Prepared,
    phases: Option<&Phases>,
    mags: &mut Vec<[u8; 3]>,
    mode: Mode<'_>,
    unbinned: bool,
    m: &mut Models,
    limit: usize,
    zero: u8,
) -> Option<Vec<u8>> {
    let mut enc = Encoder::new();
    let (nv, nd) = (level.nv, details(level, sqrt2));
    // The rotated modes take their frames (normals included), the normal-frame modes
    // the normals and modes 8 and 9 their corrections from `prep`, made once per level.
    let rotated = matches!(mode, Mode::Rotated | Mode::Shifted(..));
    let corrected = matches!(mode, Mode::Corrected(_) | Mode::CorrectedPhased(..));
    let framed = mode.framed() && !rotated;
    if (rotated && prep.frames.len() != nd)
        || (corrected && prep.corrections.len() != nd)
        || (framed && prep.normals.len() != level.nf())
    {
        return None;
    }
    let phased = matches!(mode, Mode::Phased | Mode::CorrectedPhased(..));
    let phases = phases.filter(|_| phased);
    if phased && !phases.is_some_and(|p| p.codes.iter().all(|p| p.len() == nd)) {
        return None;
    }
    // Mode 9 with joint rounding rounds each correction with the prediction's fraction.
    let joint = matches!(mode, Mode::CorrectedPhased(_, Rounding::Joint));
    if joint && !phases.is_some_and(|p| p.fracs.iter().all(|p| p.len() == nd)) {
        return None;
    }
    mags.resize(nv, [UNKNOWN; 3]);
    mags.resize(nv + nd, [0; 3]);
    for i in 0..nd {
        let (class, bins, fd) = contexts(level, mags, sqrt2, i);
        let mut d = [x[0][nv + i], x[1][nv + i], x[2][nv + i]];
        let fr = if framed {
            frame(level, &prep.normals, fd)
        } else {
            None
        };
        let mut joint_phases = None;
        let offset = match (corrected, phases) {
            (true, Some(p)) if joint => {
                let n = prep.corrections[i].map(i128::from);
                let (c, q) = joint_correction(n, fracs_at(p, i))?;
                joint_phases = Some(q);
                Some(c)
            }
            (true, _) => Some(correction(prep.corrections[i].map(i128::from))?),
            (false, _) => mode.offset(i, fr),
        };
        if let Some(c) = offset {
            d = std::array::from_fn(|k| d[k] - c[k]);
            if d.iter().any(|v| v.abs() > MAX_LIFTED) {
                return None;
            }
        }
        if let Some(f) = prep
            .frames
            .get(i)
            .and_then(Option::as_ref)
            .filter(|_| rotated)
        {
            let (r, pred) = (f.rot.forward(d), f.pred(mode));
            if r.iter().any(|v| v.abs() > MAX_LIFTED) {
                return None;
            }
            d = std::array::from_fn(|k| r[k] - pred[k]);
            if d.iter().any(|v| v.abs() > MAX_LIFTED) {
                return None;
            }
        }
        let ph = match (joint_phases, mode, phases, fr) {
            (Some(q), ..) => Phased::Axes(q),
            (_, _, Some(p), _) => Phased::Axes(phases_at(p, i)),
            (_, Mode::TangentPhased(t), _, Some(_)) => {
                Phased::Tangent(TanTerms::new(level, coarse, i, t[i], offset?))
            }
            _ => Phased::No,
        };
        mags[nv + i] = put(&mut enc, m, class, bins, d, fr, ph, unbinned, zero)?;
        if i % 64 == 63 && enc.written() > limit {
            return None;
        }
    }
    let body = enc.finish();
    (body.len() <= limit).then_some(body)
}

/// The zero slots of a mode that codes the axes themselves (0, 6, 8 or 9): the axes
/// whose details `x[k][nv..nv + nd]` are all 0 and stay 0 once corrected (modes 8 and 9;
/// with joint rounding a prediction's fraction alone can make a correction). 0 for the
/// other modes and on a level without details.
fn axis_zero_slots(
    level: &Level,
    sqrt2: bool,
    x: &[Vec<i64>; 3],
    mode: Mode<'_>,
    prep: &Prepared,
    phases: Option<&Phases>,
) -> u8 {
    let (nv, nd) = (level.nv, details(level, sqrt2));
    if mode.framed() || nd == 0 {
        return 0;
    }
    let corrected = matches!(mode, Mode::Corrected(_) | Mode::CorrectedPhased(..));
    let joint = matches!(mode, Mode::CorrectedPhased(_, Rounding::Joint));
    let mut zero = 0;
    for k in 0..3 {
        let fractions_round_to_0 = || {
            phases.is_some_and(|p| {
                p.fracs[k]
                    .iter()
                    .all(|&f| joint_correction([0; 3], [f, 0, 0]).is_some_and(|(c, _)| c[0] == 0))
            })
        };
        if x[k][nv..nv + nd].iter().all(|&v| v == 0)
            && (!corrected || prep.corrections.iter().all(|n| n[k] == 0))
            && (!joint || fractions_round_to_0())
        {
            zero |= 1 << k;
        }
    }
    zero
}

/// `a + b` per component, `None` on overflow (see [`in_range`]).
fn plus(a: [i64; 3], b: [i64; 3]) -> Option<[i64; 3]> {
    Some([
        a[0].checked_add(b[0])?,
        a[1].checked_add(b[1])?,
        a[2].checked_add(b[2])?,
    ])
}

/// A decoded detail within the bound of SPEC.md 9.3, else a corrupt level.
fn in_range(d: Option<[i64; 3]>) -> Result<[i64; 3]> {
    d.filter(|d| d.iter().all(|v| v.abs() <= MAX_LIFTED))
        .ok_or_else(|| Error::corrupt("LEVL", "detail out of range"))
}

/// Decodes what [`encode`] wrote into `x[k][nv..]`; `x[k][..nv]` are the coarse values.
/// `targets` are the level's tangent targets (modes 2 and 7), `phasing` its phases (mode
/// 6), each where the level has them.
#[allow(clippy::too_many_arguments)]
pub fn decode(
    payload: &[u8],
    level: &Level,
    sqrt2: bool,
    x: &mut [Vec<i64>; 3],
    models: &mut LevelModels,
    targets: Option<&[[i64; 3]]>,
    phasing: Option<Phasing<'_>>,
) -> Result<()> {
    let (nv, nd) = (level.nv, details(level, sqrt2));
    // Density bound (SPEC.md 2.6), checked before the level's arrays are sized.
    if nd as u64 > 2048 * (payload.len() as u64 + 8) {
        return Err(Error::corrupt(
            "LEVL",
            format!("{} bytes cannot hold {} details", payload.len(), nd),
        ));
    }
    let no_targets = || Error::corrupt("LEVL", "tangent mode on a level without tangent targets");
    let no_phases = || Error::corrupt("LEVL", "phase mode on a level without prediction phases");
    // The mode byte's top bit makes the level unbinned; bits 4 to 6 are the slots left
    // out of the stream.
    let unbinned = unbinned(payload);
    let zero = zero_slots(payload);
    let (mode, payload) = match mode_of(payload).zip(payload.get(1..)) {
        Some((0, rest)) => (Mode::Plain, rest),
        Some((1, rest)) => (Mode::Framed, rest),
        Some((2, rest)) => match targets {
            Some(t) if t.len() == nd => (Mode::Tangent(t), rest),
            _ => return Err(no_targets()),
        },
        Some((7, rest)) => match targets {
            Some(t) if t.len() == nd => (Mode::TangentPhased(t), rest),
            _ => return Err(no_targets()),
        },
        Some((4, rest)) => (Mode::Rotated, rest),
        Some((6, rest)) => match &phasing {
            Some(Phasing::Ready(p)) if p.codes.iter().all(|p| p.len() == nd) => {
                (Mode::Phased, rest)
            }
            Some(Phasing::Cc(_)) if !sqrt2 => (Mode::Phased, rest),
            _ => return Err(no_phases()),
        },
        Some((5, rest)) => match rest.split_first() {
            Some((&w, rest)) if w >> 4 <= 8 && w & 15 <= 8 => (Mode::Shifted(w >> 4, w & 15), rest),
            _ => return Err(Error::corrupt("LEVL", "bad shift weights")),
        },
        Some((8, rest)) if !sqrt2 => {
            let (w, _, rest) = read_weights(rest, false)?;
            (Mode::Corrected(w), rest)
        }
        Some((9, rest)) if !sqrt2 => match &phasing {
            Some(Phasing::Cc(_)) => {
                let (w, r, rest) = read_weights(rest, true)?;
                (Mode::CorrectedPhased(w, r), rest)
            }
            _ => return Err(no_phases()),
        },
        Some((m, _)) => return Err(Error::corrupt("LEVL", format!("unknown level mode {m}"))),
        None => return Err(Error::corrupt("LEVL", "empty level section")),
    };
    let framed = mode.framed();
    let mut dec = Decoder::new(payload, "LEVL")?;
    let mut m = models.ready(models.start(), mode);
    models.last_phased = mode.phased();
    let mags = &mut models.mags;
    mags.resize(nv, [UNKNOWN; 3]);
    mags.resize(nv + nd, [0; 3]);
    let normals = if framed {
        face_normals(level, x)
    } else {
        Vec::new()
    };
    for xs in x.iter_mut() {
        xs.resize(nv + nd, 0);
    }
    // Modes 6 and 9: the phases, given, or a Catmull-Clark level's made as it is read:
    // the edge points' from the coarse values now, the face points' from the fine edge
    // points, so such a level is synthesised as it is read (see [`Phasing::Cc`]). Mode 9
    // makes every face point's phases once its edge points are read, then reads the face
    // points with the edge points' details in place (its corrections read details), and
    // synthesises the level after, from the predictions it kept.
    let corr_phased = matches!(mode, Mode::CorrectedPhased(..));
    let phasing = phasing.filter(|_| matches!(mode, Mode::Phased) || corr_phased);
    let ne = level.ne();
    // Mode 9: every detail's prediction on each axis (the edge points' now, the face
    // points' once the edge points are read), and its phase.
    let mut preds: [Vec<i64>; 3] = Default::default();
    let mut cc_phases = Phases::default();
    // Mode 9 with joint rounding also reads the predictions' fractions.
    let joint = matches!(mode, Mode::CorrectedPhased(_, Rounding::Joint));
    // Mode 9: detail `i`'s prediction, phase and (joint rounding) fraction on one axis.
    let keep =
        |p: &crate::transform::Phaser<'_>, xk: &[i64], i: usize, ph: &mut Phases, k: usize| {
            if joint {
                let (c, q, f) = p.predict_frac(xk, i);
                ph.codes[k].push(q);
                ph.fracs[k].push(f);
                c
            } else {
                let (c, q) = p.predict(xk, i);
                ph.codes[k].push(q);
                c
            }
        };
    if let Some(Phasing::Cc(p)) = &phasing {
        if corr_phased {
            for k in 0..3 {
                for e in 0..ne.min(nd) {
                    let c = keep(p, &x[k], e, &mut cc_phases, k);
                    preds[k].push(c);
                }
            }
        } else {
            cc_phases = p.phases(x, ne.min(nd), false);
        }
    }
    for i in 0..nd {
        // What a Catmull-Clark level in mode 6 adds to the detail: its prediction.
        let mut fine = [0i64; 3];
        match &phasing {
            Some(Phasing::Cc(p)) if i == ne && corr_phased => {
                // The face points' predictions from the fine edge points; then the edge
                // points' details again.
                for k in 0..3 {
                    let xk = &mut x[k];
                    for e in 0..ne {
                        xk[nv + e] = xk[nv + e].wrapping_add(preds[k][e]);
                    }
                    for f in ne..nd {
                        let c = keep(p, xk, f, &mut cc_phases, k);
                        preds[k].push(c);
                    }
                    for e in 0..ne {
                        xk[nv + e] = xk[nv + e].wrapping_sub(preds[k][e]);
                    }
                }
            }
            Some(Phasing::Cc(p)) if i == ne => synthesise_edges(p, level, x),
            _ => {}
        }
        let (class, bins, fd) = contexts(level, mags, sqrt2, i);
        let fr = if framed {
            frame(level, &normals, fd)
        } else {
            None
        };
        let rotation = match (mode, fr) {
            (Mode::Rotated | Mode::Shifted(..), Some((_, n))) => {
                let shifted = matches!(mode, Mode::Shifted(..));
                let f = RotFrame::new(level, x, sqrt2, fd, n, shifted);
                Some((f.rot, f.pred(mode)))
            }
            _ => None,
        };
        let out_of_range = || Error::corrupt("LEVL", "detail out of range");
        let mut joint_phases = None;
        let offset = match mode {
            Mode::CorrectedPhased(w, Rounding::Joint) => {
                let n = correction_sums(level, x, &w, i);
                let (c, q) =
                    joint_correction(n, fracs_at(&cc_phases, i)).ok_or_else(out_of_range)?;
                joint_phases = Some(q);
                Some(c)
            }
            Mode::Corrected(w) | Mode::CorrectedPhased(w, _) => {
                Some(correction(correction_sums(level, x, &w, i)).ok_or_else(out_of_range)?)
            }
            _ => mode.offset(i, fr),
        };
        let ph = match (joint_phases, &phasing, mode, offset) {
            (Some(q), ..) => Phased::Axes(q),
            (_, Some(Phasing::Ready(p)), ..) => Phased::Axes(phases_at(p, i)),
            (_, Some(Phasing::Cc(_)), ..) if i < ne || corr_phased => {
                Phased::Axes(phases_at(&cc_phases, i))
            }
            (_, Some(Phasing::Cc(p)), ..) => {
                let mut q = [0u8; 3];
                for k in 0..3 {
                    (fine[k], q[k]) = p.predict(&x[k], i);
                }
                Phased::Axes(q)
            }
            (_, None, Mode::TangentPhased(t), Some(c)) => {
                Phased::Tangent(TanTerms::new(level, x, i, t[i], c))
            }
            _ => Phased::No,
        };
        let (r, mg) = get(
            &mut dec,
            &mut m,
            class,
            bins,
            fr.filter(|_| rotation.is_none()),
            ph,
            unbinned,
            zero,
        )?;
        mags[nv + i] = mg;
        let mut d = r;
        if let Some((rot, pred)) = rotation {
            d = in_range(Some(rot.inverse(in_range(plus(r, pred))?)))?;
        }
        if let Some(c) = offset {
            d = in_range(plus(r, c))?;
        }
        for k in 0..3 {
            x[k][nv + i] = d[k].wrapping_add(fine[k]);
        }
    }
    match &phasing {
        Some(Phasing::Cc(_)) if corr_phased => {
            // Mode 9: the details plus their predictions.
            for (xk, pk) in x.iter_mut().zip(&preds) {
                for (v, &c) in xk[nv..].iter_mut().zip(pk) {
                    *v = v.wrapping_add(c);
                }
            }
        }
        Some(Phasing::Cc(p)) if nd <= ne => synthesise_edges(p, level, x),
        _ => {}
    }
    models.last = Some(m);
    Ok(())
}

/// Synthesises a Catmull-Clark level's edge points `x[k][nv..nv + ne]` in place (their
/// details plus predictions from the coarse values), for mode 6's face points.
fn synthesise_edges(p: &crate::transform::Phaser<'_>, level: &Level, x: &mut [Vec<i64>; 3]) {
    let nv = level.nv;
    for xk in x.iter_mut() {
        for e in 0..level.ne() {
            // Predicted from the coarse values alone: unchanged as the edge points change.
            let c = p.predict(xk, e).0;
            xk[nv + e] = xk[nv + e].wrapping_add(c);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::fixtures::{prism_with_triangles, pseudo};

    /// [`super::encode`] of a Catmull-Clark level without a limit or targets.
    fn encode_fresh(
        level: &Level,
        x: &[Vec<i64>; 3],
        coarse: &[Vec<i64>; 3],
        models: &mut LevelModels,
    ) -> Vec<u8> {
        encode(level, false, x, coarse, models, None, None, usize::MAX).unwrap()
    }

    /// [`super::decode`] of one level from fresh models: the coarse values with the level
    /// read into them.
    fn decode_fresh(
        bytes: &[u8],
        level: &Level,
        sqrt2: bool,
        coarse: &[Vec<i64>; 3],
        targets: Option<&[[i64; 3]]>,
        phasing: Option<Phasing<'_>>,
    ) -> Result<[Vec<i64>; 3]> {
        let mut y = coarse.clone();
        let mut models = LevelModels::new();
        decode(bytes, level, sqrt2, &mut y, &mut models, targets, phasing)?;
        Ok(y)
    }

    fn refined(times: usize) -> Level {
        let mut t = prism_with_triangles();
        for _ in 0..times {
            t = Level::new(&t).unwrap().fine();
        }
        Level::new(&t).unwrap()
    }

    /// Newell's normal in 64 bits where it fits, else in 128: the same integers.
    #[test]
    fn face_normals_agree_with_128_bit_arithmetic() {
        let level = refined(1);
        for (seed, bits) in [(1u64, 20u32), (4, 29), (2, 34), (3, 53)] {
            let mut x: [Vec<i64>; 3] =
                std::array::from_fn(|k| pseudo(seed + k as u64, level.nv, bits));
            if bits == 29 {
                // Values near 2^28 in magnitude, of both signs.
                x[0][0] = (1 << 28) - 1;
                x[1][1] = -(1 << 28) + 1;
            }
            let all = face_normals(&level, &x);
            let mut wide = 0;
            for f in 0..level.nf() {
                let c = level.coarse.face(f);
                let k = c.len();
                let mut n = [0i128; 3];
                for i in 0..k {
                    let (a, b) = (c[i] as usize, c[(i + 1) % k] as usize);
                    let p = |d: usize, v: usize| x[d][v] as i128;
                    n[0] += (p(1, a) - p(1, b)) * (p(2, a) + p(2, b));
                    n[1] += (p(2, a) - p(2, b)) * (p(0, a) + p(0, b));
                    n[2] += (p(0, a) - p(0, b)) * (p(1, a) + p(1, b));
                }
                assert_eq!(face_normal(&level, &x, f), n, "face {f}, {bits}-bit values");
                assert_eq!(all[f], n, "face {f} of all, {bits}-bit values");
                wide += face_normal_64(&level, &x, f).is_none() as usize;
            }
            // Small values never need 128 bits; 53-bit ones always do.
            match bits {
                20 => assert_eq!(wide, 0),
                53 => assert_eq!(wide, level.nf()),
                _ => {}
            }
        }
    }

    #[test]
    fn slot_bins_weigh_ends_twice_and_earlier_edge_points_once() {
        let level = refined(1);
        let (nv, ne) = (level.nv, level.ne());
        let mut mags = vec![[UNKNOWN; 3]; nv + ne];
        // No magnitudes anywhere yet: the "no neighbour" bin.
        assert_eq!(slot_bins(&level, &mags, false, 0), [6; 3]);
        for m in &mut mags[..nv] {
            *m = [2, 0, 9];
        }
        for m in &mut mags[nv..] {
            *m = [4, 4, 4];
        }
        let bin = |m: u32| match m {
            0 => 0,
            1..=2 => 1,
            3..=4 => 2,
            5..=6 => 3,
            7..=9 => 4,
            _ => 5,
        };
        for e in 0..ne {
            let [a, b] = level.edges[e];
            // Earlier edges at either end, counted by brute force.
            let c = (0..e)
                .filter(|&f| {
                    let [x, y] = level.edges[f];
                    [x, y].iter().any(|&v| v == a || v == b)
                })
                .count() as u32;
            let w = 4 + c;
            let want = [2u32, 0, 9].map(|m| bin((4 * m + 4 * c + w / 2) / w));
            assert_eq!(
                slot_bins(&level, &mags, false, e),
                want.map(|b| b as usize),
                "edge {e}"
            );
        }
        // A face point: its edge points only.
        assert_eq!(slot_bins(&level, &mags, false, ne), [2; 3]);
    }

    /// A context model's first use starts from what its class and component learnt in
    /// other contexts, which costs a fraction of starting each uniform.
    #[test]
    fn unused_contexts_start_from_their_shared_model() {
        // Bytes to code two values of 3 in every context of class 0 after the class's
        // three components saw 200 values of 3 each.
        let cost = |shared: bool| {
            let mut m = Models::new();
            for slot in 0..3 {
                for _ in 0..200 {
                    m.observe(0, slot, 3);
                }
            }
            let mut enc = Encoder::new();
            for slot in 0..3 {
                for prev in [0, 3, 7] {
                    for nbr in 0..SLOT_BINS {
                        let mut uniform = IntModel::new();
                        for _ in 0..2 {
                            let model = match shared {
                                true => m.get(0, slot, prev, nbr),
                                false => &mut uniform,
                            };
                            enc.int(model, 3);
                            m.observe(0, slot, 3);
                        }
                    }
                }
            }
            enc.finish().len()
        };
        let (shared, fresh) = (cost(true), cost(false));
        assert!(
            shared * 4 < fresh,
            "shared start {shared} B, uniform {fresh} B"
        );
        // Other classes and components learn nothing from it.
        let mut m = Models::new();
        for _ in 0..200 {
            m.observe(0, 0, 3);
        }
        let mut a = Encoder::new();
        let mut b = Encoder::new();
        let mut fresh = Models::new();
        for _ in 0..50 {
            a.int(m.get(1, 2, 0, 3), 3);
            b.int(fresh.get(1, 2, 0, 3), 3);
        }
        assert_eq!(a.finish(), b.finish());
    }

    /// Details whose large component changes from one half of the level to the other:
    /// per-component neighbourhoods tell the halves apart, a level coded without neighbour
    /// bins (unbinned) does not.
    #[test]
    fn per_slot_contexts_follow_which_component_is_large() {
        let level = refined(3);
        let (nv, nd) = (level.nv, level.ne() + level.nf());
        let noise: Vec<i64> = pseudo(7, 3 * nd, 16);
        // Coarse values zero: no normal frame, the components stay x, y, z.
        let mut x: [Vec<i64>; 3] = std::array::from_fn(|_| vec![0; nv]);
        // The halves: details of (edges beside) the first or the second half of the
        // coarse faces, which lie together as they descend from the base faces in order.
        let (ne, nf) = (level.ne(), level.nf());
        for i in 0..nd {
            let f = if i < ne {
                level.edge_faces[i][0] as usize
            } else {
                i - ne
            };
            let big = if f < nf / 2 { 0 } else { 1 };
            for k in 0..3 {
                let v = noise[3 * i + k];
                x[k].push(if k == big { v >> 2 } else { v >> 13 });
            }
        }
        let coarse: [Vec<i64>; 3] = std::array::from_fn(|k| x[k][..nv].to_vec());
        let mut sizes = Vec::new();
        for plan in [UNBINNED, 0] {
            let mut models = LevelModels::new();
            models.only = Some(vec![plan].into_iter());
            let bytes = encode_fresh(&level, &x, &coarse, &mut models);
            assert_eq!(bytes[0], plan);
            let y = decode_fresh(&bytes, &level, false, &coarse, None, None).unwrap();
            assert_eq!(y, x, "plan {plan:#x} round trip");
            sizes.push(bytes.len());
        }
        assert!(
            sizes[1] * 100 < sizes[0] * 97,
            "per-slot bins {} B, unbinned {} B",
            sizes[1],
            sizes[0]
        );
    }

    #[test]
    fn isqrt_is_the_floor_of_the_square_root() {
        let squares = (1u64..1 << 26)
            .step_by(9973)
            .flat_map(|r| [r * r - 1, r * r, r * r + 1]);
        let spread = (0..52).flat_map(|b| [(1u64 << b) - 1, 1 << b, (1 << b) + 12345]);
        for v in (0u64..70_000)
            .chain(squares)
            .chain(spread)
            .chain([(1 << 52) - 1])
        {
            let r = isqrt(v);
            assert!(r * r <= v && (r + 1) * (r + 1) > v, "isqrt({v}) = {r}");
        }
    }

    /// Rotations are exact on integers, take the normal onto the first component and the
    /// tangent reference's tangential part onto the second.
    #[test]
    fn rotations_are_exact_and_align_the_frame() {
        let raw = pseudo(11, 600, 24);
        let big = pseudo(12, 600, 52);
        let mut cases: Vec<([i64; 3], [i128; 3])> = (0..100)
            .map(|c| {
                let n = [raw[6 * c], raw[6 * c + 1], raw[6 * c + 2]];
                let t = [raw[6 * c + 3], raw[6 * c + 4], raw[6 * c + 5]].map(|v| v as i128 >> 5);
                (n, t)
            })
            .collect();
        let k = (1 << 23) + 5;
        for n in [
            [0, 0, k],
            [0, 0, -k],
            [k, 0, 0],
            [-k, 0, 0],
            [0, -k, 0],
            [3, -4, 0],
        ] {
            for t in [
                [1i128, 2, 3],
                [0, 0, 0],
                [n[0] as i128, n[1] as i128, n[2] as i128],
            ] {
                cases.push((n, t));
            }
        }
        for (c, &(n, t)) in cases.iter().enumerate() {
            let rot = Rotation::new(n, t);
            for j in 0..6 {
                let v = [
                    big[(c * 6 + j) % 600],
                    big[(c * 7 + j) % 600],
                    raw[(c + j) % 600],
                ];
                let v = v.map(|x| x.clamp(-MAX_LIFTED, MAX_LIFTED));
                assert_eq!(rot.inverse(rot.forward(v)), v, "case {c}: {n:?} {t:?}");
            }
            // The normal, scaled to 2^40, lands on the first axis.
            let nf = n.map(|v| v as f64);
            let len = nf.iter().map(|v| v * v).sum::<f64>().sqrt();
            let s = (1u64 << 40) as f64 / len;
            let r = rot.forward(nf.map(|v| (v * s).round() as i64));
            assert!((r[0] as f64 - (1u64 << 40) as f64).abs() < 1e-5 * (1u64 << 40) as f64);
            assert!(r[1].abs().max(r[2].abs()) < 1 << 22, "case {c}: {r:?}");
            // The tangent's part across the normal lands on the positive second axis.
            let tf = t.map(|v| v as f64);
            let tn = (0..3).map(|k| tf[k] * nf[k]).sum::<f64>() / (len * len);
            let tp: Vec<f64> = (0..3).map(|k| tf[k] - tn * nf[k]).collect();
            let tl = tp.iter().map(|v| v * v).sum::<f64>().sqrt();
            if tl > 1e-3 * len.max(1.0) && tl > 4.0 {
                let s = (1u64 << 40) as f64 / tl;
                let r = rot.forward(std::array::from_fn(|k| (tp[k] * s).round() as i64));
                assert!(
                    r[1] > 0 && r[0].abs().max(r[2].abs()) < 1 << 22,
                    "case {c}: {r:?}"
                );
            }
        }
    }

    /// A level whose coarse values lie on a noisy surface, and details of `bits` bits.
    fn rotated_fixture(bits: u32) -> (Level, [Vec<i64>; 3], [Vec<i64>; 3]) {
        let level = refined(2);
        let (nv, nd) = (level.nv, level.ne() + level.nf());
        let coarse: [Vec<i64>; 3] = std::array::from_fn(|k| pseudo(20 + k as u64, nv, 20));
        let noise = pseudo(30, 3 * nd, bits);
        let mut x = coarse.clone();
        for i in 0..nd {
            for k in 0..3 {
                x[k].push(noise[3 * i + k]);
            }
        }
        (level, coarse, x)
    }

    /// The body of `x`'s details coded in `mode` from fresh models, or `None`
    /// if the mode cannot code them.
    fn body_in_mode(
        level: &Level,
        coarse: &[Vec<i64>; 3],
        x: &[Vec<i64>; 3],
        mode: Mode<'_>,
    ) -> Option<Vec<u8>> {
        body_within(level, coarse, x, mode, usize::MAX)
    }

    /// [`body_in_mode`], refused (`None`) past `limit` bytes.
    fn body_within(
        level: &Level,
        coarse: &[Vec<i64>; 3],
        x: &[Vec<i64>; 3],
        mode: Mode<'_>,
        limit: usize,
    ) -> Option<Vec<u8>> {
        let normals = face_normals(level, coarse);
        let prep = Prepared {
            frames: rot_frames(level, coarse, &normals, false),
            normals,
            ..Default::default()
        };
        let mut m = Models::new();
        let mut mags = Vec::new();
        encode_mode(
            level, false, x, coarse, &prep, None, &mut mags, mode, false, &mut m, limit, 0,
        )
    }

    /// Codes `x`'s details in `mode`, decodes them and checks the round trip; the
    /// payload's size.
    fn code_in_mode(
        level: &Level,
        coarse: &[Vec<i64>; 3],
        x: &[Vec<i64>; 3],
        mode: Mode<'_>,
    ) -> usize {
        let body = body_in_mode(level, coarse, x, mode).expect("in range");
        let mut payload = mode.bytes();
        payload.extend_from_slice(&body);
        let y = decode_fresh(&payload, level, false, coarse, None, None);
        assert_eq!(&y.unwrap(), x, "round trip");
        payload.len()
    }

    #[test]
    fn rotated_modes_round_trip() {
        let (level, coarse, x) = rotated_fixture(14);
        for mode in [
            Mode::Rotated,
            Mode::Shifted(4, 4),
            Mode::Shifted(8, 0),
            Mode::Shifted(3, 7),
        ] {
            code_in_mode(&level, &coarse, &x, mode);
        }
        // Extreme details: the rotated values stay in range or the mode is refused.
        let (level, coarse, mut x) = rotated_fixture(14);
        for (k, xk) in x.iter_mut().enumerate() {
            for (i, v) in xk.iter_mut().enumerate().skip(level.nv) {
                *v = if (i + k) % 2 == 0 {
                    MAX_LIFTED
                } else {
                    -MAX_LIFTED
                };
            }
        }
        let frames = rot_frames(&level, &coarse, &face_normals(&level, &coarse), false);
        let out_of_range = frames.iter().enumerate().any(|(i, f)| {
            f.as_ref().is_some_and(|f| {
                let d = std::array::from_fn(|k| x[k][level.nv + i]);
                f.rot.forward(d).iter().any(|v| v.abs() > MAX_LIFTED)
            })
        });
        // Three values of 2^52 - 1 have length sqrt(3) (2^52 - 1): some rotated value
        // passes the bound, and the mode is refused.
        assert!(out_of_range);
        assert!(body_in_mode(&level, &coarse, &x, Mode::Rotated).is_none());
        // Halved, every rotated value fits (length below 0.87 2^52): it round-trips.
        for v in x.iter_mut().flat_map(|xk| xk[level.nv..].iter_mut()) {
            *v /= 2;
        }
        code_in_mode(&level, &coarse, &x, Mode::Rotated);
    }

    /// Displaces every edge point by half its faces' offset from the midpoint
    /// (Catmull-Clark's edge rule, tangentially; the offset is sixteen times it).
    fn follow_faces(level: &Level, coarse: &[Vec<i64>; 3], x: &mut [Vec<i64>; 3]) {
        for e in 0..level.ne() {
            if let Some(off) = edge_offset(level, coarse, e) {
                for k in 0..3 {
                    x[k][level.nv + e] += crate::transform::round_div(off[k] as i128, 32);
                }
            }
        }
    }

    /// Edge points displaced by half their faces' offset from the midpoint (Catmull-Clark's
    /// edge rule, tangentially) code at least 30 % smaller with the shifted mode, whose
    /// weights the encoder finds.
    #[test]
    fn shifted_mode_predicts_edge_points_that_follow_their_faces() {
        let (level, coarse, mut x) = rotated_fixture(4);
        follow_faces(&level, &coarse, &mut x);
        let frames = rot_frames(&level, &coarse, &face_normals(&level, &coarse), false);
        assert_eq!(shift_weights(&level, &x, &frames), (4, 4));
        let plain = code_in_mode(&level, &coarse, &x, Mode::Rotated);
        let shifted = code_in_mode(&level, &coarse, &x, Mode::Shifted(4, 4));
        assert!(
            shifted * 10 < plain * 7,
            "shifted {shifted} B, rotated {plain} B"
        );
        // The encoder picks it.
        let mut models = LevelModels::new();
        let bytes = encode_fresh(&level, &x, &coarse, &mut models);
        assert_eq!((mode_of(&bytes), bytes[1]), (Some(5), 0x44));
    }

    /// The encoder's mode plan (`LevelModels::only`): each level in its planned mode,
    /// every open mode where the planned one is not open (mode 2 on a Catmull-Clark
    /// level), and the payloads decode exactly.
    #[test]
    fn planned_modes_are_the_ones_coded() {
        let (level, coarse, x) = rotated_fixture(10);
        let free = {
            let mut models = LevelModels::new();
            encode_fresh(&level, &x, &coarse, &mut models)
        };
        for (plan, want) in [(0u8, Some(0u8)), (1, Some(1)), (4, Some(4)), (2, None)] {
            let mut models = LevelModels::new();
            models.only = Some(vec![plan, plan].into_iter());
            let bytes = encode_fresh(&level, &x, &coarse, &mut models);
            match want {
                Some(m) => assert_eq!(bytes[0], m, "planned {plan}"),
                None => assert_eq!(
                    mode_of(&bytes),
                    mode_of(&free),
                    "mode {plan} is not open: every mode"
                ),
            }
            // The plan's first entry was used; the second is left for the next level.
            assert_eq!(
                models.only.as_ref().map(|o| o.as_slice()),
                Some(&[plan][..])
            );
            let y = decode_fresh(&bytes, &level, false, &coarse, None, None);
            assert_eq!(y.unwrap(), x, "planned {plan}");
        }
    }

    /// A level coded in `mode` alone from fresh models, with its mode byte.
    fn forced(
        level: &Level,
        sqrt2: bool,
        x: &[Vec<i64>; 3],
        coarse: &[Vec<i64>; 3],
        phases: Option<&Phases>,
        mode: Mode<'_>,
    ) -> Vec<u8> {
        forced_zero(level, sqrt2, x, coarse, phases, mode, None)
    }

    /// A Catmull-Clark level with phases coded by [`encode`] as a hierarchy's first
    /// level, in the mode it finds smallest.
    fn encode_phased_fresh(
        level: &Level,
        x: &[Vec<i64>; 3],
        coarse: &[Vec<i64>; 3],
        phases: &Phases,
    ) -> Vec<u8> {
        let mut models = LevelModels::new();
        let ph = Some(phases);
        encode(level, false, x, coarse, &mut models, None, ph, usize::MAX).unwrap()
    }

    /// [`forced`] with the zero slots `zero` where given, else the ones the encoder finds.
    fn forced_zero(
        level: &Level,
        sqrt2: bool,
        x: &[Vec<i64>; 3],
        coarse: &[Vec<i64>; 3],
        phases: Option<&Phases>,
        mode: Mode<'_>,
        zero: Option<u8>,
    ) -> Vec<u8> {
        let mut m = Models::new();
        let mut mags = Vec::new();
        let corrections = match mode {
            Mode::Corrected(w) | Mode::CorrectedPhased(w, _) => corrections(level, x, &w).unwrap(),
            _ => Vec::new(),
        };
        let prep = Prepared {
            normals: face_normals(level, coarse),
            corrections,
            ..Default::default()
        };
        let zero = zero.unwrap_or_else(|| axis_zero_slots(level, sqrt2, x, mode, &prep, phases));
        let body = encode_mode(
            level,
            sqrt2,
            x,
            coarse,
            &prep,
            phases,
            &mut mags,
            mode,
            false,
            &mut m,
            usize::MAX,
            zero,
        )
        .unwrap();
        let mut out = mode.bytes();
        out[0] |= zero << ZERO_SHIFT;
        out.extend(body);
        out
    }

    #[test]
    fn phase_bins_follow_the_remainder() {
        // Remainders of [n / 12]: -6..6; 6|r| against 12 and 24.
        let want = [
            (-6, 0b110),
            (-4, 0b110),
            (-3, 0b101),
            (-2, 0b101),
            (-1, 0b100),
            (0, 0),
            (1, 0),
            (2, 1),
            (3, 1),
            (4, 2),
            (5, 2),
        ];
        for (r, q) in want {
            assert_eq!(phase(r, 12), q, "remainder {r}");
        }
        // Divisor 2 (lazy edge points): remainders 0 and -1.
        assert_eq!((phase(0, 2), phase(-1, 2)), (0, 0b110));
    }

    proptest::proptest! {
        /// Mode 7's shift in 64 bits is the 128-bit one wherever it answers, from small
        /// values to ones whose products overflow 64 bits (then it must not answer).
        #[test]
        fn tangent_shift_in_64_bits_is_the_128_bit_one(
            n in proptest::array::uniform3(-(1i64 << 24)..(1i64 << 24)),
            u in proptest::array::uniform3(proptest::num::i64::ANY),
            c in 3i128..9,
            (rk, pred) in (-MAX_LIFTED..=MAX_LIFTED, -MAX_LIFTED..=MAX_LIFTED),
            scale in 0u32..63,
            n_scale in 0u32..24,
            (k, j) in (0usize..3, 1usize..3),
        ) {
            let j = (k + j) % 3;
            // Scale the values down so that every size of product occurs, and small
            // divisors, where the rounding's edges are often met.
            let t = TanTerms { u: u.map(|v| (v >> scale) as i128), c };
            let (rk, pred) = (rk >> scale.min(52), pred >> scale.min(52));
            let n = n.map(|v| v >> n_scale);
            let n = if n[k] == 0 { [1, 1, 1] } else { n };
            let wide = t.shift_128(n, k, j, rk, pred);
            if let Some(fast) = t.shift_64(n, k, j, rk, pred) {
                proptest::prop_assert_eq!(fast, wide);
            }
            proptest::prop_assert_eq!(t.shift(n, k, j, rk, pred), wide);
        }
    }

    /// Fine values of `level`, small details (of `bits` bits) on a coarse shape,
    /// synthesised with `w`; their analysis; its coarse values.
    fn synthesised(
        level: &Level,
        w: crate::transform::Wavelet,
        seed: u64,
        bits: u32,
    ) -> [[Vec<i64>; 3]; 3] {
        use crate::transform::{analyse, synthesise};
        let (nv, nd) = (level.nv, level.ne() + level.nf());
        let fine: [Vec<i64>; 3] = std::array::from_fn(|k| {
            let mut v = pseudo(seed + k as u64, nv, 12);
            v.extend(pseudo(seed + 10 + k as u64, nd, bits));
            synthesise(level, w, &mut v);
            v
        });
        let mut x = fine.clone();
        for xk in x.iter_mut() {
            analyse(level, w, xk);
        }
        let coarse = std::array::from_fn(|k| x[k][..nv].to_vec());
        [fine, x, coarse]
    }

    /// Mode 6 on Catmull-Clark levels of lazy, interp4 and interp6: the encoder's phases (from
    /// the fine values) are the decoder's (the edge points' from the coarse values, the
    /// face points' once the edge points are read), so the fine values come back
    /// exactly; a mode 6 level without phases is corrupt.
    #[test]
    fn phase_mode_round_trips_on_catmull_clark_levels() {
        use crate::transform::{Phaser, Stencils, Wavelet};
        let level = refined(2);
        let nd = level.ne() + level.nf();
        for w in [Wavelet::Lazy, Wavelet::Interp4, Wavelet::Interp6] {
            let [fine, x, coarse] = synthesised(&level, w, 40, 2);
            let st = Stencils::new(&level, w);
            let p = Phaser::new(&level, w, &st).unwrap();
            let phases = p.phases(&fine, nd, true);
            let bytes = forced(&level, false, &x, &coarse, Some(&phases), Mode::Phased);
            let ph = Some(Phasing::Cc(&p));
            let y = decode_fresh(&bytes, &level, false, &coarse, None, ph);
            // Read with the decoder's phases, the level comes back synthesised.
            assert_eq!(y.unwrap(), fine, "{w:?}");
            let err = decode_fresh(&bytes, &level, false, &coarse, None, None);
            assert!(err.unwrap_err().to_string().contains("phase"), "{w:?}");
        }
    }

    /// Mode 7 on a sqrt(2) level: exact round trip; corrupt without targets.
    #[test]
    fn tangent_phase_mode_round_trips_on_sqrt2_levels() {
        let mut t = prism_with_triangles();
        t = crate::topology::sqrt2::fine(&Level::new(&t).unwrap());
        t = crate::topology::sqrt2::fine(&Level::new(&t).unwrap());
        let level = Level::new(&t).unwrap();
        let (nv, nf) = (level.nv, level.nf());
        let coarse: [Vec<i64>; 3] = std::array::from_fn(|k| pseudo(60 + k as u64, nv, 10));
        let p = crate::transform::sqrt2::predictions(&level, &coarse);
        let targets = crate::transform::sqrt2::tangent_targets_from(&level, &coarse, &p);
        // Face points at their centroids (rounded), less the predictions: the details.
        let x: [Vec<i64>; 3] = std::array::from_fn(|k| {
            let mut v = coarse[k].clone();
            for f in 0..nf {
                let face = level.coarse.face(f);
                let s: i128 = face.iter().map(|&c| coarse[k][c as usize] as i128).sum();
                let c = crate::transform::round_div(s, face.len() as i128);
                v.push(c - p[k][f]);
            }
            v
        });
        let two = forced(&level, true, &x, &coarse, None, Mode::Tangent(&targets));
        let seven = forced(
            &level,
            true,
            &x,
            &coarse,
            None,
            Mode::TangentPhased(&targets),
        );
        assert_ne!(two[1..], seven[1..]);
        for (bytes, targets, ok) in [
            (&seven, Some(&targets[..]), true),
            (&two, Some(&targets[..]), true),
            (&seven, None, false),
        ] {
            let r = decode_fresh(bytes, &level, true, &coarse, targets, None);
            assert_eq!(r.is_ok(), ok);
            if ok {
                assert_eq!(r.unwrap(), x);
            }
        }
    }

    /// Whichever mode the encoder tries first (the previous level's), abandoning modes
    /// whose stream passes the best size so far, it picks the same mode and bytes as
    /// trying every mode in full; and a stream over its limit is abandoned.
    #[test]
    fn trying_the_previous_mode_first_codes_the_same() {
        for (seed, shift) in [(10, false), (4, true), (14, false)] {
            let (level, coarse, mut x) = rotated_fixture(seed);
            if shift {
                follow_faces(&level, &coarse, &mut x);
            }
            let run = |prev: Option<u8>| {
                let mut models = LevelModels::new();
                models.prev_mode = prev;
                encode_fresh(&level, &x, &coarse, &mut models)
            };
            let free = run(None);
            for prev in [0, 1, 4, 5] {
                assert_eq!(run(Some(prev)), free, "seed {seed}, previous mode {prev}");
            }
            // Plain and framed coded in full, then each refused under its own size.
            for mode in [Mode::Plain, Mode::Framed] {
                let full = body_in_mode(&level, &coarse, &x, mode).unwrap();
                let run = |limit| body_within(&level, &coarse, &x, mode, limit);
                assert_eq!(run(full.len()).as_ref(), Some(&full));
                assert!(run(full.len() - 1).is_none());
            }
        }
    }

    #[test]
    fn rotated_modes_need_valid_weights() {
        let (level, coarse, x) = rotated_fixture(10);
        let body = body_in_mode(&level, &coarse, &x, Mode::Shifted(2, 5)).unwrap();
        let run = |head: &[u8]| {
            let mut payload = head.to_vec();
            payload.extend_from_slice(&body);
            decode_fresh(&payload, &level, false, &coarse, None, None)
        };
        assert_eq!(run(&[5, 0x25]).unwrap(), x);
        for head in [&[5u8, 0x95][..], &[5, 0x29], &[3], &[6]] {
            let err = run(head).unwrap_err().to_string();
            assert!(err.contains("LEVL"), "{head:?}: {err}");
        }
        // Mode 5 without its weights.
        let err = decode_fresh(&[5], &level, false, &coarse, None, None).unwrap_err();
        assert!(err.to_string().contains("shift weights"), "{err}");
    }

    /// A level over a regular `n` x `n` grid of quads, with each coarse vertex's (x, y).
    fn grid_level(n: u32) -> (Level, Vec<[i64; 2]>) {
        use crate::topology::Topo;
        let mut t = Topo::new((n * n) as usize);
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let v = j * n + i;
                t.push(&[v, v + 1, v + n + 1, v + n]);
            }
        }
        let xy = (0..n * n)
            .map(|v| [(v % n) as i64, (v / n) as i64])
            .collect();
        (Level::new(&t).unwrap(), xy)
    }

    /// Mode 8's features on a grid, checked against the geometry: an edge point's first
    /// feature is the earlier edge point one step along its line, its second the earlier
    /// parallel ones one step across; a face point's first the earlier face points one
    /// step away, its second its four edge points.
    #[test]
    fn corrected_features_follow_the_grid() {
        let (level, xy) = grid_level(5);
        let (nv, ne, nd) = (level.nv, level.ne(), level.ne() + level.nf());
        // Twice each detail's position (edge midpoints and face centres are then integer).
        let at: Vec<[i64; 2]> = (0..nd)
            .map(|i| {
                let corners: Vec<u32> = if i < ne {
                    level.edges[i].to_vec()
                } else {
                    level.coarse.face(i - ne).to_vec()
                };
                let k = corners.len() as i64;
                let s = corners.iter().fold([0, 0], |s, &v| {
                    [s[0] + xy[v as usize][0], s[1] + xy[v as usize][1]]
                });
                [2 * s[0] / k, 2 * s[1] / k]
            })
            .collect();
        let x: [Vec<i64>; 3] = std::array::from_fn(|k| {
            let mut v = vec![0; nv];
            v.extend(pseudo(70 + k as u64, nd, 20));
            v
        });
        for i in 0..nd {
            let mut want = [[0i128; 3]; 2];
            for j in 0..i {
                let d = [at[j][0] - at[i][0], at[j][1] - at[i][1]];
                let feature = if i < ne && j < ne {
                    // Along the edge (its direction: where its midpoint's coordinate is
                    // odd), or across it.
                    let along = if at[i][0] % 2 != 0 { 0 } else { 1 };
                    if d[1 - along] == 0 && d[along].abs() == 2 {
                        Some(0)
                    } else if d[along] == 0 && d[1 - along].abs() == 2 {
                        Some(1)
                    } else {
                        None
                    }
                } else if i >= ne && j >= ne {
                    (d[0].abs() + d[1].abs() == 2).then_some(0)
                } else if i >= ne {
                    (d[0].abs() + d[1].abs() == 1).then_some(1)
                } else {
                    None
                };
                if let Some(f) = feature {
                    for k in 0..3 {
                        want[f][k] += x[k][nv + j] as i128;
                    }
                }
            }
            assert_eq!(corr_features(&level, &x, i), want, "detail {i}");
        }
    }

    /// Details that follow their earlier neighbours: the encoder fits weights near the
    /// generating ones and codes the level in mode 8, smaller than in mode 0; the level
    /// decodes exactly.
    #[test]
    fn corrected_mode_round_trips_and_pays_where_details_correlate() {
        let (level, _) = grid_level(17);
        let (nv, nd) = (level.nv, level.ne() + level.nf());
        let mut x: [Vec<i64>; 3] = std::array::from_fn(|_| vec![0; nv + nd]);
        let noise: [Vec<i64>; 3] = std::array::from_fn(|k| pseudo(80 + k as u64, nd, 6));
        let gen: Weights = [[[-16, 8], [0, 0], [-12, 6]], [[-4, 8], [0, 0], [-6, 4]]];
        for i in 0..nd {
            let c = correction(correction_sums(&level, &x, &gen, i)).unwrap();
            for k in 0..3 {
                x[k][nv + i] = noise[k][i] + c[k];
            }
        }
        let fit = corr_weights(&level, &x).unwrap();
        for (c, class) in fit.iter().enumerate() {
            for (k, w) in class.iter().enumerate() {
                for f in 0..NFEAT {
                    let want = gen[c][k][f] as i32;
                    assert!(
                        (w[f] as i32 - want).abs() <= 4,
                        "{c} {k} {f}: {w:?} for {want}"
                    );
                }
            }
        }
        let coarse: [Vec<i64>; 3] = std::array::from_fn(|_| vec![0; nv]);
        let mut models = LevelModels::new();
        let bytes = encode_fresh(&level, &x, &coarse, &mut models);
        assert_eq!(mode_of(&bytes), Some(8));
        let plain = forced(&level, false, &x, &coarse, None, Mode::Plain);
        assert!(bytes.len() < plain.len(), "{} {}", bytes.len(), plain.len());
        // As the encoder chose, and with the generating weights.
        let gen_bytes = forced(&level, false, &x, &coarse, None, Mode::Corrected(gen));
        for b in [bytes, gen_bytes] {
            let y = decode_fresh(&b, &level, false, &coarse, None, None);
            assert_eq!(y.unwrap(), x);
        }
    }

    #[test]
    fn corrected_mode_needs_valid_weights_and_a_catmull_clark_level() {
        let (level, _) = grid_level(5);
        let (nv, nd) = (level.nv, level.ne() + level.nf());
        let x: [Vec<i64>; 3] = std::array::from_fn(|k| {
            let mut v = vec![0; nv];
            v.extend(pseudo(90 + k as u64, nd, 8));
            v
        });
        let coarse: [Vec<i64>; 3] = std::array::from_fn(|_| vec![0; nv]);
        let w: Weights = [[[0, 0], [0, 0], [-10, 5]], [[64, -64], [0, 0], [0, 0]]];
        let bytes = forced(&level, false, &x, &coarse, None, Mode::Corrected(w));
        assert_eq!(&bytes[..6], &[8, 0b1100, 246, 5, 64, 192]);
        let body = &bytes[6..];
        let run = |head: &[u8]| {
            let mut payload = head.to_vec();
            payload.extend_from_slice(body);
            decode_fresh(&payload, &level, false, &coarse, None, None)
        };
        assert_eq!(run(&bytes[..6]).unwrap(), x);
        for head in [
            &[8, 0b1000100, 246, 5, 64, 192][..],
            &[8, 0b1100, 246, 5, 65, 192],
            &[8, 0b1100, 246, 5, 64, 191],
            &[8, 0b1100, 246, 5, 64, 128],
            &[8, 0b1100, 128, 5, 64, 192],
        ] {
            let err = run(head).unwrap_err().to_string();
            assert!(err.contains("LEVL"), "{head:?}: {err}");
        }
        // Weights cut short.
        for cut in 1..6 {
            let err = decode_fresh(&bytes[..cut], &level, false, &coarse, None, None);
            assert!(err.unwrap_err().to_string().contains("LEVL"), "{cut}");
        }
        // A sqrt(2) level has no mode 8.
        let t = prism_with_triangles();
        let sq = Level::new(&t).unwrap();
        let sx: [Vec<i64>; 3] = std::array::from_fn(|_| vec![0; sq.nv + sq.nf()]);
        let sc: [Vec<i64>; 3] = std::array::from_fn(|_| vec![0; sq.nv]);
        let mut payload = vec![8, 0];
        payload.extend(forced(&sq, true, &sx, &sc, None, Mode::Plain).split_off(1));
        let err = decode_fresh(&payload, &sq, true, &sc, None, None).unwrap_err();
        assert!(err.to_string().contains("unknown level mode 8"), "{err}");
        // A correction beyond a detail's bound is corrupt, not a panic or a wrap.
        let mut big = x.clone();
        for k in 0..3 {
            big[k][nv] = MAX_LIFTED;
        }
        let w: Weights = [[[64, 64]; 3]; 2];
        let over = (0..nd).any(|i| correction(correction_sums(&level, &big, &w, i)).is_none());
        assert!(over);
    }

    /// Mode 9 on lazy, interp4 and interp6 levels: read with the decoder's phases, the level
    /// comes back synthesised; without phases or read as mode 8 it
    /// does not.
    #[test]
    fn corrected_phased_mode_round_trips_on_catmull_clark_levels() {
        use crate::transform::{Phaser, Stencils, Wavelet};
        let (level, _) = grid_level(9);
        let nd = level.ne() + level.nf();
        for w in [Wavelet::Lazy, Wavelet::Interp4, Wavelet::Interp6] {
            let [fine, x, coarse] = synthesised(&level, w, 60, 3);
            let st = Stencils::new(&level, w);
            let p = Phaser::new(&level, w, &st).unwrap();
            let phases = p.phases(&fine, nd, true);
            let wts: Weights = [[[-12, 6], [5, -3], [64, -64]], [[-4, 9], [0, 0], [-64, 64]]];
            let mode = Mode::CorrectedPhased(wts, Rounding::Apart);
            let bytes = forced(&level, false, &x, &coarse, Some(&phases), mode);
            assert_eq!(bytes[0], 9);
            let y = decode_fresh(&bytes, &level, false, &coarse, None, Some(Phasing::Cc(&p)));
            assert_eq!(y.unwrap(), fine, "{w:?}");
            let err = decode_fresh(&bytes, &level, false, &coarse, None, None).unwrap_err();
            assert!(err.to_string().contains("phase"), "{w:?}: {err}");
            // The same weights unphased (mode 8) is another stream.
            let plain = forced(&level, false, &x, &coarse, None, Mode::Corrected(wts));
            assert_ne!(plain[1..], bytes[1..]);
            let y = decode_fresh(&plain, &level, false, &coarse, None, None);
            assert_eq!(y.unwrap(), x, "{w:?}");
        }
    }

    /// Format 25's joint correction, by hand: `[(frac + 16 n) / 512]` (halves up) and
    /// the phase of its remainder; the fraction moves it where the correction alone
    /// would round the other way.
    #[test]
    fn joint_correction_rounds_the_fraction_and_the_correction_together() {
        // n / 32 = 11/32 (0.34) alone rounds to 0; with 200/512 (0.39) it makes 1, and
        // the sum, 0.73, lies 0.27 below it: negative, bin 1.
        assert_eq!(
            joint_correction([11, -11, 0], [200, -200, 0]),
            Some(([1, -1, 0], [0b101, 0b001, 0]))
        );
        assert_eq!(correction([11, -11, 0]), Some([0, 0, 0]));
        // Halves round up; a remainder of half the divisor is bin 2.
        assert_eq!(
            joint_correction([0, 0, 16], [256, -256, 0]),
            Some(([1, 0, 1], [0b110, 0b110, 0b110]))
        );
        // Three-quarters: 1, a quarter below: bin 1; a tenth: 0, bin 0.
        assert_eq!(
            joint_correction([8, 0, 0], [256, 51, -51]),
            Some(([1, 0, 0], [0b101, 0, 0b100]))
        );
        // Beyond a detail's bound.
        let big = (MAX_LIFTED as i128 + 1) * 32;
        assert_eq!(joint_correction([big, 0, 0], [0; 3]), None);
        assert!(joint_correction([big - 32, 0, 0], [0; 3]).is_some());
    }

    /// Zero slots: on a level whose x and y details are all 0 (a terrain grid's, say)
    /// the modes that code the axes themselves flag slots 0 and 1 and leave them out,
    /// which codes smaller than coding them and decodes exactly; a level read with them
    /// cleared is not read as it was written.
    #[test]
    fn zero_slots_leave_out_axes_whose_values_are_all_0() {
        use crate::transform::{Phaser, Stencils, Wavelet};
        let (level, _) = grid_level(17);
        let (nv, nd) = (level.nv, level.ne() + level.nf());
        let st = Stencils::new(&level, Wavelet::Lazy);
        let p = Phaser::new(&level, Wavelet::Lazy, &st).unwrap();
        // x and y on a lattice (details 0), z rough.
        let coarse: [Vec<i64>; 3] = [
            (0..nv as i64).map(|i| 8 * (i % 9)).collect(),
            (0..nv as i64).map(|i| 8 * (i / 9)).collect(),
            pseudo(5, nv, 9),
        ];
        let mut x = coarse.clone();
        x[0].resize(nv + nd, 0);
        x[1].resize(nv + nd, 0);
        x[2].extend(pseudo(6, nd, 4));
        // The fine values: predictions plus details (mode 6 and 9's decoder gives these).
        let mut fine = x.clone();
        for i in 0..nd {
            for k in 0..3 {
                fine[k][nv + i] = p.predict(&fine[k], i).0 + x[k][nv + i];
            }
        }
        let phases = p.phases(&fine, nd, true);
        let w: Weights = [[[4, 0]; 3], [[0, 4]; 3]];
        for mode in [
            Mode::Plain,
            Mode::Phased,
            Mode::Corrected(w),
            Mode::CorrectedPhased(w, Rounding::Apart),
            Mode::CorrectedPhased(w, Rounding::Joint),
        ] {
            let name = mode.byte();
            let phased = mode.phased();
            let read = |bytes: &[u8]| {
                let ph = phased.then_some(Phasing::Cc(&p));
                decode_fresh(bytes, &level, false, &coarse, None, ph)
            };
            let want = if phased { &fine } else { &x };
            let at = |z| forced_zero(&level, false, &x, &coarse, Some(&phases), mode, z);
            let (with, without) = (at(None), at(Some(0)));
            assert_eq!(with[0], 0x30 | name, "mode {name}");
            assert_eq!(without[0], name, "mode {name}");
            assert!(
                with.len() < without.len(),
                "mode {name}: {} {}",
                with.len(),
                without.len()
            );
            assert_eq!(&read(&with).unwrap(), want, "mode {name}");
            assert_eq!(&read(&without).unwrap(), want, "mode {name}");
            // Cleared, the stream is read as if it held x and y.
            let mut cleared = with.clone();
            cleared[0] = name;
            if let Ok(y) = read(&cleared) {
                assert!(&y != want, "mode {name}");
            }
        }
        // A slot flagged with a value other than 0 is not a coding of the level.
        let mut m = Models::new();
        let mut enc = Encoder::new();
        let put = |m: &mut Models, enc: &mut Encoder, d, zero| {
            put(enc, m, 0, [0; 3], d, None, Phased::No, false, zero)
        };
        assert_eq!(put(&mut m, &mut enc, [0, 0, 3], 0b011), Some([0, 0, 2]));
        assert_eq!(put(&mut m, &mut enc, [0, 1, 3], 0b011), None);
        // And the encoder flags them itself.
        let bytes = encode_phased_fresh(&level, &x, &coarse, &phases);
        assert_eq!(bytes[0] & 0x70, 0x30);
        let mode = mode_of(&bytes).unwrap();
        let ph = matches!(mode, 6 | 9).then_some(Phasing::Cc(&p));
        let y = decode_fresh(&bytes, &level, false, &coarse, None, ph).unwrap();
        assert_eq!(&y, if matches!(mode, 6 | 9) { &fine } else { &x });
    }

    /// Zero slots in the modes whose slots are a frame's (1 and 4): on a flat level (z = 0
    /// everywhere) the normal part, slot 0, is all 0. The encoder finds that once it has
    /// coded the level, codes it again without the slot and keeps that: smaller than
    /// coding the slot, and exact.
    #[test]
    fn zero_slots_leave_out_a_flat_levels_normal_part() {
        let (level, _) = grid_level(17);
        let (nv, nd) = (level.nv, level.ne() + level.nf());
        // A 9 x 9 lattice, rough details in x and y, z = 0.
        let mut x: [Vec<i64>; 3] = [
            (0..nv as i64).map(|i| 64 * (i % 9)).collect(),
            (0..nv as i64).map(|i| 64 * (i / 9)).collect(),
            vec![0; nv],
        ];
        x[0].extend(pseudo(11, nd, 5));
        x[1].extend(pseudo(12, nd, 5));
        x[2].resize(nv + nd, 0);
        let coarse: [Vec<i64>; 3] = std::array::from_fn(|k| x[k][..nv].to_vec());
        for (mode, m) in [(1u8, Mode::Framed), (4, Mode::Rotated)] {
            let mut models = LevelModels::new();
            models.only = Some(vec![mode].into_iter());
            let bytes = encode_fresh(&level, &x, &coarse, &mut models);
            assert_eq!(bytes[0], 0x10 | mode, "mode {mode}");
            let y = decode_fresh(&bytes, &level, false, &coarse, None, None);
            assert_eq!(y.unwrap(), x, "mode {mode}");
            // The same mode with the slot coded.
            let with_slot = 1 + body_in_mode(&level, &coarse, &x, m).unwrap().len();
            assert!(
                bytes.len() < with_slot,
                "mode {mode}: {} {with_slot}",
                bytes.len()
            );
        }
    }

    /// Fine values that are their prediction plus their correction rounded once, now
    /// and then off by 16: mode 9 with joint rounding codes them smaller than with the
    /// correction rounded apart, and it decodes exactly; a mask with both bits 6 and 7,
    /// or bit 6 on mode 8, is corrupt.
    #[test]
    fn joint_rounding_pays_where_values_follow_prediction_plus_correction() {
        use crate::transform::{Phaser, Stencils, Wavelet};
        let (level, _) = grid_level(17);
        let (nv, nd) = (level.nv, level.ne() + level.nf());
        let gen: Weights = [[[-9, 3]; 3], [[-3, 4]; 3]];
        for w in [Wavelet::Lazy, Wavelet::Interp4, Wavelet::Interp6] {
            let st = Stencils::new(&level, w);
            let p = Phaser::new(&level, w, &st).unwrap();
            let noise: [Vec<i64>; 3] = std::array::from_fn(|k| pseudo(70 + k as u64, nd, 3));
            let mut fine: [Vec<i64>; 3] = std::array::from_fn(|k| {
                let mut v = pseudo(40 + k as u64, nv, 10);
                v.resize(nv + nd, 0);
                v
            });
            // The details, as the encoder's analysis leaves them.
            let mut x = fine.clone();
            for i in 0..nd {
                let n = correction_sums(&level, &x, &gen, i);
                let pred: [(i64, u8, i16); 3] =
                    std::array::from_fn(|k| p.predict_frac(&fine[k], i));
                let (c, _) = joint_correction(n, pred.map(|q| q.2)).unwrap();
                for k in 0..3 {
                    // One value in eight off by 16.
                    let off = [0, 0, 0, 1, 0, 0, 0, -1][noise[k][i].rem_euclid(8) as usize];
                    x[k][nv + i] = c[k] + off;
                    fine[k][nv + i] = pred[k].0 + x[k][nv + i];
                }
            }
            let coarse: [Vec<i64>; 3] = std::array::from_fn(|k| x[k][..nv].to_vec());
            let phases = p.phases(&fine, nd, true);
            let at = |r: Rounding| {
                let mode = Mode::CorrectedPhased(gen, r);
                forced(&level, false, &x, &coarse, Some(&phases), mode)
            };
            let (joint, apart) = (at(Rounding::Joint), at(Rounding::Apart));
            assert_eq!(joint[..2], [9, 0b111111 | JOINT]);
            assert!(
                joint.len() < apart.len(),
                "{w:?}: {} {}",
                joint.len(),
                apart.len()
            );
            let read = |bytes: &[u8]| {
                let ph = Some(Phasing::Cc(&p));
                decode_fresh(bytes, &level, false, &coarse, None, ph)
            };
            assert_eq!(read(&joint).unwrap(), fine, "{w:?}");
            assert_eq!(read(&apart).unwrap(), fine, "{w:?}");
            // Both mask bits 6 and 7, or bit 6 on mode 8, are corrupt.
            let mut bad = joint.clone();
            bad[1] |= 0x80;
            let err = read(&bad).unwrap_err().to_string();
            assert!(err.contains("bad correction weights"), "{w:?}: {err}");
            bad[0] = 8;
            bad[1] = joint[1];
            let err = read(&bad).unwrap_err().to_string();
            assert!(err.contains("bad correction weights"), "{w:?}: {err}");
            // The encoder, with weights of its own: it decodes exactly.
            let bytes = encode_phased_fresh(&level, &x, &coarse, &phases);
            // (A level in a phased mode comes back synthesised, else as details.)
            let want = if matches!(bytes[0] & 0x7f, 6 | 9) {
                &fine
            } else {
                &x
            };
            assert_eq!(&read(&bytes).unwrap(), want, "{w:?}");
        }
    }

    /// Details of one size everywhere (noise of 5 bits): an unbinned level codes them
    /// smaller than the neighbour bins do, and the encoder chooses it; a level with large
    /// details in one corner and zeros elsewhere stays binned. Each payload decodes
    /// exactly, and not with its flag flipped.
    #[test]
    fn unbinned_levels_pay_where_neighbours_tell_nothing() {
        let (level, _) = grid_level(33);
        let (nv, nd) = (level.nv, level.ne() + level.nf());
        let coarse: [Vec<i64>; 3] = std::array::from_fn(|_| vec![0; nv]);
        let noise = |seed: u64| -> [Vec<i64>; 3] {
            std::array::from_fn(|k| {
                let mut v = vec![0; nv];
                v.extend(pseudo(seed + k as u64, nd, 5));
                v
            })
        };
        let even = noise(300);
        // Large details on the first tenth of the details (a corner of edge points),
        // zeros elsewhere: their neighbours' sizes tell them apart.
        let mut corner = noise(310);
        for xk in corner.iter_mut() {
            for (i, v) in xk[nv..].iter_mut().enumerate() {
                *v = if i < nd / 10 { *v * 64 } else { 0 };
            }
        }
        for (x, want) in [(&even, true), (&corner, false)] {
            let mut models = LevelModels::new();
            let bytes = encode_fresh(&level, x, &coarse, &mut models);
            assert_eq!(unbinned(&bytes), want, "mode byte {:#x}", bytes[0]);
            let y = decode_fresh(&bytes, &level, false, &coarse, None, None);
            assert_eq!(&y.unwrap(), x);
            // The other choice, as a plan: larger, and exact too.
            let mut models = LevelModels::new();
            models.only = Some(vec![bytes[0] ^ UNBINNED].into_iter());
            let other = encode_fresh(&level, x, &coarse, &mut models);
            assert_eq!(other[0], bytes[0] ^ UNBINNED);
            assert!(other.len() > bytes.len(), "{} {}", other.len(), bytes.len());
            let y = decode_fresh(&other, &level, false, &coarse, None, None);
            assert_eq!(&y.unwrap(), x);
            // Read with the flag flipped: an error or other details.
            let mut flipped = bytes.clone();
            flipped[0] ^= UNBINNED;
            let y = decode_fresh(&flipped, &level, false, &coarse, None, None);
            assert!(y.map_or(true, |y| &y != x));
        }
        // The mode without the flag.
        let mut models = LevelModels::new();
        let bytes = encode_fresh(&level, &even, &coarse, &mut models);
        assert_eq!(mode_of(&bytes), Some(bytes[0] & 0x7f));
    }

    /// Phased models are handed on only from one phased level to the next (SPEC.md
    /// 10.6): after a level in another mode, a phased level starts without them.
    #[test]
    fn phased_models_are_handed_on_between_phased_levels_only() {
        let with_phased = |last_phased: bool| {
            let mut models = LevelModels::new();
            let mut m = Models::new();
            m.get_phased(0, 2, 0, 1, 0).observe(3);
            models.last = Some(m);
            models.last_phased = last_phased;
            models
        };
        let plain = Mode::Plain;
        for (last_phased, mode, kept) in [
            (false, Mode::Phased, false),
            (true, Mode::Phased, true),
            (false, plain, true),
        ] {
            let models = with_phased(last_phased);
            let m = models.ready(models.start(), mode);
            assert_eq!(!m.ph.is_empty(), kept, "{last_phased}");
            assert_eq!(!m.ph_parents.is_empty(), kept, "{last_phased}");
        }
    }
}

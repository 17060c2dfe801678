//! The detail models (SPEC.md 10.1): the context models by class, slot, previous class
//! and neighbour bin, the shared and phased models, carried from level to level.

use super::*;

pub(super) fn prev_bin(c: usize) -> usize {
    match c {
        0..=2 => 0,
        3..=6 => 1,
        _ => 2,
    }
}

#[derive(Clone)]
pub(super) struct Models {
    /// The context models, `None` until first used (then made from their shared
    /// model): a level's start clones and reseeds only those in use.
    pub(super) m: Vec<Option<IntModel>>,
    /// Per class and slot, a model of every value coded there; a context model starts
    /// from it (reseeded) at its first use.
    pub(super) parents: Vec<IntModel>,
    /// Mode 6's models, [`PHASE_BINS`] per context of `m` (`None` until
    /// first used), and their shared models (per class, slot and phase bin); empty until a
    /// level is coded in mode 6, when the shared ones start from `parents` (SPEC.md
    /// 10.6).
    pub(super) ph: Vec<Option<IntModel>>,
    pub(super) ph_parents: Vec<IntModel>,
}

/// Phase bins: the size of a prediction's remainder in sixths of its divisor, 0..=2.
pub(super) const PHASE_BINS: usize = 3;

/// Context models start from their class and slot's shared model, counts halved until
/// they sum to at most this (SPEC.md 10.1).
pub(super) const SHARED_SEED: u32 = 256;

/// Every component has its own neighbour context: the magnitudes of the same component
/// at the coarse neighbours and at the level's earlier details (SPEC.md 10.1), in six
/// bins and one for no neighbour.
pub(super) const SLOT_BINS: usize = 7;

/// A level's models start from the previous level's, counts halved until they sum to at
/// most this (SPEC.md 10.1).
pub(super) const SEED_TOTAL: u32 = 1024;

/// The detail models carried from level to level (SPEC.md 10.1): each level starts from
/// what the previous level learnt.
pub struct LevelModels {
    pub(super) last: Option<Models>,
    /// Per vertex, the magnitude classes of its coded components (base vertices
    /// `UNKNOWN`).
    pub(super) mags: Vec<[u8; 3]>,
    /// Whether the encoder tries the rotated modes (not part of the format).
    pub rotated: bool,
    /// The encoder's mode for each coming level (not part of the format): where given,
    /// a level is coded in that mode only (mode 5 with its own weights; every open mode
    /// if that one is not open to the level).
    pub only: Option<std::vec::IntoIter<u8>>,
    /// Whether a large level without a planned mode chooses it by coding a sample of
    /// its details in each mode rather than all of them (not part of the format).
    pub sampled: bool,
    /// The mode the encoder chose for the previous level (not part of the format).
    pub(super) prev_mode: Option<u8>,
    /// Whether the previous level was coded in a phased mode (6, 7 or 9): only such a
    /// level hands its phased models on (SPEC.md 10.6).
    pub(super) last_phased: bool,
}

impl LevelModels {
    /// Models for a hierarchy's first level.
    pub fn new() -> Self {
        LevelModels {
            last: None,
            mags: Vec::new(),
            rotated: true,
            only: None,
            sampled: false,
            prev_mode: None,
            last_phased: false,
        }
    }

    /// Room for the magnitudes of `n` vertices in all, made once (the levels then grow
    /// into it without moving it).
    pub fn reserve(&mut self, n: usize) {
        self.mags.reserve(n.saturating_sub(self.mags.len()));
    }

    /// A phased level after one that was not starts its phased models afresh, from the
    /// shared models as they are then (SPEC.md 10.6): `start`, the models from
    /// [`Self::start`], made ready for a level in `mode`.
    pub(super) fn ready(&self, mut start: Models, mode: Mode<'_>) -> Models {
        if mode.phased() && !self.last_phased {
            start.ph.clear();
            start.ph_parents.clear();
        }
        start
    }

    pub(super) fn start(&self) -> Models {
        match &self.last {
            Some(m) => {
                let mut m = m.clone();
                for im in
                    m.m.iter_mut()
                        .flatten()
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
    pub(super) fn new() -> Self {
        let n = 2 * 3 * 3 * SLOT_BINS;
        Models {
            m: vec![None; n],
            parents: (0..6).map(|_| IntModel::new()).collect(),
            ph: Vec::new(),
            ph_parents: Vec::new(),
        }
    }

    /// The model of mode 6 for a value of `class` in `slot` with phase bin `bin`
    /// (SPEC.md 10.6); at its first use a copy of its shared model, reseeded.
    pub(super) fn get_phased(
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
    pub(super) fn phased_shared(&mut self, class: usize, slot: usize, bin: usize) -> usize {
        if self.ph.is_empty() {
            self.ph = vec![None; self.m.len() * PHASE_BINS];
            self.ph_parents = (0..6 * PHASE_BINS)
                .map(|j| seeded(&self.parents[j / PHASE_BINS]))
                .collect();
        }
        (class * 3 + slot) * PHASE_BINS + bin
    }

    /// The shared model of `class`, `slot` and phase bin `bin` learns `v`.
    pub(super) fn observe_phased(&mut self, class: usize, slot: usize, bin: usize, v: i64) {
        if let Some(p) = self
            .ph_parents
            .get_mut((class * 3 + slot) * PHASE_BINS + bin)
        {
            p.observe(v);
        }
    }

    /// The index in `m` of the context of a value of `class` in `slot` after a value of
    /// class `prev`, with neighbour bin `nbr`.
    pub(super) fn context(&self, class: usize, slot: usize, prev: usize, nbr: usize) -> usize {
        let p = if slot == 0 { 0 } else { prev_bin(prev) };
        ((class * 3 + slot) * 3 + p) * SLOT_BINS + nbr
    }

    pub(super) fn get(
        &mut self,
        class: usize,
        axis: usize,
        prev: usize,
        nbr: usize,
    ) -> &mut IntModel {
        let i = self.context(class, axis, prev, nbr);
        let shared = &self.parents[class * 3 + axis];
        self.m[i].get_or_insert_with(|| seeded(shared))
    }

    /// [`Models::get`]'s context model and the shared model of `class` and `slot`,
    /// which learns what the context model codes in a binned level.
    #[inline(always)]
    pub(super) fn get_and_shared(
        &mut self,
        class: usize,
        slot: usize,
        prev: usize,
        nbr: usize,
    ) -> (&mut IntModel, &mut IntModel) {
        let i = self.context(class, slot, prev, nbr);
        let j = class * 3 + slot;
        let shared = &mut self.parents[j];
        (self.m[i].get_or_insert_with(|| seeded(shared)), shared)
    }

    /// The model a value in context `c` is coded with (SPEC.md 10.1, 10.6): its context
    /// model, or in an unbinned level its shared model.
    pub(super) fn model(&mut self, c: Ctx) -> &mut IntModel {
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

    /// Decodes a value in context `c` with [`Self::model`]'s model, and the model that
    /// [`Self::learn`] names learns it (in a binned level without phases, the shared
    /// model counts the symbols just read).
    #[inline(always)]
    pub(super) fn read(&mut self, dec: &mut Decoder, c: Ctx) -> Result<i64> {
        if !c.unbinned && c.bin.is_none() {
            let (model, shared) = self.get_and_shared(c.class, c.slot, c.prev, c.nbr);
            return dec.int_observed(model, shared);
        }
        let v = dec.int(self.model(c))?;
        self.learn(c, v);
        Ok(v)
    }

    /// After `v` was coded with [`Self::model`]: in a binned level its shared model
    /// learns it, in an unbinned one its context model.
    pub(super) fn learn(&mut self, c: Ctx, v: i64) {
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
    pub(super) fn observe(&mut self, class: usize, slot: usize, v: i64) {
        if let Some(p) = self.parents.get_mut(class * 3 + slot) {
            p.observe(v);
        }
    }
}

/// A coded value's context: class, slot, the previous value's class, neighbour bin,
/// phase bin (modes 6, 7 and 9) and whether its level is unbinned.
#[derive(Clone, Copy)]
pub(super) struct Ctx {
    pub(super) class: usize,
    pub(super) slot: usize,
    pub(super) prev: usize,
    pub(super) nbr: usize,
    pub(super) bin: Option<usize>,
    pub(super) unbinned: bool,
}

/// A context model's start from its shared model (SPEC.md 10.1): a copy, reseeded.
pub(super) fn seeded(shared: &IntModel) -> IntModel {
    let mut m = shared.clone();
    m.reseed(SHARED_SEED);
    m
}

/// The neighbour bin of each component of detail `i` (SPEC.md 10.1) from the
/// per-component magnitudes `mags`: the coarse neighbours (an edge's ends, a face's
/// edge points, a sqrt(2) face's corners) count twice, an edge's earlier edges at its
/// ends once; the bin is the weighted mean magnitude, doubled and rounded, at most 14,
/// or 15 with no neighbour.
pub(super) fn slot_bins(level: &Level, mags: &[[u8; 3]], family: Family, i: usize) -> [usize; 3] {
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
    if family == Family::Sqrt2 {
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
    bins_of(sum, w)
}

/// The bins of weighted magnitude sums `sum` of total weight `w`, or the "no
/// neighbour" bin when `w` is 0.
#[inline]
fn bins_of(sum: [u32; 3], w: u32) -> [usize; 3] {
    if w == 0 {
        return [SLOT_BINS - 1; 3];
    }
    // The bin of the rounded mean `m = [(s + w/2) / w]`: how many of the thresholds 1,
    // 3, 5, 7, 10 it reaches (`m >= t` exactly when `s + w/2 >= t w`), without a
    // division per component.
    let h = w / 2;
    let steps = [w, 3 * w, 5 * w, 7 * w, 10 * w];
    sum.map(|s| steps.iter().map(|&t| (s + h >= t) as usize).sum())
}

/// [`slot_bins`] of a level's details read in order (the decoder's): per coarse vertex
/// the sums of the magnitudes of its edges' details read so far and their count, so
/// that an edge point's earlier edges at its ends are two entries rather than a walk
/// of both ends' edges. The same bins.
pub(super) struct RunningBins {
    /// Per coarse vertex: the three components' sums, then the count.
    at: Vec<[u32; 4]>,
}

impl RunningBins {
    /// For a level of `family` (none for sqrt(2), whose details are all face points).
    pub(super) fn new(level: &Level, family: Family) -> Option<RunningBins> {
        (family != Family::Sqrt2).then(|| RunningBins {
            at: vec![[0; 4]; level.nv],
        })
    }

    /// [`slot_bins`] of detail `i`, every detail before it [`RunningBins::read`].
    #[inline]
    pub(super) fn bins(&self, level: &Level, mags: &[[u8; 3]], family: Family, i: usize) -> [usize; 3] {
        if i >= level.ne() {
            return slot_bins(level, mags, family, i);
        }
        let [a, b] = level.edges[i];
        let (ra, rb) = (self.at[a as usize], self.at[b as usize]);
        let mut sum = [0u32; 3];
        let mut w = ra[3] + rb[3];
        for k in 0..3 {
            sum[k] = ra[k] + rb[k];
        }
        for m in [mags[a as usize], mags[b as usize]] {
            if m[0] != UNKNOWN {
                for k in 0..3 {
                    sum[k] += 2 * m[k] as u32;
                }
                w += 2;
            }
        }
        bins_of(sum, w)
    }

    /// Detail `i` was read with magnitudes `m`.
    #[inline]
    pub(super) fn read(&mut self, level: &Level, i: usize, m: [u8; 3]) {
        if let Some(&[a, b]) = level.edges.get(i) {
            for v in [a, b] {
                let r = &mut self.at[v as usize];
                for k in 0..3 {
                    r[k] += m[k] as u32;
                }
                r[3] += 1;
            }
        }
    }
}

/// Detail `i`'s class, the neighbour bins of its three coded values ([`slot_bins`]) and
/// its detail number for [`frame`]; from `running` where the details are read in order.
#[inline(always)]
pub(super) fn contexts(
    level: &Level,
    mags: &[[u8; 3]],
    family: Family,
    i: usize,
    running: Option<&RunningBins>,
) -> (usize, [usize; 3], usize) {
    let class = match family {
        Family::Sqrt2 => 1,
        _ => (i >= level.ne()) as usize,
    };
    let bins = match running {
        Some(r) => r.bins(level, mags, family, i),
        None => slot_bins(level, mags, family, i),
    };
    (class, bins, frame_detail(level, family, i))
}

/// Detail `i`'s number for [`frame`]: itself, or on a sqrt(2) level (every detail a
/// face point) the edge count plus `i`.
#[inline]
pub(super) fn frame_detail(level: &Level, family: Family, i: usize) -> usize {
    match family {
        Family::Sqrt2 => level.ne() + i,
        _ => i,
    }
}

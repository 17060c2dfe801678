//! The LEVL encoder (SPEC.md 10): every open mode tried, the smallest kept.

use super::*;

/// Codes detail `d` (components in the order of frame `fr`, each with its neighbour bin
/// `nbr[slot]`; phased as `ph` says); returns the magnitude classes of the coded values,
/// or `None` when mode 7's shift is out of range.
#[allow(clippy::too_many_arguments)]
pub(super) fn put(
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

/// The fewest details of a level whose mode the encoder chooses on a sample, when asked
/// ([`LevelModels::sampled`]): half of them or fewer, [`Sample::of`] (not part of the
/// format).
const SAMPLE_FROM: usize = 2 * SMALL_SAMPLE;

/// Codes the details `x[k][nv..]` of one level (a sqrt(2) step when `sqrt2`). `coarse`
/// holds the level's coarse values (what the decoder has when it reads this level).
/// The payload starts with a mode byte, and the encoder keeps the mode that codes
/// smallest (SPEC.md 10.2, 10.5). `None` (`models` then unusable) when the payload would
/// take more than `limit` bytes in every mode: a caller that only wants a smaller coding
/// than one it has stops early.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    level: &Level,
    family: Family,
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
    let rotated = models.rotated && (open(4) || open(5));
    // Without a plan, the open modes binned, then the best of them unbinned (kept only
    // if strictly smaller); on a large level, when asked, all of them on a sample,
    // what the modes read made for the sample alone, and the chosen one then whole.
    let unbinned_trial = plan_unbinned.is_none();
    let nd = family.details(level);
    let sample = match models.sampled && unbinned_trial && nd >= SAMPLE_FROM {
        true => Sample::of(nd),
        false => Sample::All,
    };
    let (modes, prep) = candidates(
        level, family, x, coarse, targets, phases, rotated, open, sample,
    );
    let start = models.start();
    let zeros = AxisZeros::new(level, family, x);
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
    let order = trial_order(&modes, models.prev_mode);
    // Codes the level in mode `i` (unbinned or not) and keeps it in `best` if smaller.
    // A stream longer than `cap` or than the best so far is abandoned; ties go to the
    // first mode in `modes`' order whatever the order of trying.
    let attempt = |best: &mut Option<(usize, Tried)>,
                   prep: &Prepared,
                   i: usize,
                   unbinned: bool,
                   cap: usize| {
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
                level, family, x, coarse, prep, phases, &mut mg, mode, unbinned, &mut m, room, zero,
                Sample::All,
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
        let Some(mut tried) = code(zeros.slots(mode, prep, phases)) else {
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
    // While the unbinned trial is to come, the binned codings are not cut at the
    // limit: their best is the mode tried unbinned, which may fit where they do not.
    let cap = if unbinned_trial { usize::MAX } else { limit };
    let mut best: Option<(usize, Tried)> = None;
    if sample != Sample::All {
        // Mode i's sample in bytes, if within `cap`.
        let sampled = |i: usize, unbinned: bool, cap: usize| {
            let mode = modes[i];
            let mut mg = models.mags.clone();
            let mut m = models.ready(start.clone(), mode);
            let zero = zeros.slots(mode, &prep, phases);
            let head = mode.bytes().len();
            encode_mode(
                level, family, x, coarse, &prep, phases, &mut mg, mode, unbinned, &mut m,
                cap.saturating_sub(head), zero, sample,
            )
            .map(|b| b.len() + head)
        };
        // The fewest bytes, the first in `modes` on ties; in the order of trying, a
        // sample is abandoned once past the fewest so far.
        let mut chosen: Option<(usize, usize)> = None;
        for i in order {
            let cap = chosen.map_or(usize::MAX, |(b, _)| b);
            if let Some(b) = sampled(i, false, cap) {
                if chosen.is_none_or(|c| (b, i) < c) {
                    chosen = Some((b, i));
                }
            }
        }
        let chosen = chosen.map(|(size, j)| (j, sampled(j, true, size.saturating_sub(1)).is_some()));
        // What the modes read for the sample goes before the chosen one's is made for
        // the whole level (the memory of large levels).
        drop(prep);
        if let Some((j, unbinned)) = chosen {
            if let Some(whole) = whole_prep(level, family, x, coarse, modes[j]) {
                attempt(&mut best, &whole, j, unbinned, usize::MAX);
            }
        }
        // A value out of range outside the sample: every mode whole instead.
        if best.is_none() {
            models.sampled = false;
            let out = encode(level, family, x, coarse, models, targets, phases, limit);
            models.sampled = true;
            return out;
        }
    } else {
        for i in order {
            attempt(&mut best, &prep, i, plan_unbinned.unwrap_or(false), cap);
        }
        if let Some(j) = best.as_ref().map(|(j, _)| *j).filter(|_| unbinned_trial) {
            attempt(&mut best, &prep, j, true, limit);
        }
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

/// The modes a level can be coded in (those `open` to it, if any is), and what they
/// read beside the details: corrections, normals, rotated frames.
#[allow(clippy::too_many_arguments)]
fn candidates<'t>(
    level: &Level,
    family: Family,
    x: &[Vec<i64>; 3],
    coarse: &[Vec<i64>; 3],
    targets: Option<&'t [[i64; 3]]>,
    phases: Option<&Phases>,
    rotated: bool,
    open: impl Fn(u8) -> bool,
    sample: Sample,
) -> (Vec<Mode<'t>>, Prepared) {
    let mut modes = vec![Mode::Plain, Mode::Framed];
    if let Some(t) = targets {
        modes.push(Mode::Tangent(t));
        modes.push(Mode::TangentPhased(t));
    }
    if phases.is_some() {
        modes.push(Mode::Phased);
    }
    let mut prep = Prepared::default();
    if family != Family::Sqrt2 && (open(8) || open(9)) {
        let made = sampled_corr_weights(level, x, sample)
            .and_then(|w| Some((w, sampled_corrections(level, x, &w, sample)?)));
        if let Some((w, c)) = made {
            modes.push(Mode::Corrected(w));
            if phases.is_some() {
                modes.push(Mode::CorrectedPhased(w, Rounding::Apart));
                modes.push(Mode::CorrectedPhased(w, Rounding::Joint));
            }
            prep.corrections = c;
        }
    }
    if rotated {
        modes.push(Mode::Rotated);
        prep.normals = sampled_normal_frames(level, coarse, family, sample);
        prep.frames = rot_frames(level, coarse, &prep.normals, family, true);
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
        prep.normals = sampled_normal_frames(level, coarse, family, sample);
    }
    (modes, prep)
}

/// What `mode` reads beside the details, for every detail of the level (its weights
/// as chosen on a sample); `None` if a correction is beyond the bound of a detail.
fn whole_prep(
    level: &Level,
    family: Family,
    x: &[Vec<i64>; 3],
    coarse: &[Vec<i64>; 3],
    mode: Mode<'_>,
) -> Option<Prepared> {
    let mut prep = Prepared::default();
    if mode.framed() {
        prep.normals = normal_frames(level, coarse, family);
    }
    if matches!(mode, Mode::Rotated | Mode::Shifted(..)) {
        let shifted = matches!(mode, Mode::Shifted(..));
        prep.frames = rot_frames(level, coarse, &prep.normals, family, shifted);
    }
    if let Mode::Corrected(w) | Mode::CorrectedPhased(w, _) = mode {
        prep.corrections = corrections(level, x, &w)?;
    }
    Some(prep)
}

/// The order modes are tried in: the previous level's mode first (a mode is abandoned
/// once its stream passes the best size so far, and the best is often the previous
/// level's), then the rest in `modes`' order.
fn trial_order(modes: &[Mode<'_>], prev: Option<u8>) -> Vec<usize> {
    let mut order: Vec<usize> = (0..modes.len()).collect();
    if let Some(i) = modes
        .iter()
        .position(|m| Some(m.byte()) == prev)
    {
        order.remove(i);
        order.insert(0, i);
    }
    order
}

#[allow(clippy::too_many_arguments)]
pub(super) fn encode_mode(
    level: &Level,
    family: Family,
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
    sample: Sample,
) -> Option<Vec<u8>> {
    let mut enc = Encoder::new();
    let (nv, nd) = (level.nv, family.details(level));
    // The rotated modes take their frames (normals included), the normal-frame modes
    // the normals and modes 8 and 9 their corrections from `prep`, made once per level.
    let rotated = matches!(mode, Mode::Rotated | Mode::Shifted(..));
    let corrected = matches!(mode, Mode::Corrected(_) | Mode::CorrectedPhased(..));
    let framed = mode.framed() && !rotated;
    if (rotated && prep.frames.len() != nd)
        || (corrected && prep.corrections.len() != nd)
        || (framed && prep.normals.len() != nd)
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
        if !sample.has(i) {
            continue;
        }
        let (class, bins, _) = contexts(level, mags, family, i, None);
        let mut d = [x[0][nv + i], x[1][nv + i], x[2][nv + i]];
        let fr = if framed {
            prep.normals[i].get()
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
        if let Some(f) = rotated.then(|| prep.frames.get(i)).flatten() {
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
#[cfg(test)]
pub(super) fn axis_zero_slots(
    level: &Level,
    family: Family,
    x: &[Vec<i64>; 3],
    mode: Mode<'_>,
    prep: &Prepared,
    phases: Option<&Phases>,
) -> u8 {
    AxisZeros::new(level, family, x).slots(mode, prep, phases)
}

/// What a mode's zero slots (the axes a mode that codes them leaves out, SPEC.md 10.2)
/// depend on that every mode of a level shares, found once per level rather than once
/// per mode tried: which axes' details are all 0, and (when a joint-rounded mode first
/// asks) whether every prediction's fraction rounds to a 0 correction.
pub(super) struct AxisZeros {
    /// The details `x[k][nv..nv + nd]` of axis `k` are all 0 (and the level has some).
    axes: [bool; 3],
    fractions: [std::cell::OnceCell<bool>; 3],
}

impl AxisZeros {
    pub(super) fn new(level: &Level, family: Family, x: &[Vec<i64>; 3]) -> Self {
        let (nv, nd) = (level.nv, family.details(level));
        AxisZeros {
            axes: std::array::from_fn(|k| nd > 0 && x[k][nv..nv + nd].iter().all(|&v| v == 0)),
            fractions: Default::default(),
        }
    }

    /// The zero slots of a mode that codes the axes themselves (0, 6, 8 or 9): the axes
    /// whose details are all 0 and stay 0 once corrected (modes 8 and 9; with joint
    /// rounding a prediction's fraction alone can make a correction). 0 for the other
    /// modes and on a level without details.
    pub(super) fn slots(&self, mode: Mode<'_>, prep: &Prepared, phases: Option<&Phases>) -> u8 {
        if mode.framed() {
            return 0;
        }
        let corrected = matches!(mode, Mode::Corrected(_) | Mode::CorrectedPhased(..));
        let joint = matches!(mode, Mode::CorrectedPhased(_, Rounding::Joint));
        let fractions_round_to_0 = |k: usize| {
            *self.fractions[k].get_or_init(|| {
                phases.is_some_and(|p| {
                    p.fracs[k].iter().all(|&f| joint_rounds_to_0(f))
                })
            })
        };
        let mut zero = 0;
        for k in 0..3 {
            if self.axes[k]
                && (!corrected || prep.corrections.iter().all(|n| n[k] == 0))
                && (!joint || fractions_round_to_0(k))
            {
                zero |= 1 << k;
            }
        }
        zero
    }
}

//! The LEVL decoder (SPEC.md 10).

use super::*;

#[allow(clippy::too_many_arguments)]
pub(super) fn get(
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
            m.read(dec, c)?
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

/// [`get`] without a frame or phases (the plain, corrected and rotated modes): the same
/// values, with the model of each decided without the frame's and phases' cases.
#[inline]
fn get_plain(
    dec: &mut Decoder,
    m: &mut Models,
    class: usize,
    nbr: [usize; 3],
    unbinned: bool,
    zero: u8,
) -> Result<([i64; 3], [u8; 3])> {
    let mut d = [0i64; 3];
    let mut mags = [0u8; 3];
    let mut prev = 0;
    for slot in 0..3 {
        // A zero slot's values are not in the stream, and no model learns them.
        let v = if zero >> slot & 1 == 1 {
            0
        } else {
            let c = Ctx {
                class,
                slot,
                prev,
                nbr: nbr[slot],
                bin: None,
                unbinned,
            };
            m.read(dec, c)?
        };
        prev = class_of(v);
        mags[slot] = prev as u8;
        if v.abs() > MAX_LIFTED {
            return Err(Error::corrupt("LEVL", "detail out of range"));
        }
        d[slot] = v;
    }
    Ok((d, mags))
}

/// Decodes what [`encode`] wrote into `x[k][nv..]`; `x[k][..nv]` are the coarse values.
/// `targets` are the level's tangent targets (modes 2 and 7), `phasing` its phases (mode
/// 6), each where the level has them. With `threads` above 1 a rotated level's rotations
/// are made on another thread while its values are read (the same values either way).
#[allow(clippy::too_many_arguments)]
pub fn decode(
    payload: &[u8],
    level: &Level,
    family: Family,
    x: &mut [Vec<i64>; 3],
    models: &mut LevelModels,
    targets: Option<&[[i64; 3]]>,
    phasing: Option<Phasing<'_>>,
    threads: usize,
) -> Result<()> {
    let (nv, nd) = (level.nv, family.details(level));
    // Density bound (SPEC.md 2.6), checked before the level's arrays are sized.
    if nd as u64 > 2048 * (payload.len() as u64 + 8) {
        return Err(Error::corrupt(
            "LEVL",
            format!("{} bytes cannot hold {} details", payload.len(), nd),
        ));
    }
    // The mode byte's top bit makes the level unbinned; bits 4 to 6 are the slots left
    // out of the stream.
    let unbinned = unbinned(payload);
    let zero = zero_slots(payload);
    let (mode, payload) = read_mode(payload, family, nd, targets, phasing.as_ref())?;
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
        FaceNormals::Narrow(Vec::new())
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
    // Mode 9 with joint rounding also reads the predictions' fractions.
    let joint = matches!(mode, Mode::CorrectedPhased(_, Rounding::Joint));
    let (mut preds, mut cc_phases) = edge_predictions(phasing.as_ref(), corr_phased, x, ne.min(nd), joint);
    // A rotated level reads every value first, then makes and undoes the rotations
    // (none predicts a value: their models see the rotated values).
    let rotated = matches!(mode, Mode::Rotated | Mode::Shifted(..));
    if rotated {
        return decode_rotated(&mut dec, &mut m, level, family, x, mags, &normals, mode, (unbinned, zero), threads)
            .map(|()| models.last = Some(m));
    }
    let mut running = RunningBins::new(level, family);
    for i in 0..nd {
        // What a Catmull-Clark level in mode 6 adds to the detail: its prediction.
        let mut fine = [0i64; 3];
        match &phasing {
            Some(Phasing::Cc(p)) if i == ne && corr_phased => {
                face_predictions(p, level, nd, x, &mut preds, &mut cc_phases, joint)
            }
            Some(Phasing::Cc(p)) if i == ne => synthesise_edges(p, level, x),
            _ => {}
        }
        let (class, bins, fd) = contexts(level, mags, family, i, running.as_ref());
        let fr = if framed {
            frame(level, &normals, fd)
        } else {
            None
        };
        let (offset, joint_phases) = detail_offset(level, x, mode, i, fr, &cc_phases)?;
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
        let (r, mg) = match (fr, ph) {
            (None, Phased::No) => get_plain(&mut dec, &mut m, class, bins, unbinned, zero)?,
            _ => get(&mut dec, &mut m, class, bins, fr, ph, unbinned, zero)?,
        };
        mags[nv + i] = mg;
        if let Some(r) = &mut running {
            r.read(level, i, mg);
        }
        let d = match offset {
            Some(c) => in_range(plus(r, c))?,
            None => r,
        };
        for k in 0..3 {
            x[k][nv + i] = d[k].wrapping_add(fine[k]);
        }
    }
    if let Some(Phasing::Cc(p)) = &phasing {
        finish_cc(p, level, x, corr_phased.then_some(&preds));
    }
    models.last = Some(m);
    Ok(())
}

/// A detail's rotation as far as [`Rotations::prepare`] makes it: its frame detail,
/// whether it has a frame, the first two plane rotations, the normal's components that
/// make the second, and the tangent reference's as the rotations leave it.
#[derive(Clone, Copy)]
struct Partial {
    fd: u32,
    framed: bool,
    g0: Givens,
    g1: Givens,
    n: [i64; 2],
    t: [i64; 3],
}

/// A rotated level's rotations (modes 4 and 5, SPEC.md 10.5), made a block of details
/// at a time in passes of one plane rotation each, into buffers kept between blocks:
/// the same rotations as [`RotFrame::new`]'s, whose three steps depend on each other (a
/// division, then products, then the next), so that a pass holds short, independent
/// steps of many details at once where one detail's whole chain would leave the
/// processor waiting.
struct Rotations<'a, 'l> {
    level: &'l Level,
    coarse: [&'a [i64]; 3],
    family: Family,
    normals: &'a FaceNormals,
    mode: Mode<'a>,
}

impl Rotations<'_, '_> {
    /// The first two rotations of details `lo..hi` into `parts` (a scratch kept between
    /// blocks; a detail without a frame turns a stand-in normal, unused).
    fn prepare(&self, lo: usize, hi: usize, parts: &mut Vec<Partial>) {
        let (level, family) = (self.level, self.family);
        parts.clear();
        parts.extend((lo..hi).map(|i| {
            let fd = frame_detail(level, family, i);
            let f = frame(level, self.normals, fd);
            let n = f.map_or([1, 0, 0], |(_, n)| n);
            let t = to_24_bits(tangent_ref(level, self.coarse, fd));
            let g0 = Givens::towards(n[0], n[1]);
            let (t0, t1) = g0.apply(t[0], t[1]);
            Partial {
                fd: fd as u32,
                framed: f.is_some(),
                g0,
                g1: g0,
                n: [g0.apply(n[0], n[1]).0, n[2]],
                t: [t0, t1, t[2]],
            }
        }));
        for p in parts.iter_mut() {
            p.g1 = Givens::towards(p.n[0], p.n[1]);
            p.t[2] = p.g1.apply(p.t[0], p.t[2]).1;
        }
    }

    /// The third rotation of a detail that [`Rotations::prepare`] began, and what the
    /// mode subtracts from its rotated values; `None` without a frame.
    #[inline]
    fn finish(&self, p: &Partial) -> Option<(Rotation, [i64; 3])> {
        p.framed.then(|| {
            let rot = Rotation([p.g0, p.g1, Givens::towards(p.t[1], p.t[2])]);
            let shifted = matches!(self.mode, Mode::Shifted(..));
            let fd = p.fd as usize;
            let fr = RotFrame::with(self.level, self.coarse, self.family, fd, rot, shifted);
            (fr.rot, fr.pred(self.mode))
        })
    }

    /// Each detail `lo..` in `f` (whose first entry is detail `base`'s) undone with its
    /// rotation from `rots`: what the mode subtracted added back, then the rotation
    /// undone (SPEC.md 10.5), each within the bound of 9.3.
    fn undo<T>(
        &self,
        lo: usize,
        base: usize,
        rots: &[T],
        rot: impl Fn(&T) -> Option<(Rotation, [i64; 3])>,
        f: [&mut [i64]; 3],
    ) -> Result<()> {
        let [f0, f1, f2] = f;
        for (i, t) in (lo..).zip(rots) {
            if let Some((rot, pred)) = rot(t) {
                let j = i - base;
                let r = in_range(plus([f0[j], f1[j], f2[j]], pred))?;
                let d = in_range(Some(rot.inverse(r)))?;
                (f0[j], f1[j], f2[j]) = (d[0], d[1], d[2]);
            }
        }
        Ok(())
    }
}

/// A detail's rotation and what its mode subtracts, as [`Rotations::finish`] gives it.
type RotationOf = Option<(Rotation, [i64; 3])>;

/// Fewest details for which a level's work beside its reading (a rotated level's
/// rotations, the decoder's transform) goes to another thread.
pub const BESIDE_MIN: usize = 4096;

/// Details per block of [`decode_rotated`]: the rotations of one block are made while
/// the values of the one before are read (a bounded store, whatever the level's size).
const ROT_BLOCK: usize = 16384;

/// Details per [`Rotations`] pass on one thread (about 300 kB of scratch).
const ROT_PASS: usize = 4096;

/// A rotated level (modes 4 and 5, SPEC.md 10.5) read as [`decode`] reads it: no value
/// read depends on a rotation (their models see the rotated values, and no frame
/// predicts), so the values are read first, then each detail's rotation is made and
/// undone, in blocks. With `threads` above 1 and enough details, each block's rotations
/// are made on another thread beside the reading of its values, and undone there beside
/// the reading of the next (one thread for the level: a thread started per block waited
/// up to milliseconds for its start). The coarse values `x[k][..nv]` are read-only
/// meanwhile.
#[allow(clippy::too_many_arguments)]
fn decode_rotated(
    dec: &mut Decoder,
    m: &mut Models,
    level: &Level,
    family: Family,
    x: &mut [Vec<i64>; 3],
    mags: &mut [[u8; 3]],
    normals: &FaceNormals,
    mode: Mode<'_>,
    (unbinned, zero): (bool, u8),
    threads: usize,
) -> Result<()> {
    let (nv, nd) = (level.nv, family.details(level));
    let [x0, x1, x2] = x;
    let (c0, f0) = x0.split_at_mut(nv);
    let (c1, f1) = x1.split_at_mut(nv);
    let (c2, f2) = x2.split_at_mut(nv);
    let rots = Rotations {
        level,
        coarse: [c0, c1, c2],
        family,
        normals,
        mode,
    };
    let mut running = RunningBins::new(level, family);
    // Details lo..hi into `f`, whose first entry is detail `base`'s.
    let mut read = |lo: usize, hi: usize, base: usize, f: [&mut [i64]; 3]| -> Result<()> {
        let [f0, f1, f2] = f;
        for i in lo..hi {
            let (class, bins, _) = contexts(level, mags, family, i, running.as_ref());
            let (r, mg) = get_plain(dec, m, class, bins, unbinned, zero)?;
            mags[nv + i] = mg;
            if let Some(r) = &mut running {
                r.read(level, i, mg);
            }
            (f0[i - base], f1[i - base], f2[i - base]) = (r[0], r[1], r[2]);
        }
        Ok(())
    };
    if !(threads > 1 && nd >= BESIDE_MIN) {
        // (The passes over a part of a block at a time: a smaller scratch.)
        let mut parts = Vec::with_capacity(nd.min(ROT_PASS));
        let mut lo = 0;
        while lo < nd {
            let hi = (lo + ROT_BLOCK).min(nd);
            read(lo, hi, 0, [&mut *f0, &mut *f1, &mut *f2])?;
            for lo in (lo..hi).step_by(ROT_PASS) {
                rots.prepare(lo, (lo + ROT_PASS).min(hi), &mut parts);
                let f = [&mut *f0, &mut *f1, &mut *f2];
                rots.undo(lo, 0, &parts, |p| rots.finish(p), f)?;
            }
            lo = hi;
        }
        return Ok(());
    }
    let mut parts = Vec::with_capacity(nd.min(ROT_BLOCK));
    // On two threads, a pipeline with one helper for the level: it makes each block's
    // rotations (which need no value) while the block is read, then undoes the block
    // once the reading hands its values over, while the next block is read. Errors come
    // in the one-thread order: the reading stops at its first error, after the blocks
    // before it are undone, and an undoing error (always of an earlier block) comes
    // first.
    let blocks: Vec<(usize, usize)> = (0..nd)
        .step_by(ROT_BLOCK)
        .map(|lo| (lo, (lo + ROT_BLOCK).min(nd)))
        .collect();
    let (rots, blocks) = (&rots, &blocks);
    let (hand, take) = std::sync::mpsc::channel::<[&mut [i64]; 3]>();
    std::thread::scope(|s| {
        let helper = s.spawn(move || -> Result<()> {
            let mut made: Vec<RotationOf> = Vec::with_capacity(nd.min(ROT_BLOCK));
            for &(lo, hi) in blocks {
                rots.prepare(lo, hi, &mut parts);
                made.clear();
                made.extend(parts.iter().map(|p| rots.finish(p)));
                // The block's values, once read (none when the reading stopped).
                let Ok(f) = take.recv() else {
                    return Ok(());
                };
                rots.undo(lo, lo, &made, |&r| r, f)?;
            }
            Ok(())
        });
        let mut rest = [f0, f1, f2];
        let mut reading = Ok(());
        for &(lo, hi) in blocks {
            let [a, b, c] = rest;
            let ((a, a2), (b, b2), (c, c2)) = (
                a.split_at_mut(hi - lo),
                b.split_at_mut(hi - lo),
                c.split_at_mut(hi - lo),
            );
            rest = [a2, b2, c2];
            reading = read(lo, hi, lo, [&mut *a, &mut *b, &mut *c]);
            // (A helper gone has met an error in an earlier block.)
            if reading.is_err() || hand.send([a, b, c]).is_err() {
                break;
            }
        }
        drop(hand);
        let undone = helper.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
        undone.and(reading)
    })
}

/// The level's mode from its mode byte and the mode's parameters, checked against what
/// the level has (tangent targets, phases), and the rest of the payload: the stream.
fn read_mode<'a, 't>(
    payload: &'a [u8],
    family: Family,
    nd: usize,
    targets: Option<&'t [[i64; 3]]>,
    phasing: Option<&Phasing<'_>>,
) -> Result<(Mode<'t>, &'a [u8])> {
    let no_targets = || Error::corrupt("LEVL", "tangent mode on a level without tangent targets");
    let no_phases = || Error::corrupt("LEVL", "phase mode on a level without prediction phases");
    Ok(match mode_of(payload).zip(payload.get(1..)) {
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
        Some((6, rest)) => match phasing {
            Some(Phasing::Ready(p)) if p.codes.iter().all(|p| p.len() == nd) => {
                (Mode::Phased, rest)
            }
            Some(Phasing::Cc(_)) if family != Family::Sqrt2 => (Mode::Phased, rest),
            _ => return Err(no_phases()),
        },
        Some((5, rest)) => match rest.split_first() {
            Some((&w, rest)) if w >> 4 <= 8 && w & 15 <= 8 => (Mode::Shifted(w >> 4, w & 15), rest),
            _ => return Err(Error::corrupt("LEVL", "bad shift weights")),
        },
        Some((8, rest)) if family != Family::Sqrt2 => {
            let (w, _, rest) = read_weights(rest, false)?;
            (Mode::Corrected(w), rest)
        }
        Some((9, rest)) if family != Family::Sqrt2 => match phasing {
            Some(Phasing::Cc(_)) => {
                let (w, r, rest) = read_weights(rest, true)?;
                (Mode::CorrectedPhased(w, r), rest)
            }
            _ => return Err(no_phases()),
        },
        Some((m, _)) => return Err(Error::corrupt("LEVL", format!("unknown level mode {m}"))),
        None => return Err(Error::corrupt("LEVL", "empty level section")),
    })
}
/// Modes 6 and 9 on a Catmull-Clark level, before its details are read: the phases of
/// its first `n` details (the edge points') from the coarse values, and for mode 9
/// (`corrected`) their predictions on each axis.
fn edge_predictions(
    phasing: Option<&Phasing<'_>>,
    corrected: bool,
    x: &[Vec<i64>; 3],
    n: usize,
    joint: bool,
) -> ([Vec<i64>; 3], Phases) {
    let mut preds: [Vec<i64>; 3] = Default::default();
    let mut phases = Phases::default();
    match phasing {
        Some(Phasing::Cc(p)) if corrected => {
            for k in 0..3 {
                for e in 0..n {
                    let c = keep(p, &x[k], e, &mut phases, k, joint);
                    preds[k].push(c);
                }
            }
        }
        Some(Phasing::Cc(p)) => phases = p.phases(x, n, false),
        _ => {}
    }
    (preds, phases)
}

/// Modes 6 and 9 on a Catmull-Clark level, after its details are read: mode 9 adds the
/// predictions `preds` it kept to every detail; mode 6 synthesises the edge points if
/// the level had no face point (it synthesised them before its first face point).
fn finish_cc(
    p: &crate::transform::Phaser<'_>,
    level: &Level,
    x: &mut [Vec<i64>; 3],
    preds: Option<&[Vec<i64>; 3]>,
) {
    let nv = level.nv;
    match preds {
        Some(preds) => {
            for (xk, pk) in x.iter_mut().zip(preds) {
                for (v, &c) in xk[nv..].iter_mut().zip(pk) {
                    *v = v.wrapping_add(c);
                }
            }
        }
        None if x[0].len() - nv <= level.ne() => synthesise_edges(p, level, x),
        None => {}
    }
}

/// The phases of a detail's correction rounded together with its prediction (mode 9,
/// joint rounding), per axis.
type Joint = [u8; 3];

/// Mode 9, detail `i`'s prediction on one axis, its phase and (joint rounding) fraction
/// kept in `ph`.
fn keep(
    p: &crate::transform::Phaser<'_>,
    xk: &[i64],
    i: usize,
    ph: &mut Phases,
    k: usize,
    joint: bool,
) -> i64 {
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
}

/// Mode 9, once a level's edge points are read: the face points' predictions from the
/// fine edge points (their details plus `preds`), kept in `preds` with their phases;
/// then the edge points hold their details again.
fn face_predictions(
    p: &crate::transform::Phaser<'_>,
    level: &Level,
    nd: usize,
    x: &mut [Vec<i64>; 3],
    preds: &mut [Vec<i64>; 3],
    phases: &mut Phases,
    joint: bool,
) {
    let (nv, ne) = (level.nv, level.ne());
    for k in 0..3 {
        let xk = &mut x[k];
        for e in 0..ne {
            xk[nv + e] = xk[nv + e].wrapping_add(preds[k][e]);
        }
        for f in ne..nd {
            let c = keep(p, xk, f, phases, k, joint);
            preds[k].push(c);
        }
        for e in 0..ne {
            xk[nv + e] = xk[nv + e].wrapping_sub(preds[k][e]);
        }
    }
}

/// What detail `i` of a level in `mode` adds to its coded value (SPEC.md 10.4, 10.8,
/// 10.9), and with joint rounding the phases its correction gives.
fn detail_offset(
    level: &Level,
    x: &[Vec<i64>; 3],
    mode: Mode<'_>,
    i: usize,
    fr: Option<(usize, [i64; 3])>,
    cc_phases: &Phases,
) -> Result<(Option<[i64; 3]>, Option<Joint>)> {
    let out_of_range = || Error::corrupt("LEVL", "detail out of range");
    Ok(match mode {
        Mode::CorrectedPhased(w, Rounding::Joint) => {
            let n = correction_sums(level, x, &w, i);
            let (c, q) = joint_correction(n, fracs_at(cc_phases, i)).ok_or_else(out_of_range)?;
            (Some(c), Some(q))
        }
        Mode::Corrected(w) | Mode::CorrectedPhased(w, _) => (
            Some(correction(correction_sums(level, x, &w, i)).ok_or_else(out_of_range)?),
            None,
        ),
        _ => (mode.offset(i, fr), None),
    })
}

/// Synthesises a Catmull-Clark level's edge points `x[k][nv..nv + ne]` in place (their
/// details plus predictions from the coarse values), for mode 6's face points.
pub(super) fn synthesise_edges(
    p: &crate::transform::Phaser<'_>,
    level: &Level,
    x: &mut [Vec<i64>; 3],
) {
    let nv = level.nv;
    for xk in x.iter_mut() {
        for e in 0..level.ne() {
            // Predicted from the coarse values alone: unchanged as the edge points change.
            let c = p.predict(xk, e).0;
            xk[nv + e] = xk[nv + e].wrapping_add(c);
        }
    }
}

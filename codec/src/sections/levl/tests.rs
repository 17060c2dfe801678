//! Tests of the LEVL coding.

use super::read::*;
use super::write::*;
use super::*;
use crate::topology::fixtures::{prism_with_triangles, pseudo};

/// [`super::encode`] of a Catmull-Clark level without a limit or targets.
fn encode_fresh(
    level: &Level,
    x: &[Vec<i64>; 3],
    coarse: &[Vec<i64>; 3],
    models: &mut LevelModels,
) -> Vec<u8> {
    encode(level, Family::Cc, x, coarse, models, None, None, usize::MAX).unwrap()
}

/// [`super::decode`] of one level from fresh models: the coarse values with the level
/// read into them.
fn decode_fresh(
    bytes: &[u8],
    level: &Level,
    family: Family,
    coarse: &[Vec<i64>; 3],
    targets: Option<&[[i64; 3]]>,
    phasing: Option<Phasing<'_>>,
) -> Result<[Vec<i64>; 3]> {
    let mut y = coarse.clone();
    let mut models = LevelModels::new();
    decode(bytes, level, family, &mut y, &mut models, targets, phasing, 1)?;
    Ok(y)
}

fn refined(times: usize) -> Level {
    let mut t = prism_with_triangles();
    for _ in 0..times {
        t = Level::new(&t).unwrap().fine();
    }
    Level::new(&t).unwrap()
}

/// The encoder's packed per-detail normal frames are the decoder's frames from the
/// faces' normals, detail for detail, for both families' detail numbering, small and
/// large values (the reduced normals fill 24 bits, some negative).
#[test]
fn packed_normal_frames_are_the_frames() {
    let level = refined(2);
    for (seed, bits) in [(1u64, 6u32), (5, 20), (9, 53)] {
        let x: [Vec<i64>; 3] = std::array::from_fn(|k| pseudo(seed + k as u64, level.nv, bits));
        let normals = face_normals(&level, &x);
        for (family, ne) in [(Family::Cc, 0), (Family::Sqrt2, level.ne())] {
            let packed = normal_frames(&level, &x, family);
            assert_eq!(packed.len(), family.details(&level));
            let mut wide = 0;
            for (i, p) in packed.iter().enumerate() {
                let want = frame(&level, &normals, ne + i);
                assert_eq!(p.get(), want, "{family:?} detail {i}, {bits}-bit values");
                wide += want.is_some_and(|(_, n)| n.iter().any(|v| v.abs() >= 1 << 23)) as usize;
            }
            if bits > 6 {
                assert!(wide > 0, "{family:?}: no normal reaches 24 bits");
            }
        }
    }
}

/// Newell's normal in 64 bits where it fits, else in 128: the same integers.
#[test]
fn face_normals_agree_with_128_bit_arithmetic() {
    let level = refined(1);
    for (seed, bits) in [(1u64, 20u32), (4, 29), (2, 34), (3, 53)] {
        let mut x: [Vec<i64>; 3] = std::array::from_fn(|k| pseudo(seed + k as u64, level.nv, bits));
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
            let kept = match &all {
                FaceNormals::Narrow(v) => v[f].map(i128::from),
                FaceNormals::Wide(v) => v[f],
            };
            assert_eq!(kept, n, "face {f} of all, {bits}-bit values");
            wide += face_normal_64(&level, &x, f).is_none() as usize;
        }
        // 64-bit normals where every one fits, and the same frames as from 128-bit ones.
        assert_eq!(matches!(all, FaceNormals::Narrow(_)), bits <= 29, "{bits}-bit values");
        let exact = FaceNormals::Wide((0..level.nf()).map(|f| face_normal(&level, &x, f)).collect());
        for d in 0..level.ne() + level.nf() {
            assert_eq!(frame(&level, &all, d), frame(&level, &exact, d), "detail {d}, {bits}-bit values");
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
    assert_eq!(slot_bins(&level, &mags, Family::Cc, 0), [6; 3]);
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
            slot_bins(&level, &mags, Family::Cc, e),
            want.map(|b| b as usize),
            "edge {e}"
        );
    }
    // A face point: its edge points only.
    assert_eq!(slot_bins(&level, &mags, Family::Cc, ne), [2; 3]);
}

/// The decoder's running neighbour sums give [`slot_bins`]'s bins detail by detail,
/// with magnitudes up to 53 and some coarse vertices unknown.
#[test]
fn running_bins_are_the_slot_bins() {
    let level = refined(2);
    let (nv, nd) = (level.nv, level.ne() + level.nf());
    let m = pseudo(7, 3 * (nv + nd), 6);
    let mut mags: Vec<[u8; 3]> = (0..nv + nd)
        .map(|i| std::array::from_fn(|k| (m[3 * i + k].unsigned_abs() % 54) as u8))
        .collect();
    for v in mags.iter_mut().take(nv / 3) {
        *v = [UNKNOWN; 3];
    }
    let mut running = RunningBins::new(&level, Family::Cc).unwrap();
    let mut distinct = std::collections::BTreeSet::new();
    for i in 0..nd {
        let bins = running.bins(&level, &mags, Family::Cc, i);
        assert_eq!(bins, slot_bins(&level, &mags, Family::Cc, i), "detail {i}");
        distinct.extend(bins);
        running.read(&level, i, mags[nv + i]);
    }
    // The data reaches most bins: the comparison is not of constants.
    assert!(distinct.len() >= 4, "{distinct:?}");
    assert!(RunningBins::new(&level, Family::Sqrt2).is_none());
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
        let y = decode_fresh(&bytes, &level, Family::Cc, &coarse, None, None).unwrap();
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

/// The table's rotations take their own direction onto the first axis, the factors
/// growing with the angle up to 45 degrees (tan 22.5 and sin 45 degrees at the end).
#[test]
fn the_rotation_table_follows_its_angles() {
    for (m, &(p, u)) in TURNS.iter().enumerate() {
        let g = Givens::towards(1 << 28, (m as i64) << 18);
        assert_eq!((g.turns, g.p, g.u), (0, p, u), "entry {m}");
        let v = g.apply(1 << 28, (m as i64) << 18);
        assert!(v.1.abs() <= 2, "entry {m}: {v:?}");
        if m > 0 {
            assert!(p > TURNS[m - 1].0 && u < TURNS[m - 1].1, "entry {m}");
        }
    }
    let one = (1i64 << 30) as f64;
    let (p, u) = TURNS[1 << TURN_BITS];
    assert_eq!((p, u), (444_758_426, -759_250_126), "SPEC.md 10.5's last entry");
    assert!((p as f64 / one - (std::f64::consts::PI / 8.0).tan()).abs() < 1e-8);
    assert!((u as f64 / one + std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-8);
    // Every quadrant and both signs: to within half a table step of the positive axis.
    let k = 1i64 << 30;
    for (a, b) in [(k, 0), (0, k), (-k, 0), (0, -k), (k, k), (-k, k), (-k, -k), (k, -k), (3, -7), (-5, 2), (0, 0)] {
        let g = Givens::towards(a, b);
        let v = g.apply(a, b);
        assert!(v.0 >= 0 && v.1.abs() <= v.0 / 1000 + 2, "({a}, {b}): {v:?}");
        assert_eq!(g.undo(v.0, v.1), (a, b));
    }
}

/// The branch-free rotation choice is SPEC.md's case by case: every quadrant, the
/// diagonals and axes, zero, and random pairs up to 2^40.
#[test]
fn rotation_choice_without_branches_is_the_cases() {
    let raw = pseudo(21, 4000, 40);
    let small = pseudo(22, 4000, 4);
    let k = 1i64 << 39;
    let mut pairs: Vec<(i64, i64)> = raw.chunks(2).map(|c| (c[0], c[1])).collect();
    pairs.extend(small.chunks(2).map(|c| (c[0], c[1])));
    for a in [-k, -3, -1, 0, 1, 3, k] {
        for b in [-k, -3, -1, 0, 1, 3, k, a, -a] {
            pairs.push((a, b));
        }
    }
    for (a, b) in pairs {
        assert_eq!(Givens::towards(a, b), Givens::towards_by_cases(a, b), "({a}, {b})");
    }
}

/// Rotations are exact on integers, take the normal onto the first component and the
/// tangent reference's tangential part onto the second.
#[test]
fn rotations_are_exact_and_align_the_frame() {
    let raw = pseudo(11, 600, 24);
    let big = pseudo(12, 600, 52);
    let mut cases: Vec<([i64; 3], [i64; 3])> = (0..100)
        .map(|c| {
            let n = [raw[6 * c], raw[6 * c + 1], raw[6 * c + 2]];
            let t = [raw[6 * c + 3], raw[6 * c + 4], raw[6 * c + 5]].map(|v| v >> 5);
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
            [1i64, 2, 3],
            [0, 0, 0],
            n,
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
        // (Table rotations: within half a step of 2^-10 each, three steps.)
        assert!(r[1].abs().max(r[2].abs()) < 1 << 31, "case {c}: {r:?}");
        // The tangent's part across the normal lands on the positive second axis.
        let tf = t.map(|v| v as f64);
        let tn = (0..3).map(|k| tf[k] * nf[k]).sum::<f64>() / (len * len);
        let tp: Vec<f64> = (0..3).map(|k| tf[k] - tn * nf[k]).collect();
        let tl = tp.iter().map(|v| v * v).sum::<f64>().sqrt();
        if tl > 1e-3 * len.max(1.0) && tl > 4.0 {
            let s = (1u64 << 40) as f64 / tl;
            let r = rot.forward(std::array::from_fn(|k| (tp[k] * s).round() as i64));
            assert!(
                r[1] > 0 && r[0].abs().max(r[2].abs()) < 1 << 31,
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
    let normals = normal_frames(level, coarse, Family::Cc);
    let prep = Prepared {
        frames: rot_frames(level, coarse, &normals, Family::Cc, true),
        normals,
        ..Default::default()
    };
    let mut m = Models::new();
    let mut mags = Vec::new();
    encode_mode(
        level, Family::Cc, x, coarse, &prep, None, &mut mags, mode, false, &mut m, limit, 0, Sample::All,
    )
}

/// Codes `x`'s details in `mode`, decodes them and checks the round trip; the
/// payload's size.
fn code_in_mode(level: &Level, coarse: &[Vec<i64>; 3], x: &[Vec<i64>; 3], mode: Mode<'_>) -> usize {
    let body = body_in_mode(level, coarse, x, mode).expect("in range");
    let mut payload = mode.bytes();
    payload.extend_from_slice(&body);
    let y = decode_fresh(&payload, level, Family::Cc, coarse, None, None);
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
    let frames = rot_frames(&level, &coarse, &normal_frames(&level, &coarse, Family::Cc), Family::Cc, true);
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
        if let Some(off) = edge_offset(level, slices(coarse), e) {
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
    let frames = rot_frames(&level, &coarse, &normal_frames(&level, &coarse, Family::Cc), Family::Cc, true);
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
        let y = decode_fresh(&bytes, &level, Family::Cc, &coarse, None, None);
        assert_eq!(y.unwrap(), x, "planned {plan}");
    }
}

/// A level coded in `mode` alone from fresh models, with its mode byte.
fn forced(
    level: &Level,
    family: Family,
    x: &[Vec<i64>; 3],
    coarse: &[Vec<i64>; 3],
    phases: Option<&Phases>,
    mode: Mode<'_>,
) -> Vec<u8> {
    forced_zero(level, family, x, coarse, phases, mode, None)
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
    encode(level, Family::Cc, x, coarse, &mut models, None, ph, usize::MAX).unwrap()
}

/// [`forced`] with the zero slots `zero` where given, else the ones the encoder finds.
fn forced_zero(
    level: &Level,
    family: Family,
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
        normals: normal_frames(level, coarse, family),
        corrections,
        ..Default::default()
    };
    let zero = zero.unwrap_or_else(|| axis_zero_slots(level, family, x, mode, &prep, phases));
    let body = encode_mode(
        level,
        family,
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
        Sample::All,
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
        let bytes = forced(&level, Family::Cc, &x, &coarse, Some(&phases), Mode::Phased);
        let ph = Some(Phasing::Cc(&p));
        let y = decode_fresh(&bytes, &level, Family::Cc, &coarse, None, ph);
        // Read with the decoder's phases, the level comes back synthesised.
        assert_eq!(y.unwrap(), fine, "{w:?}");
        let err = decode_fresh(&bytes, &level, Family::Cc, &coarse, None, None);
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
    let two = forced(&level, Family::Sqrt2, &x, &coarse, None, Mode::Tangent(&targets));
    let seven = forced(
        &level,
        Family::Sqrt2,
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
        let r = decode_fresh(bytes, &level, Family::Sqrt2, &coarse, targets, None);
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
        decode_fresh(&payload, &level, Family::Cc, &coarse, None, None)
    };
    assert_eq!(run(&[5, 0x25]).unwrap(), x);
    for head in [&[5u8, 0x95][..], &[5, 0x29], &[3], &[6]] {
        let err = run(head).unwrap_err().to_string();
        assert!(err.contains("LEVL"), "{head:?}: {err}");
    }
    // Mode 5 without its weights.
    let err = decode_fresh(&[5], &level, Family::Cc, &coarse, None, None).unwrap_err();
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
    let plain = forced(&level, Family::Cc, &x, &coarse, None, Mode::Plain);
    assert!(bytes.len() < plain.len(), "{} {}", bytes.len(), plain.len());
    // As the encoder chose, and with the generating weights.
    let gen_bytes = forced(&level, Family::Cc, &x, &coarse, None, Mode::Corrected(gen));
    for b in [bytes, gen_bytes] {
        let y = decode_fresh(&b, &level, Family::Cc, &coarse, None, None);
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
    let bytes = forced(&level, Family::Cc, &x, &coarse, None, Mode::Corrected(w));
    assert_eq!(&bytes[..6], &[8, 0b1100, 246, 5, 64, 192]);
    let body = &bytes[6..];
    let run = |head: &[u8]| {
        let mut payload = head.to_vec();
        payload.extend_from_slice(body);
        decode_fresh(&payload, &level, Family::Cc, &coarse, None, None)
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
        let err = decode_fresh(&bytes[..cut], &level, Family::Cc, &coarse, None, None);
        assert!(err.unwrap_err().to_string().contains("LEVL"), "{cut}");
    }
    // A sqrt(2) level has no mode 8.
    let t = prism_with_triangles();
    let sq = Level::new(&t).unwrap();
    let sx: [Vec<i64>; 3] = std::array::from_fn(|_| vec![0; sq.nv + sq.nf()]);
    let sc: [Vec<i64>; 3] = std::array::from_fn(|_| vec![0; sq.nv]);
    let mut payload = vec![8, 0];
    payload.extend(forced(&sq, Family::Sqrt2, &sx, &sc, None, Mode::Plain).split_off(1));
    let err = decode_fresh(&payload, &sq, Family::Sqrt2, &sc, None, None).unwrap_err();
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
        let bytes = forced(&level, Family::Cc, &x, &coarse, Some(&phases), mode);
        assert_eq!(bytes[0], 9);
        let y = decode_fresh(&bytes, &level, Family::Cc, &coarse, None, Some(Phasing::Cc(&p)));
        assert_eq!(y.unwrap(), fine, "{w:?}");
        let err = decode_fresh(&bytes, &level, Family::Cc, &coarse, None, None).unwrap_err();
        assert!(err.to_string().contains("phase"), "{w:?}: {err}");
        // The same weights unphased (mode 8) is another stream.
        let plain = forced(&level, Family::Cc, &x, &coarse, None, Mode::Corrected(wts));
        assert_ne!(plain[1..], bytes[1..]);
        let y = decode_fresh(&plain, &level, Family::Cc, &coarse, None, None);
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

/// The encoder's shortcut for a zero axis under joint rounding is the joint correction
/// of a 0 numerator, for every fraction.
#[test]
fn joint_rounds_to_0_is_the_joint_correction_of_0() {
    let mut zeros = 0;
    for f in i16::MIN..=i16::MAX {
        let full = joint_correction([0; 3], [f, 0, 0]).is_some_and(|(c, _)| c[0] == 0);
        assert_eq!(joint_rounds_to_0(f), full, "fraction {f}");
        zeros += full as u32;
    }
    // Both answers occur: [-256, 256) rounds to 0.
    assert_eq!(zeros, 512);
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
            decode_fresh(bytes, &level, Family::Cc, &coarse, None, ph)
        };
        let want = if phased { &fine } else { &x };
        let at = |z| forced_zero(&level, Family::Cc, &x, &coarse, Some(&phases), mode, z);
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
    let y = decode_fresh(&bytes, &level, Family::Cc, &coarse, None, ph).unwrap();
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
        let y = decode_fresh(&bytes, &level, Family::Cc, &coarse, None, None);
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
            let pred: [(i64, u8, i16); 3] = std::array::from_fn(|k| p.predict_frac(&fine[k], i));
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
            forced(&level, Family::Cc, &x, &coarse, Some(&phases), mode)
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
            decode_fresh(bytes, &level, Family::Cc, &coarse, None, ph)
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
        let y = decode_fresh(&bytes, &level, Family::Cc, &coarse, None, None);
        assert_eq!(&y.unwrap(), x);
        // The other choice, as a plan: larger, and exact too.
        let mut models = LevelModels::new();
        models.only = Some(vec![bytes[0] ^ UNBINNED].into_iter());
        let other = encode_fresh(&level, x, &coarse, &mut models);
        assert_eq!(other[0], bytes[0] ^ UNBINNED);
        assert!(other.len() > bytes.len(), "{} {}", other.len(), bytes.len());
        let y = decode_fresh(&other, &level, Family::Cc, &coarse, None, None);
        assert_eq!(&y.unwrap(), x);
        // Read with the flag flipped: an error or other details.
        let mut flipped = bytes.clone();
        flipped[0] ^= UNBINNED;
        let y = decode_fresh(&flipped, &level, Family::Cc, &coarse, None, None);
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

/// A large level whose mode the encoder chooses on a sample of its details
/// (`LevelModels::sampled`) decodes exactly, without any flag of the sample, and codes
/// within 3 % of the search that codes every mode whole.
#[test]
fn sampled_mode_choice_round_trips() {
    let mut times = 1;
    while refined(times).ne() + refined(times).nf() < 16_384 {
        times += 1;
    }
    let level = refined(times);
    let (nv, nd) = (level.nv, level.ne() + level.nf());
    let coarse: [Vec<i64>; 3] = std::array::from_fn(|k| pseudo(40 + k as u64, nv, 24));
    // Details of three sizes: the axes' models differ.
    let noise: [Vec<i64>; 3] = std::array::from_fn(|k| pseudo(50 + k as u64, nd, 4 + 3 * k as u32));
    let mut x = coarse.clone();
    for (xk, nk) in x.iter_mut().zip(&noise) {
        xk.extend_from_slice(nk);
    }
    let mut whole = LevelModels::new();
    let all = encode_fresh(&level, &x, &coarse, &mut whole);
    let mut models = LevelModels::new();
    models.sampled = true;
    let sampled = encode_fresh(&level, &x, &coarse, &mut models);
    let y = decode_fresh(&sampled, &level, Family::Cc, &coarse, None, None).unwrap();
    assert_eq!(y, x, "round trip");
    assert!(
        sampled.len() * 100 <= all.len() * 103,
        "sampled {} B, every mode whole {} B",
        sampled.len(),
        all.len()
    );
}

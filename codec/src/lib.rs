//! subwave's codec: the integer mesh model, mesh file I/O, quantisation, entropy coding
//! and the container's sections. Most users want the facade crate `subwave`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// Numeric kernels index several arrays (axes, positions, weights) in lockstep.
#![allow(clippy::needless_range_loop)]

pub mod entropy;
pub mod error;
pub mod io;
pub mod mesh;
pub mod quant;
pub mod sections;
pub mod topology;
pub mod transform;

pub use error::{Error, Result};
pub use mesh::{Mesh, MAX_COORD};
pub use quant::{FloatWidth, Quantization, RawCoords};
pub use sections::head::{Family, Header, Source, Transform};
pub use sections::vmap::ValueMap;
pub use subwave_container::{Limits, FORMAT_VERSION};
pub use transform::polar::DiscTransform;
pub use transform::Wavelet;

use std::collections::HashMap;

use sections::{base, levl, ordr};
use subwave_container::{Container, ContainerWriter, SectionKind};
use topology::{Canonical, Level, Topo};
use transform::{fit, polar, sqrt2};

/// Which transform to use on a hierarchy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TransformChoice {
    /// Try every transform and keep the smallest container.
    #[default]
    Auto,
    /// This one.
    Fixed(Wavelet),
    /// The subdivision fit (SPEC.md 9.10) on a Catmull-Clark hierarchy.
    Fit,
}

/// How to encode.
#[derive(Debug, Clone)]
pub struct EncodeOptions {
    /// Store the input's vertex and face order (ORDR section).
    pub keep_order: bool,
    /// The format the mesh was read from, recorded so decoding can default to it.
    pub source: Source,
    /// The transform for subdivision levels.
    pub transform: TransformChoice,
    /// Most refinement levels to look for (0: code the mesh flat).
    pub max_levels: u8,
    /// Polar hierarchies: the transform of the poles' discs (SPEC.md 9.9); `None` tries
    /// each with the best Catmull-Clark transform and keeps the smallest.
    pub disc: Option<DiscTransform>,
    /// Per-axis value maps (SPEC.md 3.1): `None` tries the sparse axes' map beside no
    /// map and keeps the smaller container, `Some(true)` maps every axis, `Some(false)`
    /// none.
    pub value_map: Option<bool>,
    /// How many threads the encoder may use (0 counts as 1): `auto` then codes its
    /// candidate families and transforms at once. The container is the same for every
    /// count; each thread holds a coding's working memory.
    pub threads: usize,
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            keep_order: false,
            source: Source::Unknown,
            transform: TransformChoice::Auto,
            max_levels: 16,
            disc: None,
            value_map: None,
            threads: 1,
        }
    }
}

/// One section's place in a container.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SectionInfo {
    /// Its kind code, as text (`HEAD`, `BASE`, ...).
    pub kind: String,
    /// Bytes it occupies, overhead included.
    pub bytes: usize,
    /// A level section's coding mode (SPEC.md 10.1, 10.2: 0 plain, 1 normal frame, 2
    /// tangent, ..., 9 phased corrected; without format 22's unbinned flag and format
    /// 26's zero-slot flags), for containers of version 3 on; `None` for other sections
    /// and for a subdivision fit's levels (10.4), which have no mode.
    pub mode: Option<u8>,
    /// Whether a level section is unbinned (SPEC.md 10.1, format 22 on).
    pub unbinned: bool,
    /// Whether a mode 9 level rounds its corrections jointly (SPEC.md 10.9, format 25
    /// on).
    pub joint: bool,
    /// A level section's slots whose values are all 0 and left out of its stream
    /// (SPEC.md 10.1, format 26 on), in increasing order.
    pub zero_slots: Vec<u8>,
}

/// The result of [`encode`].
#[derive(Debug, Clone)]
pub struct Encoded {
    /// The container.
    pub bytes: Vec<u8>,
    /// `order[i]` is the input index of decoded vertex `i` (when the container has no
    /// ORDR section; with one, decoding restores the input order itself).
    pub order: Vec<u32>,
    /// The header written.
    pub header: Header,
    /// Sections written, in order.
    pub sections: Vec<SectionInfo>,
}

/// Section payloads before they are wrapped in a container.
struct Payloads {
    header: Header,
    base: Vec<u8>,
    levels: Vec<Vec<u8>>,
    /// The ORDR section, when the input order is kept: it depends on the coded order,
    /// so candidates are compared with it.
    order: Option<Vec<u8>>,
}

impl Payloads {
    /// Bytes of the BASE and LEVL payloads: what the codings of one hierarchy differ by.
    fn coded(&self) -> usize {
        self.base.len() + self.levels.iter().map(Vec::len).sum::<usize>()
    }

    fn size(&self) -> usize {
        self.coded() + self.order.as_ref().map_or(0, Vec::len)
    }

    /// Each LEVL payload's mode byte, format 22's unbinned flag included (SPEC.md 10.1):
    /// the plan of a coding in the same modes.
    fn modes(&self) -> Vec<u8> {
        self.levels
            .iter()
            .filter_map(|l| l.first().copied())
            .collect()
    }
}

/// The ORDR payload (SPEC.md 7): the coded vertex order (`vertices[coded] = input`),
/// face order and corner rotations.
fn order_section(vertices: &[u32], faces: Vec<u32>, rotations: Vec<u32>) -> Vec<u8> {
    let o = ordr::InputOrder {
        vertices: vertices.to_vec(),
        faces,
        rotations,
    };
    ordr::encode(&o)
}

fn flat_header(mesh: &Mesh, q: &Quantization, opts: &EncodeOptions) -> Header {
    Header {
        vertices: mesh.vertex_count() as u64,
        faces: mesh.face_count() as u64,
        corners: mesh.corner_count() as u64,
        base_vertices: mesh.vertex_count() as u64,
        base_faces: mesh.face_count() as u64,
        base_corners: mesh.corner_count() as u64,
        levels: 0,
        family: Family::None,
        transform: Transform::None,
        quantization: *q,
        source: opts.source,
        has_order: opts.keep_order,
        has_value_map: false,
        poles: Vec::new(),
        disc: DiscTransform::None,
    }
}

/// Codes a canonical hierarchy with wavelet `w` (SPEC.md 9, 10), trying the rotated
/// level modes (10.5) when `rotated`, each level in its mode from `modes` where given
/// (every open mode where not); `None` if a lifted value leaves the supported range or
/// the BASE and LEVL payloads would take more than `bound` bytes.
#[allow(clippy::too_many_arguments)]
fn code_hierarchy(
    canon: &Canonical,
    pos: &[Vec<i64>; 3],
    w: Wavelet,
    disc: DiscTransform,
    header: &Header,
    rotated: bool,
    modes: Option<Vec<u8>>,
    bound: usize,
) -> Option<Payloads> {
    let mut x = pos.clone();
    // The coarse values of each level, as the decoder will have them when it reads the
    // level's details.
    let mut coarse: Vec<[Vec<i64>; 3]> = vec![Default::default(); canon.levels.len()];
    // sqrt(2) levels: their tangent targets (SPEC.md 10.3), from the same coarse values;
    // sqrt2-lazy levels: their predictions' phases (10.6).
    let mut targets: Vec<Option<Vec<[i64; 3]>>> = vec![None; canon.levels.len()];
    let mut phases: Vec<Option<transform::phase::Phases>> = vec![None; canon.levels.len()];
    for (l, level) in canon.levels.iter().enumerate().rev() {
        // As the decoder: sqrt2-lazy keeps the coarse values, so one prediction per
        // face serves the analysis and the tangent targets; the other sqrt(2)
        // transforms take a plan.
        let predictions = (canon.sqrt2 && w == Wavelet::Sqrt2Lazy).then(|| {
            let (p, ph) = sqrt2::predictions_with(level, &x, true);
            phases[l] = ph;
            p
        });
        let plan = (canon.sqrt2 && predictions.is_none()).then(|| sqrt2::Plan::new(level, w));
        if let Some(p) = &predictions {
            let n = topology::sqrt2::fine_nv(level);
            for (xs, pk) in x.iter_mut().zip(p) {
                sqrt2::apply_predictions(&mut xs[..n], level.nv, pk, true);
            }
        } else if let Some(plan) = &plan {
            let n = topology::sqrt2::fine_nv(level);
            for xs in x.iter_mut() {
                plan.analyse(&mut xs[..n]);
            }
        } else {
            // Polar levels: the poles' discs first, then the rest (SPEC.md 9.9).
            let n = level.fine_nv();
            let (discs, owned) = polar::discs(level, &canon.poles, l as u32, disc);
            let st = transform::Stencils::new(level, w);
            // Predict-only transforms: the phases of mode 6 (SPEC.md 10.6), from the fine
            // values (the decoder makes them as it reads the level).
            if canon.poles.is_empty() {
                if let Some(p) = transform::Phaser::new(level, w, &st) {
                    phases[l] = Some(p.phases(&x, level.ne() + level.nf(), true));
                }
            }
            for xs in x.iter_mut() {
                for d in &discs {
                    polar::analyse(d, disc, &mut xs[..n]);
                }
                transform::analyse_with(level, w, &st, &mut xs[..n], &owned);
            }
        }
        coarse[l] = std::array::from_fn(|k| x[k][..level.nv].to_vec());
        targets[l] = match (&predictions, &plan) {
            (Some(p), _) => Some(sqrt2::tangent_targets_from(level, &coarse[l], p)),
            (None, Some(plan)) => Some(sqrt2::tangent_targets(level, plan, &coarse[l])),
            (None, None) => None,
        };
    }
    if x.iter().flatten().any(|v| v.abs() > levl::MAX_LIFTED) {
        return None;
    }
    let (mut header, base_bytes) = hierarchy_base(canon, &x, header);
    let mut models = levl::LevelModels::new();
    models.rotated = rotated;
    models.only = modes.map(Vec::into_iter);
    // Bytes the levels may take: a coding over the bound is not wanted.
    let mut room = bound.checked_sub(base_bytes.len())?;
    let mut level_bytes = Vec::with_capacity(canon.levels.len());
    for (((l, c), t), ph) in canon.levels.iter().zip(&coarse).zip(&targets).zip(&phases) {
        let (s2, t) = (canon.sqrt2, t.as_deref());
        let b = levl::encode(l, s2, &x, c, &mut models, t, ph.as_ref(), room)?;
        room -= b.len();
        level_bytes.push(b);
    }
    header.disc = if canon.poles.is_empty() {
        DiscTransform::None
    } else {
        disc
    };
    header.transform = Transform::Wavelet(w);
    Some(Payloads {
        header,
        base: base_bytes,
        levels: level_bytes,
        order: None,
    })
}

/// The header and BASE payload of a hierarchy's coding: the base mesh with the values
/// `x[k][..base vertices]` (SPEC.md 6), the header with the hierarchy's counts, family
/// and poles (the transform is the caller's).
fn hierarchy_base(canon: &Canonical, x: &[Vec<i64>; 3], header: &Header) -> (Header, Vec<u8>) {
    let nb = canon.base.nv;
    let mut base = Mesh::new();
    base.positions = (0..nb).map(|i| [x[0][i], x[1][i], x[2][i]]).collect();
    base.faces = canon.base.idx.clone();
    base.face_starts = canon.base.starts.clone();
    let mut header = header.clone();
    header.base_vertices = nb as u64;
    header.base_faces = canon.base.nf() as u64;
    header.base_corners = canon.base.idx.len() as u64;
    header.levels = canon.levels.len() as u8;
    header.family = if canon.sqrt2 {
        Family::Sqrt2
    } else if !canon.poles.is_empty() {
        Family::Polar
    } else {
        Family::Cc
    };
    header.poles = canon.poles.clone();
    (header, base::encode(&base))
}

/// Mean [`fit::defect`] over the axes of the finest level above which `auto` does not
/// try the fit: rounded subdivision gives about 70 / 12 (the variance of the rounding
/// noise it sums), fitted detail far more.
const FIT_SCREEN: f64 = 12.0;

/// The least-squares fit stops when no control value moves by more than this (units of
/// the grid): far below the 2^-10 of the finest precision tried.
const FIT_TOLERANCE: f64 = 1e-5;

/// No bound on a hierarchy coding's size ([`code_hierarchy`]).
const UNBOUNDED: usize = usize::MAX;

/// `auto` codes the best-ranked other transform of a family in every mode when its
/// ranking size is below this many hundredths of the first transform's size.
const RANK_MARGIN: usize = 103;

/// Extra bits `auto` tries for the fit's control values.
const FIT_BITS: [u8; 3] = [6, 8, 10];

/// Codes a Catmull-Clark hierarchy as a subdivision fit (SPEC.md 9.10): the control
/// values from least squares, then for each precision in `bits` the integer subdivision
/// and the residuals; the smallest coding (B = 0 when no precision in `bits` keeps the
/// values in range). `None` when `screen` is set and the finest level is far from any
/// subdivision.
fn code_fit(
    canon: &Canonical,
    pos: &[Vec<i64>; 3],
    header: &Header,
    bits: &[u8],
    screen: bool,
) -> Option<Payloads> {
    let last = canon.levels.last()?;
    if !canon.poles.is_empty() {
        return None;
    }
    if screen {
        let d: f64 = pos
            .iter()
            .map(|x| fit::defect(last, x).unwrap_or(f64::MAX))
            .sum();
        if d / 3.0 > FIT_SCREEN {
            return None;
        }
    }
    let nb = canon.base.nv;
    let op = fit::Operator::new(&canon.levels);
    let fine: Vec<[f64; 3]> = (0..pos[0].len())
        .map(|i| std::array::from_fn(|k| pos[k][i] as f64))
        .collect();
    let control = op.fit(&fine, &fine[..nb], 400, FIT_TOLERANCE);
    let mut best: Option<Payloads> = None;
    // B = 0 last, for values too large for any precision asked for.
    for b in bits.iter().copied().chain([0]) {
        if b == 0 && best.is_some() {
            break;
        }
        let s = (1u64 << b) as f64;
        let mut x: [Vec<i64>; 3] =
            std::array::from_fn(|k| control.iter().map(|v| (v[k] * s).round() as i64).collect());
        if x.iter().flatten().any(|v| v.abs() > levl::MAX_LIFTED) {
            continue;
        }
        let (mut h, base_bytes) = hierarchy_base(canon, &x, header);
        for l in &canon.levels {
            for xs in x.iter_mut() {
                fit::subdivide(l, xs);
            }
        }
        let mut level_bytes = vec![Vec::new(); canon.levels.len() - 1];
        level_bytes.push(levl::fit::encode_residuals(&x, pos, b));
        h.transform = Transform::Fit { bits: b };
        let p = Payloads {
            header: h,
            base: base_bytes,
            levels: level_bytes,
            order: None,
        };
        if best.as_ref().is_none_or(|q| p.size() < q.size()) {
            best = Some(p);
        }
    }
    best
}

/// Matches canonical faces to the input's: position and first corner (SPEC.md 7).
fn face_order(mesh: &Mesh, fine: &Topo, vorder: &[u32]) -> Result<(Vec<u32>, Vec<u32>)> {
    let mut by_edge: HashMap<(u32, u32), (u32, u32)> = HashMap::with_capacity(mesh.corner_count());
    for (j, face) in mesh.iter_faces().enumerate() {
        let k = face.len();
        for r in 0..k {
            by_edge.insert((face[r], face[(r + 1) % k]), (j as u32, r as u32));
        }
    }
    let mut perm = Vec::with_capacity(fine.nf());
    let mut rot = Vec::with_capacity(fine.nf());
    for c in 0..fine.nf() {
        let f = fine.face(c);
        let key = (vorder[f[0] as usize], vorder[f[1] as usize]);
        let &(j, r) = by_edge
            .get(&key)
            .ok_or_else(|| Error::InvalidMesh("hierarchy does not match the input faces".into()))?;
        perm.push(j);
        rot.push(r);
    }
    Ok((perm, rot))
}

/// The mesh's positions in a hierarchy's canonical order, per axis.
fn canonical_positions(mesh: &Mesh, canon: &Canonical) -> [Vec<i64>; 3] {
    std::array::from_fn(|k| {
        canon
            .order
            .iter()
            .map(|&o| mesh.positions[o as usize][k])
            .collect()
    })
}

/// Encodes an integer mesh whose values map to the file's through `q`: as a
/// Catmull-Clark, sqrt(2) or polar hierarchy when one is found, else flat; with the
/// value map of `opts.value_map` (SPEC.md 3.1) when it makes the container smaller.
pub fn encode(mesh: &Mesh, q: &Quantization, opts: &EncodeOptions) -> Result<Encoded> {
    mesh.validate()?;
    let map = match opts.value_map {
        Some(false) => None,
        Some(true) => ValueMap::every_axis(&mesh.positions),
        None => ValueMap::candidate(&mesh.positions),
    };
    let Some(map) = map else {
        return encode_with(mesh, q, opts, None);
    };
    let ranked = Mesh {
        positions: map.ranks(&mesh.positions),
        face_starts: mesh.face_starts.clone(),
        faces: mesh.faces.clone(),
    };
    let mapped = encode_with(&ranked, q, opts, Some(&map))?;
    if opts.value_map == Some(true) {
        return Ok(mapped);
    }
    let plain = encode_with(mesh, q, opts, None)?;
    Ok(if mapped.bytes.len() < plain.bytes.len() {
        mapped
    } else {
        plain
    })
}

/// The best coding of one family's candidate hierarchies (SPEC.md 8: Catmull-Clark and
/// polar, or sqrt(2)) and the hierarchy it codes: every candidate with the family's
/// first transform, then, with `auto`, the family's `others` ranked on the best
/// candidate, the ranking's winner coded in every mode, and a coding without the
/// rotated modes. `threads` (at least 1) may code the ranking's transforms at once; the
/// result is the same for every count.
#[allow(clippy::too_many_arguments)]
fn code_family(
    mesh: &Mesh,
    opts: &EncodeOptions,
    flat_h: &Header,
    canons: Vec<Canonical>,
    auto_first: Wavelet,
    others: &[Wavelet],
    threads: usize,
) -> Result<Option<(Payloads, Canonical)>> {
    let first = match opts.transform {
        TransformChoice::Auto | TransformChoice::Fit => auto_first,
        TransformChoice::Fixed(w) => w,
    };
    let mut fam_best: Option<(Payloads, Canonical, [Vec<i64>; 3])> = None;
    for canon in canons {
        let pos = canonical_positions(mesh, &canon);
        // code_hierarchy drops the disc transform of a hierarchy without poles.
        let disc = opts.disc.unwrap_or(DiscTransform::None);
        let order = if opts.keep_order {
            let (faces, rotations) = face_order(mesh, &canon.fine, &canon.order)?;
            Some(order_section(&canon.order, faces, rotations))
        } else {
            None
        };
        // Wanted only if smaller than the best candidate so far.
        let bound = fam_best.as_ref().map_or(UNBOUNDED, |b| {
            let order_len = order.as_ref().map_or(0, Vec::len);
            b.0.size().saturating_sub(order_len + 1)
        });
        if let Some(mut p) = code_hierarchy(&canon, &pos, first, disc, flat_h, true, None, bound) {
            p.order = order;
            if fam_best.as_ref().is_none_or(|b| p.size() < b.0.size()) {
                fam_best = Some((p, canon, pos));
            }
        }
    }
    let Some((mut p, canon, pos)) = fam_best else {
        return Ok(None);
    };
    // Codings of one hierarchy share their ORDR section (the order depends on the
    // hierarchy only), so they compare by `coded()`, and a coding stops as soon
    // as it cannot be wanted (`code_hierarchy`'s bound).
    //
    // Codes the chosen hierarchy with (w, d) and keeps it if smaller.
    let try_code = |p: &mut Payloads, w: Wavelet, d: DiscTransform, rotated: bool| {
        let bound = p.coded().saturating_sub(1);
        if let Some(mut q) = code_hierarchy(&canon, &pos, w, d, flat_h, rotated, None, bound) {
            q.order = p.order.clone();
            if q.coded() < p.coded() {
                *p = q;
            }
        }
    };
    // Other (transform, disc) pairs are ranked coding each level in the mode p
    // chose for it (a fraction of the work of trying every mode); the best of
    // them is then coded in every mode. Whichever coding is smallest is kept.
    let rank_then_code = |p: &mut Payloads, pairs: &[(Wavelet, DiscTransform)]| {
        let modes = p.modes();
        let mut ranked: Option<(usize, Wavelet, DiscTransform)> = None;
        // The largest ranking size that leads to coding in every mode.
        let margin = (p.coded() * RANK_MARGIN).div_ceil(100).saturating_sub(1);
        // On several threads every ranking coding runs at once, with the widest bound
        // the loop below can give (before anything is ranked); the loop then takes
        // each coding only where it fits its own bound, as coded alone it would have
        // (a coding within a bound is the same coding under any wider one).
        let code = |&(w, d): &(Wavelet, DiscTransform), bound: usize| {
            code_hierarchy(&canon, &pos, w, d, flat_h, true, Some(modes.clone()), bound)
        };
        let widest = p.coded().saturating_sub(1).max(margin);
        let mut ahead = if threads > 1 {
            par_map(pairs, threads, |pair| code(pair, widest))
        } else {
            Vec::new()
        };
        for (i, pair) in pairs.iter().enumerate() {
            let (w, d) = *pair;
            // Wanted if smaller than p, or ranked first within the margin.
            let rank = ranked.map_or(margin, |(s, ..)| s.saturating_sub(1).min(margin));
            let bound = p.coded().saturating_sub(1).max(rank);
            let coded = match ahead.get_mut(i) {
                Some(q) => q.take().filter(|q| q.coded() <= bound),
                None => code(pair, bound),
            };
            if let Some(mut q) = coded {
                if ranked.is_none_or(|(s, ..)| q.coded() < s) {
                    ranked = Some((q.coded(), w, d));
                }
                q.order = p.order.clone();
                if q.coded() < p.coded() {
                    *p = q;
                }
            }
        }
        if let Some((_, w, d)) = ranked.filter(|&(s, ..)| s <= margin) {
            try_code(p, w, d, true);
        }
    };
    let disc = p.header.disc;
    if opts.transform == TransformChoice::Auto {
        let pairs: Vec<_> = others
            .iter()
            .filter(|&&w| w != first)
            .map(|&w| (w, disc))
            .collect();
        rank_then_code(&mut p, &pairs);
    }
    // A polar hierarchy: the other disc transforms, with the best transform.
    if let (false, None, Transform::Wavelet(w)) =
        (canon.poles.is_empty(), opts.disc, p.header.transform)
    {
        let d0 = p.header.disc;
        let pairs: Vec<_> = DiscTransform::ALL
            .into_iter()
            .filter(|&d| d != d0)
            .map(|d| (w, d))
            .collect();
        rank_then_code(&mut p, &pairs);
    }
    // Each level keeps its smallest mode, but a rotated level hands the next one
    // models learnt in another frame: the best coding without the rotated modes
    // can be smaller in all. (Without a rotated level it would be this coding
    // again: the same modes win, the rotated ones coming last on ties.)
    let rotated = p
        .modes()
        .iter()
        .any(|&m| matches!(levl::mode_of(&[m]), Some(4 | 5)));
    if let (true, Transform::Wavelet(w)) = (rotated, p.header.transform) {
        let d = p.header.disc;
        try_code(&mut p, w, d, false);
    }
    Ok(Some((p, canon)))
}

/// `f` of every item, in order, on up to `threads` threads (this one among them), each
/// taking the next item not yet taken.
fn par_map<T: Sync, R: Send>(items: &[T], threads: usize, f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let n = threads.min(items.len());
    if n <= 1 {
        return items.iter().map(f).collect();
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let work = || {
        let mut done = Vec::new();
        loop {
            let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let Some(item) = items.get(i) else {
                return done;
            };
            done.push((i, f(item)));
        }
    };
    let mut out: Vec<Option<R>> = (0..items.len()).map(|_| None).collect();
    std::thread::scope(|s| {
        let others: Vec<_> = (1..n).map(|_| s.spawn(work)).collect();
        let mine = work();
        for (i, r) in others
            .into_iter()
            .flat_map(|h| h.join().expect("a coding thread panicked"))
            .chain(mine)
        {
            out[i] = Some(r);
        }
    });
    out.into_iter()
        .map(|r| r.expect("every item was taken"))
        .collect()
}

/// [`encode`] with a given value map (`mesh` holding the ranks on its mapped axes).
fn encode_with(
    mesh: &Mesh,
    q: &Quantization,
    opts: &EncodeOptions,
    vmap: Option<&ValueMap>,
) -> Result<Encoded> {
    let mut flat_h = flat_header(mesh, q, opts);
    flat_h.has_value_map = vmap.is_some();
    let mut topo = Topo::new(mesh.vertex_count());
    topo.idx = mesh.faces.clone();
    topo.starts = mesh.face_starts.clone();
    // The best hierarchy coding, and the canonical hierarchy it was made from.
    let mut best: Option<Payloads> = None;
    let mut chosen: Option<Canonical> = None;
    if opts.max_levels > 0 {
        let (want_cc, want_sqrt2) = match opts.transform {
            TransformChoice::Auto => (true, true),
            TransformChoice::Fixed(w) => (!w.is_sqrt2(), w.is_sqrt2()),
            TransformChoice::Fit => (true, false),
        };
        let fit_only = opts.transform == TransformChoice::Fit;
        let max = opts.max_levels as usize;
        // The base mesh's faces in the order of the connectivity coder's gates, unless
        // the input's order is kept: then as recovered, which makes the order cheap.
        let gates = !opts.keep_order;
        // Per family: its candidate hierarchies, the transform that compares them, and
        // the family's other transforms (tried on the better candidate with `auto`).
        let mut families: Vec<(Vec<Canonical>, Wavelet, &[Wavelet])> = Vec::new();
        if want_cc {
            let mut canons = Vec::new();
            for rec in topology::cc::recover_all(mesh.vertex_count(), &topo, max) {
                canons.push(topology::canonicalise(&rec, gates)?);
            }
            // Polar levels take the Catmull-Clark transforms (SPEC.md 8.6).
            canons.extend(topology::polar::recover_all(
                mesh.vertex_count(),
                &topo,
                max,
                gates,
            ));
            // The subdivision fit, on each candidate whose finest level is near a
            // subdivision (every candidate when asked for by name).
            let try_fit = matches!(opts.transform, TransformChoice::Auto | TransformChoice::Fit);
            for canon in canons.iter().filter(|_| try_fit) {
                let pos = canonical_positions(mesh, canon);
                if let Some(mut p) = code_fit(canon, &pos, &flat_h, &FIT_BITS, !fit_only) {
                    if opts.keep_order {
                        let (faces, rotations) = face_order(mesh, &canon.fine, &canon.order)?;
                        p.order = Some(order_section(&canon.order, faces, rotations));
                    }
                    if best.as_ref().is_none_or(|b| p.size() < b.size()) {
                        best = Some(p);
                        chosen = Some(canon.clone());
                    }
                }
            }
            // A mesh and its dual can both be the base: compare them with one transform.
            if !fit_only {
                families.push((canons, Wavelet::Bicubic, &Wavelet::ALL));
            }
        }
        if want_sqrt2 {
            let canons: Vec<Canonical> = topology::sqrt2::recover(&topo, max)
                .and_then(|rec| topology::sqrt2::canonicalise(&rec, &topo, gates).ok())
                .into_iter()
                .collect();
            families.push((canons, Wavelet::Sqrt2Lazy, &Wavelet::SQRT2));
        }
        // The families code apart; on several threads at once, each with its share.
        families.retain(|(canons, ..)| !canons.is_empty());
        let threads = opts.threads.max(1);
        let share = (threads / families.len().max(1)).max(1);
        // Each family is taken once, by the thread that codes it (on one thread, in
        // order).
        let jobs: Vec<_> = families
            .into_iter()
            .map(|f| std::sync::Mutex::new(Some(f)))
            .collect();
        let coded = par_map(&jobs, threads, |job| {
            let taken = job.lock().map(|mut j| j.take()).ok().flatten();
            let (canons, first, others) = taken.expect("each family is coded once");
            code_family(mesh, opts, &flat_h, canons, first, others, share)
        });
        for family in coded {
            let Some((p, canon)) = family? else {
                continue;
            };
            if best.as_ref().is_none_or(|b| p.size() < b.size()) {
                best = Some(p);
                chosen = Some(canon);
            }
        }
    }
    let (payloads, order) = match (best, chosen) {
        (Some(p), Some(canon)) => (p, canon.order),
        _ => {
            // Faces as the connectivity coder's gates visit them (rotated to start at
            // their gate); when the order is kept, also in the input's order and
            // breadth-first, whichever codes smaller with the ORDR section. Vertices in
            // order of first use (SPEC.md 6.1).
            let mut best_flat: Option<(Payloads, Vec<u32>)> = None;
            let nf = mesh.face_count();
            let mut candidates = vec![topology::gates::gate_order(&mesh.face_starts, &mesh.faces)];
            if opts.keep_order {
                candidates.push(((0..nf as u32).collect(), vec![0; nf]));
                candidates.push((base::face_order(mesh), vec![0; nf]));
            }
            for (forder, rot) in candidates {
                let by_faces = base::permute_faces_rotated(mesh, &forder, &rot);
                let order = base::canonical_order(&by_faces);
                let p = Payloads {
                    header: flat_h.clone(),
                    base: base::encode(&base::permute(&by_faces, &order)),
                    levels: Vec::new(),
                    order: opts.keep_order.then(|| order_section(&order, forder, rot)),
                };
                if best_flat.as_ref().is_none_or(|b| p.size() < b.0.size()) {
                    best_flat = Some((p, order));
                }
            }
            best_flat.expect("at least one candidate")
        }
    };
    let header = payloads.header.clone();
    let transform = header.transform;
    let mut w = ContainerWriter::new();
    let mut sections = Vec::new();
    let mut put = |w: &mut ContainerWriter, kind: SectionKind, payload: &[u8]| {
        if payload.len() >= u32::MAX as usize {
            return Err(Error::Range(format!(
                "section {kind} would be {} bytes, over the format's 4 GiB",
                payload.len()
            )));
        }
        w.section(kind, payload);
        let bytes = payload.len() + subwave_container::section_overhead(payload.len());
        sections.push(section_info(kind, bytes, transform, payload));
        Ok(())
    };
    put(&mut w, SectionKind::HEADER, &header.write())?;
    if let Some(m) = vmap {
        put(&mut w, SectionKind::VALUE_MAP, &m.encode())?;
    }
    put(&mut w, SectionKind::BASE, &payloads.base)?;
    for l in &payloads.levels {
        put(&mut w, SectionKind::LEVEL, l)?;
    }
    if let Some(o) = &payloads.order {
        put(&mut w, SectionKind::ORDER, o)?;
    }
    let bytes = w.finish();
    let end = subwave_container::section_overhead(0);
    sections.push(section_info(SectionKind::END, end, transform, &[]));
    Ok(Encoded {
        bytes,
        order,
        header,
        sections,
    })
}

/// How to decode.
#[derive(Debug, Clone, Default)]
pub struct DecodeOptions {
    /// Bounds on what the container may ask for.
    pub limits: Limits,
    /// Decode only up to this level (0 = the base mesh). The container may then be cut
    /// off anywhere after that level's section.
    pub max_level: Option<u8>,
}

/// The result of [`decode`].
#[derive(Debug, Clone)]
pub struct Decoded {
    /// The mesh, in the input's vertex and face order when the container has an ORDR
    /// section and the finest level was decoded, in canonical order otherwise.
    pub mesh: Mesh,
    /// How integers map to values.
    pub quantization: Quantization,
    /// The container's header.
    pub header: Header,
    /// The level decoded (0 = base mesh).
    pub level: u8,
    /// Whether the vertices are in the input's order.
    pub input_order: bool,
}

/// A parsed header and section table, without decoding any geometry.
#[derive(Debug, Clone)]
pub struct Info {
    /// Format version of the container.
    pub version: u16,
    /// The header.
    pub header: Header,
    /// Sections, in order.
    pub sections: Vec<SectionInfo>,
    /// Total bytes.
    pub bytes: usize,
}

fn expect_kind(c: &Container<'_>, i: usize, kind: SectionKind, what: &str) -> Result<()> {
    match c.sections.get(i) {
        Some(s) if s.kind == kind => Ok(()),
        Some(s) => Err(subwave_container::Error::malformed(
            s.offset,
            format!("expected the {what} section ({kind}), found {}", s.kind),
        )
        .into()),
        None => Err(subwave_container::Error::Truncated {
            what: format!("the {what} section ({kind}) is missing"),
        }
        .into()),
    }
}

/// A section's entry in the section table: a level section's mode, unbinned flag, mode
/// 9's joint flag and zero slots read from its payload (SPEC.md 10.1, 10.9); none of them
/// under `transform` 9, whose level sections have no mode byte (10.4).
fn section_info(
    kind: SectionKind,
    bytes: usize,
    transform: Transform,
    payload: &[u8],
) -> SectionInfo {
    let fit = matches!(transform, Transform::Fit { .. });
    let level = kind == SectionKind::LEVEL && !fit;
    SectionInfo {
        kind: kind.to_string(),
        bytes,
        mode: level.then(|| levl::mode_of(payload)).flatten(),
        unbinned: level && levl::unbinned(payload),
        joint: level && levl::joint(payload),
        zero_slots: match level {
            true => {
                let z = levl::zero_slots(payload);
                (0..3).filter(|s| z >> s & 1 == 1).collect()
            }
            false => Vec::new(),
        },
    }
}

/// Reads the header and section table (SPEC.md 2, 5), checking every checksum.
pub fn inspect(bytes: &[u8], limits: &Limits) -> Result<Info> {
    let c = Container::parse(bytes, limits)?;
    let header = layout(&c, limits, true)?;
    let t = header.transform;
    Ok(Info {
        version: c.version,
        header,
        sections: c
            .sections
            .iter()
            .map(|s| section_info(s.kind, s.total_len(), t, s.payload))
            .collect(),
        bytes: bytes.len(),
    })
}

/// Checks the section sequence (SPEC.md 2.4) and returns the header. With `whole`, the
/// container must hold every section; otherwise a prefix is fine.
fn layout(c: &Container<'_>, limits: &Limits, whole: bool) -> Result<Header> {
    expect_kind(c, 0, SectionKind::HEADER, "header")?;
    let h = Header::read(c.sections[0].payload, c.sections[0].offset + 8, limits)?;
    let mut expected = Vec::new();
    if h.has_value_map {
        expected.push((SectionKind::VALUE_MAP, "value map"));
    }
    expected.push((SectionKind::BASE, "base mesh"));
    expected.extend((0..h.levels).map(|_| (SectionKind::LEVEL, "level")));
    if h.has_order {
        expected.push((SectionKind::ORDER, "vertex order"));
    }
    expected.push((SectionKind::END, "end marker"));
    for (i, &(kind, what)) in expected.iter().enumerate() {
        if !whole && i + 1 >= c.sections.len() {
            break;
        }
        expect_kind(c, i + 1, kind, what)?;
    }
    if c.sections.len() > expected.len() + 1 {
        let s = &c.sections[expected.len() + 1];
        return Err(
            subwave_container::Error::malformed(s.offset, "section after the end marker").into(),
        );
    }
    Ok(h)
}

/// Decodes a container (SPEC.md 2-10).
pub fn decode(bytes: &[u8], opts: &DecodeOptions) -> Result<Decoded> {
    let limits = &opts.limits;
    let c = if opts.max_level.is_some() {
        Container::parse_prefix(bytes, limits)?
    } else {
        Container::parse(bytes, limits)?
    };
    let h = layout(&c, limits, opts.max_level.is_none())?;
    // Decompression-bomb guard (SPEC.md 2.5): what the header asks for, per byte given.
    let allowance = (bytes.len() as u64)
        .max(64)
        .saturating_mul(limits.max_expansion);
    if h.memory_estimate() > allowance {
        return Err(subwave_container::Error::Limit {
            what: "decoder memory for a container this size (bytes; see Limits::max_expansion)",
            requested: h.memory_estimate(),
            limit: allowance,
        }
        .into());
    }
    // The value map (SPEC.md 3.1); the other sections then sit where they do without one.
    let mut c = c;
    let vmap = if h.has_value_map {
        if c.sections.len() < 2 {
            return Err(subwave_container::Error::Truncated {
                what: "the value map section (VMAP) is missing".into(),
            }
            .into());
        }
        let s = c.sections.remove(1);
        Some(ValueMap::decode(s.payload, h.vertices)?)
    } else {
        None
    };
    let level = opts.max_level.map_or(h.levels, |k| k.min(h.levels));
    // Sections needed: header, base, `level` levels.
    let needed = 2 + level as usize;
    if c.sections.len() < needed {
        return Err(subwave_container::Error::Truncated {
            what: format!(
                "level {level} needs {needed} sections, the file holds {} whole ones",
                c.sections.len()
            ),
        }
        .into());
    }
    let bound = if h.levels == 0 {
        MAX_COORD
    } else {
        levl::MAX_LIFTED
    };
    let base = base::decode(
        c.sections[1].payload,
        h.base_vertices,
        h.base_faces,
        h.base_corners,
        bound,
    )?;
    let mut mesh = match h.transform {
        _ if h.levels == 0 => base,
        Transform::Wavelet(w) => synthesise_levels(&c, &h, base, w, level)?,
        Transform::Fit { bits } => synthesise_fit(&c, &h, base, bits, level)?,
        Transform::None => return Err(Error::Unsupported("levels without a transform".into())),
    };
    if let Some(m) = &vmap {
        m.values(&mut mesh.positions, level == h.levels)?;
    }
    let mut input_order = false;
    if h.has_order && level == h.levels {
        if let Some(s) = c.sections.get(2 + h.levels as usize) {
            let degrees: Vec<u32> = mesh.face_starts.windows(2).map(|w| w[1] - w[0]).collect();
            let o = ordr::decode(s.payload, mesh.vertex_count(), &degrees)?;
            mesh = restore_order(&mesh, &o);
            input_order = true;
        }
    }
    Ok(Decoded {
        mesh,
        quantization: h.quantization,
        header: h,
        level,
        input_order,
    })
}

/// Refuses a refinement larger than the header's finest mesh, before it is built.
fn check_refinement_size(h: &Header, fine_nv: usize, fine_faces: usize) -> Result<()> {
    if fine_nv as u64 > h.vertices || fine_faces as u64 > h.faces {
        return Err(Error::corrupt(
            "HEAD",
            "the base mesh refines to more than the header's counts",
        ));
    }
    Ok(())
}

/// The finest refined topology must have the header's counts.
fn check_finest_counts(h: &Header, topo: &Topo) -> Result<()> {
    if topo.nv as u64 != h.vertices
        || topo.nf() as u64 != h.faces
        || topo.idx.len() as u64 != h.corners
    {
        return Err(Error::corrupt(
            "HEAD",
            "the refined mesh does not have the header's counts",
        ));
    }
    Ok(())
}

/// Rebuilds levels 1..=`upto` from the base mesh (SPEC.md 8-10).
fn synthesise_levels(
    c: &Container<'_>,
    h: &Header,
    base: Mesh,
    w: Wavelet,
    upto: u8,
) -> Result<Mesh> {
    let mut topo = Topo::new(base.vertex_count());
    topo.idx = base.faces;
    topo.starts = base.face_starts;
    let mut x: [Vec<i64>; 3] =
        std::array::from_fn(|k| base.positions.iter().map(|p| p[k]).collect());
    let mut models = levl::LevelModels::new();
    let is_sqrt2 = h.family == Family::Sqrt2;
    // Polar hierarchies: which vertices are poles (the same at every level, SPEC.md 8.6);
    // every face at a pole must be a triangle.
    let mut pole = vec![
        false;
        if h.family == Family::Polar {
            topo.nv
        } else {
            0
        }
    ];
    for &p in &h.poles {
        *pole
            .get_mut(p as usize)
            .ok_or_else(|| Error::corrupt("HEAD", "a pole is not a base vertex"))? = true;
    }
    if !pole.is_empty() {
        for f in 0..topo.nf() {
            let face = topo.face(f);
            if face.len() != 3 && face.iter().any(|&v| pole[v as usize]) {
                return Err(Error::corrupt("BASE", "a face at a pole is not a triangle"));
            }
        }
    }
    // A sqrt(2) or Catmull-Clark level's successor, derived from it (cheaper than from
    // its fine faces).
    let mut next: Option<Level> = None;
    for l in 0..upto as usize {
        let mut level = match next.take() {
            Some(n) => n,
            None => Level::new(&topo)?,
        };
        // Refuse a refinement larger than the header's finest mesh before building it.
        let (fine_nv, fine_faces) = if is_sqrt2 {
            (topology::sqrt2::fine_nv(&level), level.ne())
        } else {
            (level.fine_nv(), level.fine_faces_with(&pole))
        };
        check_refinement_size(h, fine_nv, fine_faces)?;
        if is_sqrt2 && !topology::sqrt2::closed(&level) {
            return Err(Error::corrupt("BASE", "a sqrt(2) level with a boundary"));
        }
        let payload = c.sections[2 + l].payload;
        // sqrt2-lazy: the face points' predictions, from the coarse values, serve the
        // tangent targets and the synthesis; sqrt2-sym takes a plan, ir2w a pass of its
        // own after the details.
        let lazy = is_sqrt2 && w == Wavelet::Sqrt2Lazy;
        // Only sqrt2-sym (SPEC.md 9.8) reads the per-vertex lists.
        if is_sqrt2 && w != Wavelet::Sqrt2Sym {
            level.free_vertex_adjacency();
        }
        // (Made before the details are decoded: while the coarse values alone are in
        // memory, which is smaller than making them after.)
        // Modes 6 and 9 read the predictions' phases (SPEC.md 10.6, 10.9).
        let mode = levl::mode_of(payload);
        let phased = matches!(mode, Some(6 | 9));
        let (predictions, phases) = match lazy {
            true => {
                let (p, ph) = sqrt2::predictions_with(&level, &x, phased);
                (Some(p), ph)
            }
            false => (None, None),
        };
        let plan = (is_sqrt2 && w == Wavelet::Sqrt2Sym).then(|| sqrt2::Plan::new(&level, w));
        // Tangent targets only for a level coded in tangent mode (SPEC.md 10.3).
        let tangent = matches!(mode, Some(2 | 7));
        let targets = (is_sqrt2 && tangent).then(|| match &predictions {
            Some(pr) => sqrt2::tangent_targets_from(&level, &x, pr),
            None => sqrt2::tangent_targets_from(&level, &x, &sqrt2::predictions(&level, &x)),
        });
        // A Catmull-Clark level's stencils, for its phases and its synthesis.
        let st = (!is_sqrt2).then(|| transform::Stencils::new(&level, w));
        let phaser = match &st {
            Some(st) if phased && h.poles.is_empty() => transform::Phaser::new(&level, w, st),
            _ => None,
        };
        let phasing = match (&phases, &phaser) {
            (Some(p), _) => Some(levl::Phasing::Ready(p)),
            (None, Some(p)) => Some(levl::Phasing::Cc(p)),
            (None, None) => None,
        };
        levl::decode(
            payload,
            &level,
            is_sqrt2,
            &mut x,
            &mut models,
            targets.as_deref(),
            phasing,
        )?;
        // A Catmull-Clark level in mode 6 or 9 is synthesised as it is read.
        let synthesised = phaser.is_some();
        drop(phaser);
        if l + 1 == upto as usize {
            // The last level read: its magnitudes serve no later level.
            models = levl::LevelModels::new();
        }
        if is_sqrt2 && w == Wavelet::Ir2w {
            sqrt2::ir2w_synthesise(&level, &mut x);
        } else if is_sqrt2 {
            if let Some(plan) = &plan {
                for xs in x.iter_mut() {
                    plan.synthesise(xs);
                }
            }
            // sqrt2-lazy predicts from the coarse values as decoded.
            for (xs, pk) in x.iter_mut().zip(predictions.iter().flatten()) {
                sqrt2::apply_predictions(xs, level.nv, pk, false);
            }
        } else if !synthesised {
            let (discs, owned) = polar::discs(&level, &h.poles, l as u32, h.disc);
            let st = st.unwrap_or_else(|| transform::Stencils::new(&level, w));
            for xs in x.iter_mut() {
                transform::synthesise_with(&level, w, &st, xs, &owned);
                for d in discs.iter().rev() {
                    polar::synthesise(d, h.disc, xs);
                }
            }
        }
        if x.iter().flatten().any(|v| v.abs() > levl::MAX_LIFTED) {
            return Err(Error::corrupt("LEVL", "reconstructed value out of range"));
        }
        if is_sqrt2 && l + 1 < upto as usize {
            // Only sqrt2-sym reads the per-vertex lists: the others' levels are made
            // without them.
            next = Some(topology::sqrt2::next_level(level, w == Wavelet::Sqrt2Sym)?);
        } else if is_sqrt2 {
            // The finest topology needs only the level's edges: its other arrays go first.
            topo = topology::sqrt2::fine_owned(level);
        } else if pole.is_empty() && l + 1 < upto as usize {
            // A Catmull-Clark level's successor, derived from it (no edge lookups).
            next = Some(level.next());
        } else {
            topo = level.fine_with(&pole);
            if !pole.is_empty() {
                pole.resize(topo.nv, false);
            }
        }
    }
    if upto == h.levels {
        check_finest_counts(h, &topo)?;
    }
    // A coarser level's values carry 1/gain of the geometry per level still above it.
    let gain: i64 = match w {
        Wavelet::Bicubic => 4,
        Wavelet::Biquintic => 16,
        _ => 1,
    };
    let mut scale: i64 = 1;
    for _ in upto..h.levels {
        scale = scale.saturating_mul(gain);
    }
    let mut mesh = Mesh::new();
    mesh.positions = Vec::with_capacity(topo.nv);
    for i in 0..topo.nv {
        let mut p = [0i64; 3];
        for k in 0..3 {
            p[k] = x[k][i]
                .checked_mul(scale)
                .filter(|v| v.abs() <= MAX_COORD)
                .ok_or_else(|| Error::corrupt("LEVL", "reconstructed coordinate out of range"))?;
        }
        mesh.positions.push(p);
    }
    mesh.faces = topo.idx;
    mesh.face_starts = topo.starts;
    Ok(mesh)
}

/// Rebuilds levels 1..=`upto` of a subdivision fit (SPEC.md 9.10, 10.4): the control
/// values refined in integers, rounded to the grid, and at the finest level the
/// residuals added.
fn synthesise_fit(c: &Container<'_>, h: &Header, base: Mesh, bits: u8, upto: u8) -> Result<Mesh> {
    let mut topo = Topo::new(base.vertex_count());
    topo.idx = base.faces;
    topo.starts = base.face_starts;
    let mut x: [Vec<i64>; 3] =
        std::array::from_fn(|k| base.positions.iter().map(|p| p[k]).collect());
    for l in 0..upto as usize {
        let level = Level::new(&topo)?;
        check_refinement_size(h, level.fine_nv(), level.fine_faces_with(&[]))?;
        if l + 1 < h.levels as usize && !c.sections[2 + l].payload.is_empty() {
            return Err(Error::corrupt(
                "LEVL",
                "a fit's level other than the finest holds data",
            ));
        }
        for xs in x.iter_mut() {
            fit::subdivide(&level, xs);
        }
        topo = level.fine();
    }
    if upto == h.levels {
        check_finest_counts(h, &topo)?;
        let payload = c.sections[1 + upto as usize].payload;
        levl::fit::decode_residuals(payload, &mut x, bits, MAX_COORD)?;
    } else {
        // A coarser level: the control mesh's refinement, rounded to the grid.
        let half = (1i64 << bits) >> 1;
        for v in x.iter_mut().flatten() {
            *v = (*v + half) >> bits;
            if v.abs() > MAX_COORD {
                return Err(Error::corrupt(
                    "LEVL",
                    "reconstructed coordinate out of range",
                ));
            }
        }
    }
    let mut mesh = Mesh::new();
    mesh.positions = (0..topo.nv).map(|i| [x[0][i], x[1][i], x[2][i]]).collect();
    mesh.faces = topo.idx;
    mesh.face_starts = topo.starts;
    Ok(mesh)
}

/// Undoes [`base::permute`]: `order[new] = old`.
fn unpermute(mesh: &Mesh, order: &[u32]) -> Mesh {
    let mut positions = vec![[0i64; 3]; order.len()];
    for (new, &old) in order.iter().enumerate() {
        positions[old as usize] = mesh.positions[new];
    }
    Mesh {
        positions,
        face_starts: mesh.face_starts.clone(),
        faces: mesh.faces.iter().map(|&v| order[v as usize]).collect(),
    }
}

/// Puts vertices and faces back in the input's order (SPEC.md 7).
fn restore_order(mesh: &Mesh, o: &ordr::InputOrder) -> Mesh {
    let mut out = unpermute(mesh, &o.vertices);
    let nf = mesh.face_count();
    let mut degree = vec![0u32; nf];
    for c in 0..nf {
        degree[o.faces[c] as usize] = mesh.face_starts[c + 1] - mesh.face_starts[c];
    }
    let mut starts = Vec::with_capacity(nf + 1);
    starts.push(0u32);
    for d in &degree {
        starts.push(starts.last().copied().unwrap_or(0) + d);
    }
    let mut faces = vec![0u32; mesh.faces.len()];
    for c in 0..nf {
        let src = &out.faces[mesh.face_starts[c] as usize..mesh.face_starts[c + 1] as usize];
        let k = src.len();
        let r = o.rotations[c] as usize;
        let dst = starts[o.faces[c] as usize] as usize;
        for i in 0..k {
            faces[dst + i] = src[(i + k - r) % k];
        }
    }
    out.faces = faces;
    out.face_starts = starts;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::fixtures::{prism_with_triangles, pseudo};

    /// `code_hierarchy`'s bound: a coding whose BASE and LEVL payloads fit is the
    /// unbounded one, byte for byte; one byte less and it is refused. With and without
    /// a mode plan, for several transforms.
    #[test]
    fn bounded_codings_are_the_unbounded_ones_or_none() {
        let mut t = prism_with_triangles();
        for _ in 0..3 {
            t = topology::Level::new(&t).unwrap().fine();
        }
        let rec = topology::cc::recover_all(t.nv, &t, 16).remove(0);
        let canon = topology::canonicalise(&rec, true).unwrap();
        let vals: Vec<Vec<i64>> = (0..3).map(|k| pseudo(k + 1, t.nv, 12)).collect();
        let mesh = Mesh {
            positions: (0..t.nv)
                .map(|v| std::array::from_fn(|k| vals[k][v]))
                .collect(),
            face_starts: t.starts.clone(),
            faces: t.idx.clone(),
        };
        let q = Quantization::Decimal { decimals: 0 };
        let header = flat_header(&mesh, &q, &EncodeOptions::default());
        let pos = canonical_positions(&mesh, &canon);
        let d = DiscTransform::None;
        for w in [Wavelet::Bicubic, Wavelet::Interp4, Wavelet::Lazy] {
            let free = code_hierarchy(&canon, &pos, w, d, &header, true, None, UNBOUNDED).unwrap();
            let plan = free.modes();
            for modes in [None, Some(plan)] {
                let whole =
                    code_hierarchy(&canon, &pos, w, d, &header, true, modes.clone(), UNBOUNDED)
                        .unwrap();
                let n = whole.coded();
                let fit = code_hierarchy(&canon, &pos, w, d, &header, true, modes.clone(), n)
                    .unwrap_or_else(|| panic!("fits its own size {w:?} {:?} {n}", modes));
                assert_eq!((fit.base, fit.levels), (whole.base, whole.levels), "{w:?}");
                assert!(
                    code_hierarchy(&canon, &pos, w, d, &header, true, modes, n - 1).is_none(),
                    "{w:?}"
                );
            }
        }
    }
}

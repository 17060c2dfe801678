//! The encoder's search (not part of the format): which family, transform, level modes
//! and fit precision code a mesh smallest, tried on one or more threads.

use super::*;

/// Codes a canonical hierarchy of `mesh` with wavelet `w` (SPEC.md 9, 10), trying the rotated
/// level modes (10.5) as `search` says, each level in its mode from `modes` where given
/// (every open mode where not); `None` if a lifted value leaves the supported range or
/// the BASE and LEVL payloads would take more than `bound` bytes.
#[allow(clippy::too_many_arguments)]
pub(crate) fn code_hierarchy(
    canon: &Canonical,
    mesh: &Mesh,
    w: Wavelet,
    disc: DiscTransform,
    header: &Header,
    search: ModeSearch,
    modes: Option<Vec<u8>>,
    bound: usize,
    progress: &Progress,
) -> Option<Payloads> {
    let coding = Coding {
        canon,
        mesh,
        w,
        disc,
        header,
        search,
        bound,
        progress,
    };
    coding.code(modes, None)
}

/// What [`code_hierarchy`] codes, and how.
struct Coding<'a> {
    canon: &'a Canonical,
    mesh: &'a Mesh,
    w: Wavelet,
    disc: DiscTransform,
    header: &'a Header,
    search: ModeSearch,
    bound: usize,
    progress: &'a Progress,
}

impl Coding<'_> {
    /// [`code_hierarchy`], from the hierarchy's values analysed with the wavelet
    /// beforehand where `given` (a Catmull-Clark or polar hierarchy's, as [`analysed`]
    /// gives them): each level's phases are then found from its fine values, which its
    /// synthesis gives back before it is coded (the finest level's are the mesh's).
    fn code(&self, modes: Option<Vec<u8>>, given: Option<Values>) -> Option<Payloads> {
        let (canon, mesh, w, disc) = (self.canon, self.mesh, self.w, self.disc);
        let (header, search, bound, progress) =
            (self.header, self.search, self.bound, self.progress);
        let sqrt2 = canon.family == Family::Sqrt2;
        let scheme = scheme_of(canon, w, disc);
        // (A sqrt2-lazy coding keeps its levels' predictions from the analysis, but on
        // large meshes: memory.)
        let keep = sqrt2 && mesh.vertex_count() <= LARGE_MESH;
        let (mut x, phases, mut kept) = match given.filter(|_| !sqrt2) {
            Some(x) => (x, None, Vec::new()),
            None => {
                let (x, p, kept) = analyse_all(canon, mesh, &scheme, true, keep)?;
                (x, Some(p), kept)
            }
        };
        let (mut header, base_bytes) = hierarchy_base(canon, &x, header);
        let mut models = levl::LevelModels::new();
        models.rotated = search.rotated;
        models.sampled = search.sampled;
        models.only = modes.map(Vec::into_iter);
        // Bytes the levels may take: a coding over the bound is not wanted.
        let mut room = bound.checked_sub(base_bytes.len())?;
        let mut level_bytes = Vec::with_capacity(canon.levels.len());
        // Level by level, coarse first, as the decoder goes: `x[k][..nv]` holds the
        // level's coarse values as the decoder has them when it reads the level's
        // details, and the level, once coded, is synthesised in place into the next
        // one's (its details are then no longer wanted). No copy of any level's coarse
        // values is kept (the memory of large meshes), but for one level at a time
        // where the values were analysed beforehand: its phases need its fine values
        // before it is coded.
        let last = canon.levels.len().saturating_sub(1);
        for (i, level) in canon.levels.iter().enumerate() {
            progress.report(Stage::Level {
                transform: w.name(),
                level: i + 1,
                levels: canon.levels.len(),
            });
            // The level's transform, made from its coarse values as the decoder makes it:
            // for its synthesis once it is coded (not the finest's), for a sqrt(2)
            // level's tangent targets (SPEC.md 10.3) and, the values analysed beforehand,
            // for the phases of its predictions (10.6).
            let t = (i < last || sqrt2 || phases.is_none()).then(|| {
                kept.get_mut(i)
                    .and_then(Option::take)
                    .unwrap_or_else(|| LevelTransform::new(&scheme, level, i, &x, false))
            });
            let targets = t.as_ref().and_then(|t| t.tangent_targets(level, &x));
            // The level's coarse values and details, where `x` is already synthesised.
            let mut before: Option<Values> = None;
            let found = match (&phases, &t) {
                (Some(_), _) | (None, None) => None,
                (None, Some(t)) => t.phaser(level).map(|p| {
                    let n = level.ne() + level.nf();
                    if i == last {
                        return p.phases(&canonical_positions(mesh, canon), n, true);
                    }
                    let fine = canon.family.fine_nv(level);
                    before = Some(std::array::from_fn(|k| x[k][..fine].to_vec()));
                    t.synthesise(level, &mut x);
                    p.phases(&x, n, true)
                }),
            };
            let ph = match &phases {
                Some(p) => p[i].as_ref(),
                None => found.as_ref(),
            };
            let xs = before.as_ref().unwrap_or(&x);
            let b = levl::encode(
                level,
                canon.family,
                xs,
                xs,
                &mut models,
                targets.as_deref(),
                ph,
                room,
            )?;
            room -= b.len();
            level_bytes.push(b);
            if let Some(t) = t.filter(|_| i < last && before.is_none()) {
                t.synthesise(level, &mut x);
            }
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
}

/// The transform of hierarchy `canon` with wavelet `w` and disc transform `disc`.
fn scheme_of(canon: &Canonical, w: Wavelet, disc: DiscTransform) -> Scheme<'_> {
    // Every coding of the hierarchy shares its stencils but a large one's (memory).
    let large = canon.levels.last().map_or(0, |l| canon.family.fine_nv(l)) > LARGE_MESH;
    Scheme {
        family: canon.family,
        wavelet: w,
        poles: &canon.poles,
        disc,
        stencils: (!large).then_some(&canon.stencils),
    }
}

/// A hierarchy's analysed values (the base values in `x[k][..base vertices]`, then every
/// level's details), each level's phases (modes 6 and 9) and, where kept, its
/// sqrt2-lazy transforms.
type Analysis<'c> = (
    [Vec<i64>; 3],
    Vec<Option<crate::transform::phase::Phases>>,
    Vec<Option<LevelTransform<'c>>>,
);

/// A hierarchy's analysis with `scheme` (SPEC.md 9), fine to coarse, as the decoder
/// undoes it, and the phases of its Catmull-Clark levels where `with_phases` (else
/// none: an estimate does not read them); `None` if a lifted value leaves the
/// supported range. With `keep`, each sqrt2-lazy level's transform too: its
/// predictions are made from the coarse values, which the analysis leaves as the
/// decoder has them, so the coding synthesises and finds its tangent targets with
/// them rather than making them again.
fn analyse_all<'c>(
    canon: &'c Canonical,
    mesh: &Mesh,
    scheme: &Scheme<'_>,
    with_phases: bool,
    keep: bool,
) -> Option<Analysis<'c>> {
    // The positions in canonical order, gathered for each coding rather than held
    // beside the hierarchy (the memory of large meshes).
    let mut x = canonical_positions(mesh, canon);
    // sqrt2-lazy levels: their predictions' phases (10.6).
    let mut phases: Vec<Option<crate::transform::phase::Phases>> = vec![None; canon.levels.len()];
    let mut kept: Vec<Option<LevelTransform<'c>>> = Vec::new();
    if keep {
        kept.resize_with(canon.levels.len(), || None);
    }
    for (l, level) in canon.levels.iter().enumerate().rev() {
        // As the decoder: sqrt2-lazy predicts from the coarse values (which it keeps)
        // and finds its phases with the predictions; ir2w runs its own passes,
        // sqrt2-sym a plan; polar levels code the poles' discs first (SPEC.md 9.9).
        let mut t = LevelTransform::new(scheme, level, l, &x, true);
        // The phases of modes 6 and 9 (SPEC.md 10.6): sqrt2-lazy's from its predictions,
        // a predict-only Catmull-Clark level's from the fine values (the decoder makes
        // them as it reads the level).
        phases[l] = match t.take_phases() {
            Some(p) => Some(p),
            None if with_phases => t
                .phaser(level)
                .map(|p| p.phases(&x, level.ne() + level.nf(), true)),
            None => None,
        };
        t.analyse(level, canon.family.fine_nv(level), &mut x);
        if keep && matches!(t, LevelTransform::Sqrt2Lazy { .. }) {
            kept[l] = Some(t);
        }
    }
    if x.iter().flatten().any(|v| v.abs() > levl::MAX_LIFTED) {
        return None;
    }
    Some((x, phases, kept))
}

/// What ranks a hierarchy's transforms at the default effort without coding them: the
/// bits of its details as a plain integer code would spend them (each nonzero value
/// its bit length and a sign), all of them and the finest level's ([`by_bits`] ranks
/// by those). `None` if a lifted value leaves the supported range.
pub(crate) fn detail_bits(
    canon: &Canonical,
    mesh: &Mesh,
    w: Wavelet,
    disc: DiscTransform,
) -> Option<DetailBits> {
    let x = analysed(canon, mesh, w, disc)?;
    Some(DetailBits {
        all: value_bits(&x, canon.base.nv),
        finest: value_bits(&x, canon.levels.last().map_or(0, |l| l.nv)),
    })
}

/// The details' bits of a transform on a hierarchy ([`detail_bits`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct DetailBits {
    /// Of every level's details.
    pub all: u64,
    /// Of the finest level's details.
    pub finest: u64,
}

/// The values of hierarchy `canon` with its finest level analysed (the coarser levels
/// not yet) by `scheme`, and the bits of that level's details ([`value_bits`]);
/// `None` if a detail leaves the supported range.
fn finest_analysed(canon: &Canonical, mesh: &Mesh, scheme: &Scheme<'_>) -> Option<(Values, u64)> {
    let mut x = canonical_positions(mesh, canon);
    let Some((l, level)) = canon.levels.iter().enumerate().next_back() else {
        return Some((x, 0));
    };
    let t = LevelTransform::new(scheme, level, l, &x, true);
    t.analyse(level, canon.family.fine_nv(level), &mut x);
    if x.iter()
        .any(|xk| xk[level.nv..].iter().any(|v| v.abs() > levl::MAX_LIFTED))
    {
        return None;
    }
    let bits = value_bits(&x, level.nv);
    Some((x, bits))
}

/// [`analysed`] from the values [`finest_analysed`] left: the coarser levels analysed
/// too; `None` if a value leaves the supported range.
fn finish_analysis(canon: &Canonical, scheme: &Scheme<'_>, mut x: Values) -> Option<Values> {
    let last = canon.levels.len().saturating_sub(1);
    for (l, level) in canon.levels.iter().enumerate().take(last).rev() {
        let t = LevelTransform::new(scheme, level, l, &x, true);
        t.analyse(level, canon.family.fine_nv(level), &mut x);
    }
    if x.iter().flatten().any(|v| v.abs() > levl::MAX_LIFTED) {
        return None;
    }
    Some(x)
}

/// Values per axis.
type Values = [Vec<i64>; 3];

/// A hierarchy's values analysed with `w` (its phases not found: [`analyse_all`]);
/// `None` if a lifted value leaves the supported range.
fn analysed(canon: &Canonical, mesh: &Mesh, w: Wavelet, disc: DiscTransform) -> Option<Values> {
    analyse_all(canon, mesh, &scheme_of(canon, w, disc), false, false).map(|(x, ..)| x)
}

/// Meshes above this many vertices are large: for their memory the encoder holds less
/// and makes it again. Smaller ones keep the analysis of the transform their estimate
/// ranks first for its coding ([`by_bits`]; every transform's analysis is held until
/// they are ranked), their hierarchies' stencils for every coding ([`scheme_of`]), and
/// their first candidate hierarchy's levels while another's fit is tried
/// (`best_hierarchy`).
pub(crate) const LARGE_MESH: usize = 500_000;

/// `first` and `others` ranked by the bits their finest level's details take on
/// hierarchy `canon` ([`DetailBits::finest`]; `known` a transform's where already
/// estimated), fewest first (`first` first on ties); those out of range last, in their
/// order; with the first's analysed values where made and kept ([`LARGE_MESH`]).
/// Only the finest level is analysed for the ranking (it holds most details), the
/// coarser ones then for the first alone; should they take it out of range, every
/// transform is analysed whole and ranked by all its details instead. The analyses run
/// on up to `threads` threads.
fn by_bits(
    canon: &Canonical,
    mesh: &Mesh,
    (first, others): (Wavelet, &[Wavelet]),
    disc: DiscTransform,
    known: Option<(Wavelet, DetailBits)>,
    threads: usize,
) -> (Vec<Wavelet>, Option<Values>) {
    let all: Vec<Wavelet> = std::iter::once(first)
        .chain(others.iter().copied())
        .collect();
    if all.len() == 1 {
        return (all, None);
    }
    let keep = mesh.vertex_count() <= LARGE_MESH;
    if !keep {
        return by_all_bits(canon, mesh, &all, disc, known, threads);
    }
    let found = par_map(&all, threads, |&w| match known {
        Some((k, bits)) if k == w => (Some(bits.finest), None),
        _ => match finest_analysed(canon, mesh, &scheme_of(canon, w, disc)) {
            Some((x, bits)) => (Some(bits), Some(x)),
            None => (None, None),
        },
    });
    let mut ranked = rank(&all, found);
    let (bits, w) = (ranked[0].0, ranked[0].1);
    let x = match ranked[0].2.take() {
        Some(x) => finish_analysis(canon, &scheme_of(canon, w, disc), x),
        // The known transform: its coding analyses it.
        None if bits != u64::MAX => return (ranked.into_iter().map(|(_, w, _)| w).collect(), None),
        None => None,
    };
    let Some(x) = x else {
        return by_all_bits(canon, mesh, &all, disc, known, threads);
    };
    (ranked.into_iter().map(|(_, w, _)| w).collect(), Some(x))
}

/// Transforms `all` with what their analyses `found` (bits, where in range, and
/// values, where kept), fewest bits first (a stable sort: equal bits keep their order;
/// those out of range last).
fn rank(
    all: &[Wavelet],
    found: Vec<(Option<u64>, Option<Values>)>,
) -> Vec<(u64, Wavelet, Option<Values>)> {
    let mut ranked: Vec<(u64, Wavelet, Option<Values>)> = all
        .iter()
        .zip(found)
        .map(|(&w, (b, x))| (b.unwrap_or(u64::MAX), w, x))
        .collect();
    ranked.sort_by_key(|&(b, ..)| b);
    ranked
}

/// [`by_bits`] ranking by every level's details, each transform analysed whole.
fn by_all_bits(
    canon: &Canonical,
    mesh: &Mesh,
    all: &[Wavelet],
    disc: DiscTransform,
    known: Option<(Wavelet, DetailBits)>,
    threads: usize,
) -> (Vec<Wavelet>, Option<Values>) {
    let keep = mesh.vertex_count() <= LARGE_MESH;
    let found = par_map(all, threads, |&w| match known {
        Some((k, bits)) if k == w => (Some(bits.all), None),
        _ => {
            let x = analysed(canon, mesh, w, disc);
            (
                x.as_ref().map(|x| value_bits(x, canon.base.nv)),
                x.filter(|_| keep),
            )
        }
    });
    let mut ranked = rank(all, found);
    let x = ranked.first_mut().and_then(|r| r.2.take());
    (ranked.into_iter().map(|(_, w, _)| w).collect(), x)
}

/// Meshes up to this many vertices are small: at the estimated efforts `auto` codes
/// the family's first transform and the two its estimate ranks best, not the best
/// alone (the estimate misses by a few percent, and their codings take little time).
const SMALL_MESH: usize = 32_768;

/// The bits of `x[k][from..]` as a plain integer code spends them: each nonzero value
/// its bit length and a sign.
fn value_bits(x: &[Vec<i64>; 3], from: usize) -> u64 {
    x.iter()
        .flat_map(|xk| &xk[from.min(xk.len())..])
        .filter(|&&v| v != 0)
        .map(|&v| 1 + u64::from(64 - v.unsigned_abs().leading_zeros()))
        .sum()
}

/// The header and BASE payload of a hierarchy's coding: the base mesh with the values
/// `x[k][..base vertices]` (SPEC.md 6), the header with the hierarchy's counts, family
/// and poles (the transform is the caller's).
pub(crate) fn hierarchy_base(
    canon: &Canonical,
    x: &[Vec<i64>; 3],
    header: &Header,
) -> (Header, Vec<u8>) {
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
    header.family = canon.family;
    header.poles = canon.poles.clone();
    (header, base::encode(&base))
}

/// No bound on a hierarchy coding's size ([`code_hierarchy`]).
pub(crate) const UNBOUNDED: usize = usize::MAX;

/// `auto`, ranking by coding, codes the best-ranked other transform of a family in
/// every mode when its ranking size is below this many hundredths of the first
/// transform's size.
pub(crate) const RANK_MARGIN: usize = 103;

/// A hierarchy's coding and the hierarchy.
type Candidate = (Payloads, Canonical);

/// Of a family's candidate hierarchies, the one that codes smallest with transform
/// `first`, and its coding.
fn best_candidate(
    mesh: &Mesh,
    opts: &EncodeOptions,
    flat_h: &Header,
    mut canons: Vec<Canonical>,
    first: Wavelet,
    mut given: Option<Values>,
) -> Result<Option<Candidate>> {
    let effort = Effort::of(opts.effort);
    // Below effort 8, the preferred candidate alone (recovery ranks it first); with
    // the input's order kept, also the one whose order codes smallest, if another
    // (an exporter's own base mesh, whose elements its order follows: SPEC.md 7.3).
    let mut take: Vec<bool> = (0..canons.len())
        .map(|i| i == 0 || effort.candidates)
        .collect();
    let mut orders: Vec<Option<Vec<u8>>> = vec![None; canons.len()];
    if opts.keep_order && !effort.candidates && canons.len() > 1 {
        for (i, canon) in canons.iter_mut().enumerate() {
            canon.unstow()?;
            orders[i] = Some(hierarchy_order(mesh, canon)?);
            if i > 0 {
                canon.stow();
            }
        }
        let smallest = (0..orders.len()).min_by_key(|&i| orders[i].as_ref().map_or(0, Vec::len));
        if let Some(j) = smallest {
            take[j] = true;
        }
    }
    let mut fam_best: Option<Candidate> = None;
    let picked = canons.into_iter().enumerate().filter(|(i, _)| take[*i]);
    for (i, mut canon) in picked {
        // One candidate's levels at a time: the best so far waits stowed.
        if let Some((_, best)) = fam_best.as_mut() {
            best.stow();
        }
        canon.unstow()?;
        // code_hierarchy drops the disc transform of a hierarchy without poles.
        let disc = opts.disc.unwrap_or(DiscTransform::None);
        let order = match (opts.keep_order, orders[i].take()) {
            (true, Some(o)) => Some(o),
            (true, None) => Some(hierarchy_order(mesh, &canon)?),
            (false, _) => None,
        };
        // Wanted only if smaller than the best candidate so far.
        let bound = fam_best.as_ref().map_or(UNBOUNDED, |b| {
            let order_len = order.as_ref().map_or(0, Vec::len);
            b.0.size().saturating_sub(order_len + 1)
        });
        let coding = Coding {
            canon: &canon,
            mesh,
            w: first,
            disc,
            header: flat_h,
            search: effort.modes(),
            bound,
            progress: &opts.progress,
        };
        // The first candidate's values may be analysed already.
        let given = given.take().filter(|_| i == 0);
        if let Some(mut p) = coding.code(None, given) {
            p.order = order;
            if fam_best.as_ref().is_none_or(|b| p.size() < b.0.size()) {
                fam_best = Some((p, canon));
            }
        }
    }
    if let Some((_, best)) = fam_best.as_mut() {
        best.unstow()?;
    }
    Ok(fam_best)
}

/// The best coding of one family's candidate hierarchies (SPEC.md 8: Catmull-Clark and
/// polar, or sqrt(2)) and the hierarchy it codes: every candidate with the family's
/// first transform, then, with `auto`, the family's `others` ranked on the best
/// candidate, the ranking's winner coded in every mode, and a coding without the
/// rotated modes. `known` is a transform's details' bits on the first candidate where
/// already estimated. `threads` (at least 1) may code the ranking's transforms at once;
/// the result is the same for every count.
#[allow(clippy::too_many_arguments)]
pub(crate) fn code_family(
    mesh: &Mesh,
    opts: &EncodeOptions,
    flat_h: &Header,
    canons: Vec<Canonical>,
    auto_first: Wavelet,
    others: &[Wavelet],
    known: Option<(Wavelet, DetailBits)>,
    threads: usize,
) -> Result<Option<(Payloads, Canonical)>> {
    let first = match opts.transform {
        TransformChoice::Auto | TransformChoice::Fit => auto_first,
        TransformChoice::Fixed(w) => w,
    };
    let effort = Effort::of(opts.effort);
    let auto = opts.transform == TransformChoice::Auto;
    // The listed transforms besides the first (all of them without a list).
    let listed: Vec<Wavelet> = others
        .iter()
        .copied()
        .filter(|&w| w != first && effort.rank.is_none_or(|r| r.contains(&w)))
        .collect();
    // At the estimated efforts the transform with the fewest details' bits on the
    // preferred candidate is the one coded (the first on ties), on a small mesh also
    // the runner-up and the first; at the others, the others are ranked by coding them.
    // (And the analysis of the one coded, where made.)
    let mut given = None;
    let (first, also) = match (auto && effort.estimated, canons.first()) {
        (true, Some(canon)) => {
            let disc = opts.disc.unwrap_or(DiscTransform::None);
            let (ranked, x) = by_bits(canon, mesh, (first, &listed), disc, known, threads);
            given = x;
            let mut also = Vec::new();
            if mesh.vertex_count() <= SMALL_MESH {
                also.extend(ranked.get(1).copied());
                also.push(first);
                also.retain(|&w| w != ranked[0]);
                also.dedup();
            }
            (ranked[0], also)
        }
        _ => (first, Vec::new()),
    };
    let fam_best = best_candidate(mesh, opts, flat_h, canons, first, given)?;
    let Some((mut p, canon)) = fam_best else {
        return Ok(None);
    };
    let coder = Recoder {
        canon: &canon,
        mesh,
        opts,
        flat_h,
        threads,
    };
    let disc = p.header.disc;
    for w in also {
        coder.try_code(&mut p, w, disc, effort.modes());
    }
    if auto && !effort.estimated {
        let pairs: Vec<_> = listed.iter().map(|&w| (w, disc)).collect();
        if !pairs.is_empty() {
            coder.rank_then_code(&mut p, &pairs, effort.modes());
        }
    }
    // A polar hierarchy: the other disc transforms, with the best transform.
    if let (false, None, Transform::Wavelet(w), true) = (
        canon.poles.is_empty(),
        opts.disc,
        p.header.transform,
        effort.discs,
    ) {
        let d0 = p.header.disc;
        let pairs: Vec<_> = DiscTransform::ALL
            .into_iter()
            .filter(|&d| d != d0)
            .map(|d| (w, d))
            .collect();
        coder.rank_then_code(&mut p, &pairs, effort.modes());
    }
    // Each level keeps its smallest mode, but a rotated level hands the next one
    // models learnt in another frame: the best coding without the rotated modes
    // can be smaller in all. (Without a rotated level it would be this coding
    // again: the same modes win, the rotated ones coming last on ties.)
    let rotated = p.modes().iter().any(|&m| levl::rotated(&[m]));
    if let (true, Transform::Wavelet(w), true) = (rotated, p.header.transform, effort.unrotated) {
        let d = p.header.disc;
        let search = ModeSearch {
            rotated: false,
            ..effort.modes()
        };
        coder.try_code(&mut p, w, d, search);
    }
    Ok(Some((p, canon)))
}

/// Codes one chosen hierarchy again with other transforms, keeping the smallest coding.
///
/// Codings of one hierarchy share their ORDR section (the order depends on the
/// hierarchy only), so they compare by `coded()`, and a coding stops as soon as it
/// cannot be wanted (`code_hierarchy`'s bound).
struct Recoder<'a> {
    canon: &'a Canonical,
    mesh: &'a Mesh,
    opts: &'a EncodeOptions,
    flat_h: &'a Header,
    threads: usize,
}

impl Recoder<'_> {
    /// The hierarchy coded with (w, d), each level in one of `modes` (every mode if
    /// `None`), if it fits within `bound`.
    fn code(
        &self,
        (w, d): (Wavelet, DiscTransform),
        search: ModeSearch,
        modes: Option<Vec<u8>>,
        bound: usize,
    ) -> Option<Payloads> {
        code_hierarchy(
            self.canon,
            self.mesh,
            w,
            d,
            self.flat_h,
            search,
            modes,
            bound,
            &self.opts.progress,
        )
    }

    /// Codes the hierarchy with (w, d) in every mode and keeps it in `p` if smaller.
    fn try_code(&self, p: &mut Payloads, w: Wavelet, d: DiscTransform, search: ModeSearch) {
        let bound = p.coded().saturating_sub(1);
        if let Some(mut q) = self.code((w, d), search, None, bound) {
            q.order = p.order.clone();
            if q.coded() < p.coded() {
                *p = q;
            }
        }
    }

    /// Other (transform, disc) pairs are ranked coding each level in the mode p chose
    /// for it (a fraction of the work of trying every mode); the best of them is then
    /// coded in every mode. Whichever coding is smallest is kept.
    fn rank_then_code(
        &self,
        p: &mut Payloads,
        pairs: &[(Wavelet, DiscTransform)],
        search: ModeSearch,
    ) {
        let modes = p.modes();
        let mut ranked: Option<(usize, Wavelet, DiscTransform)> = None;
        // The largest ranking size that leads to coding in every mode.
        let margin = (p.coded() * RANK_MARGIN).div_ceil(100).saturating_sub(1);
        // On several threads every ranking coding runs at once, with the widest bound
        // the loop below can give (before anything is ranked); the loop then takes
        // each coding only where it fits its own bound, as coded alone it would have
        // (a coding within a bound is the same coding under any wider one).
        let code = |&pair: &(Wavelet, DiscTransform), bound: usize| {
            self.code(pair, search, Some(modes.clone()), bound)
        };
        let widest = p.coded().saturating_sub(1).max(margin);
        let mut ahead = if self.threads > 1 {
            par_map(pairs, self.threads, |pair| code(pair, widest))
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
            self.try_code(p, w, d, search);
        }
    }
}

/// `f` of every item, in order, on up to `threads` threads (this one among them), each
/// taking the next item not yet taken.
pub(crate) fn par_map<T: Sync, R: Send>(
    items: &[T],
    threads: usize,
    f: impl Fn(&T) -> R + Sync,
) -> Vec<R> {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The finest level analysed alone and then the rest is the whole analysis, for
    /// every Catmull-Clark transform; its bits are the finest level's of
    /// [`detail_bits`]; and the ranking puts the fewest finest bits first, with its
    /// values analysed whole.
    #[test]
    fn the_finest_level_first_then_the_rest_is_the_whole_analysis() {
        let (canon, mesh, _) = super::super::tests::refined_prism();
        assert!(canon.levels.len() >= 2);
        let d = DiscTransform::None;
        let mut fewest: Option<(u64, Wavelet)> = None;
        for w in Wavelet::ALL.into_iter().filter(|w| !w.is_sqrt2()) {
            let scheme = scheme_of(&canon, w, d);
            let (x, bits) = finest_analysed(&canon, &mesh, &scheme).unwrap();
            let bits_whole = detail_bits(&canon, &mesh, w, d).unwrap();
            assert_eq!(bits, bits_whole.finest, "{w:?}");
            assert!(bits_whole.all > bits_whole.finest, "{w:?}");
            let whole = analysed(&canon, &mesh, w, d).unwrap();
            assert_eq!(finish_analysis(&canon, &scheme, x).unwrap(), whole, "{w:?}");
            if fewest.is_none_or(|(b, _)| bits < b) {
                fewest = Some((bits, w));
            }
        }
        let others: Vec<Wavelet> = Wavelet::ALL
            .into_iter()
            .filter(|w| !w.is_sqrt2() && *w != Wavelet::Bicubic)
            .collect();
        let (order, x) = by_bits(&canon, &mesh, (Wavelet::Bicubic, &others), d, None, 1);
        let (_, best) = fewest.unwrap();
        assert_eq!(order[0], best);
        assert_eq!(x.unwrap(), analysed(&canon, &mesh, order[0], d).unwrap());
        // The whole order: by finest bits, ties in the listed order.
        let mut want: Vec<(u64, Wavelet)> = std::iter::once(Wavelet::Bicubic)
            .chain(others.iter().copied())
            .map(|w| (detail_bits(&canon, &mesh, w, d).unwrap().finest, w))
            .collect();
        want.sort_by_key(|&(b, _)| b);
        assert_eq!(order, want.iter().map(|&(_, w)| w).collect::<Vec<_>>());
        // The same with the first transform's bits known beforehand.
        let known = detail_bits(&canon, &mesh, Wavelet::Bicubic, d).unwrap();
        let (order_known, _) = by_bits(
            &canon,
            &mesh,
            (Wavelet::Bicubic, &others),
            d,
            Some((Wavelet::Bicubic, known)),
            1,
        );
        assert_eq!(order_known, order);
    }

    /// A coding from values analysed beforehand (their phases then found level by
    /// level from the synthesised values) is the coding that analyses them itself,
    /// byte for byte: every Catmull-Clark transform, every mode open and each level
    /// held to the phased modes 6 and 9 (which read the phases).
    #[test]
    fn codings_from_analysed_values_are_the_same() {
        let (canon, mesh, header) = super::super::tests::refined_prism();
        let d = DiscTransform::None;
        let levels = canon.levels.len();
        let mut phased = 0;
        for w in [
            Wavelet::Interp6,
            Wavelet::Interp4,
            Wavelet::Lazy,
            Wavelet::Bicubic,
        ] {
            for modes in [None, Some(vec![6; levels]), Some(vec![9; levels])] {
                let coding = Coding {
                    canon: &canon,
                    mesh: &mesh,
                    w,
                    disc: d,
                    header: &header,
                    search: ModeSearch::ALL,
                    bound: UNBOUNDED,
                    progress: &Progress::default(),
                };
                let itself = coding.code(modes.clone(), None);
                let given = coding.code(modes.clone(), analysed(&canon, &mesh, w, d));
                let key =
                    |p: &Option<Payloads>| p.as_ref().map(|p| (p.base.clone(), p.levels.clone()));
                assert_eq!(key(&itself), key(&given), "{w:?} {modes:?}");
                if modes.is_none() {
                    assert!(itself.is_some(), "{w:?}");
                }
                let reads_phases = |p: &Payloads| {
                    p.levels
                        .iter()
                        .any(|l| matches!(levl::mode_of(l), Some(6 | 9)))
                };
                phased += itself.as_ref().is_some_and(reads_phases) as usize;
            }
        }
        assert!(phased >= 3, "{phased} codings read phases");
    }
}

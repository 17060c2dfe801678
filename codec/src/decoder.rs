//! The decoder: one straight pipeline from the container to the mesh (SPEC.md 2-10).

use crate::error::{Error, Result};
use crate::mesh::{Mesh, MAX_COORD};
use crate::quant::Quantization;
use crate::sections::head::{Family, Header, Transform};
use crate::sections::vmap::ValueMap;
use crate::sections::{base, levl, ordr};
use crate::topology::{self, Level, Topo};
use crate::transform::polar::{self};
use crate::transform::{self, fit, sqrt2, Wavelet};
use crate::Limits;
use subwave_container::{Container, SectionKind};

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

pub(crate) fn expect_kind(
    c: &Container<'_>,
    i: usize,
    kind: SectionKind,
    what: &str,
) -> Result<()> {
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

/// Checks the section sequence (SPEC.md 2.4) and returns the header. With `whole`, the
/// container must hold every section; otherwise a prefix is fine.
pub(crate) fn layout(c: &Container<'_>, limits: &Limits, whole: bool) -> Result<Header> {
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
        let phased = levl::reads_phases(payload);
        let (predictions, phases) = match lazy {
            true => {
                let (p, ph) = sqrt2::predictions_with(&level, &x, phased);
                (Some(p), ph)
            }
            false => (None, None),
        };
        let plan = (is_sqrt2 && w == Wavelet::Sqrt2Sym).then(|| sqrt2::Plan::new(&level, w));
        // Tangent targets only for a level coded in tangent mode (SPEC.md 10.3).
        let tangent = levl::reads_targets(payload);
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

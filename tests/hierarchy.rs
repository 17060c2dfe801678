//! Catmull-Clark, polar and sqrt(2) hierarchies: recovery depth on the shared corpus, coarser levels from
//! whole and cut-off files, and exact round trips of random hierarchies through every
//! transform.

mod common;

use std::path::Path;

use proptest::prelude::*;
use subwave::{EncodeOptions, Mesh, Quantization, TransformChoice, Wavelet};
use subwave_corpus::{PolyMesh, Rng};

/// Encodes, with transform `w`, every shared-corpus mesh whose manifest topology is in
/// `topologies`, ordered and shuffled, checks it decodes exactly, and hands each to
/// `check` with its manifest entry;
/// returns how many were checked (`None` without `../shared/corpus`).
fn each_manifest_mesh(
    topologies: &[&str],
    w: Wavelet,
    mut check: impl FnMut(&serde_json::Value, &str, &subwave::Encoded),
) -> Option<usize> {
    let Some(dir) = common::shared_corpus() else {
        eprintln!("../shared/corpus not found; skipping");
        return None;
    };
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).unwrap()).unwrap();
    let mut checked = 0;
    for e in manifest["meshes"].as_array().unwrap() {
        if !topologies.contains(&e["topology"].as_str().unwrap()) {
            continue;
        }
        for key in ["file", "shuffled_file"] {
            let name = e[key].as_str().unwrap();
            let m = subwave::load(&std::fs::read(dir.join(name)).unwrap(), Some(16)).unwrap();
            let opts = EncodeOptions {
                transform: TransformChoice::Fixed(w),
                ..Default::default()
            };
            let enc = subwave::encode_to_vec(&m.mesh, &m.quantization, &opts).unwrap();
            // Every one decodes exactly (vertex and face order aside).
            let dec = subwave::decode_slice(&enc.bytes).unwrap();
            assert_eq!(
                common::fingerprint(&dec.mesh),
                common::fingerprint(&m.mesh),
                "{name}"
            );
            check(e, name, &enc);
            checked += 1;
        }
    }
    Some(checked)
}

#[test]
fn recovered_depth_reaches_the_manifest_on_cc_and_grid_meshes() {
    let checked = each_manifest_mesh(&["cc", "grid"], Wavelet::Lazy, |e, name, enc| {
        let want = e["levels"].as_u64().unwrap();
        assert_eq!(enc.header.family, subwave::Family::Cc, "{name}");
        assert!(
            enc.header.levels as u64 >= want,
            "{name}: recovered {} levels, manifest says {want}",
            enc.header.levels
        );
    });
    if let Some(checked) = checked {
        assert!(checked >= 34, "checked only {checked} meshes");
    }
}

#[test]
fn polar_meshes_recover_their_full_depth_in_any_order() {
    let checked = each_manifest_mesh(&["polar"], Wavelet::Bicubic, |e, name, enc| {
        assert_eq!(enc.header.family, subwave::Family::Polar, "{name}");
        assert_eq!(
            enc.header.levels as u64,
            e["levels"].as_u64().unwrap(),
            "{name}"
        );
        assert_eq!(
            (enc.header.base_vertices, enc.header.base_faces),
            (
                e["base_vertex_count"].as_u64().unwrap(),
                e["base_face_count"].as_u64().unwrap()
            ),
            "{name}"
        );
        let poles = e["pole_base_valences"].as_array().unwrap().len();
        assert_eq!(enc.header.poles.len(), poles, "{name}");
    });
    if let Some(checked) = checked {
        assert_eq!(checked, 4, "two polar meshes, ordered and shuffled");
    }
}

/// A random polar hierarchy: a latitude-longitude sphere (`n` spokes, `rings` rings) or
/// the mixed base with a fan of 5 triangles in place of a pentagon, refined `levels`
/// times, shuffled, with random coordinates of up to `bits` bits.
fn random_polar_hierarchy(seed: u64, base: usize, levels: u32, bits: u32) -> (Mesh, usize) {
    let mut rng = Rng::new(seed);
    let (b, poles) = match base {
        0 => (subwave_corpus::polar_sphere(4, 1), vec![0, 1]),
        1 => (subwave_corpus::polar_sphere(7, 2), vec![0, 1]),
        _ => {
            let mut b = subwave_corpus::mixed_polygons();
            let hub = b.positions.len() as u32;
            b.positions.push([0.0, 0.0, -0.8]);
            let top = b.faces.remove(0);
            for i in 0..top.len() {
                b.faces.push(vec![hub, top[i], top[(i + 1) % top.len()]]);
            }
            (b, vec![hub])
        }
    };
    let fine = b.polar_refined(&poles, levels);
    (randomised(&fine, &mut rng, bits), poles.len())
}

#[test]
fn polar_levels_decode_coarser_meshes_with_their_fans() {
    let (mesh, _) = random_polar_hierarchy(4, 1, 3, 20);
    let enc = subwave::encode_to_vec(
        &mesh,
        &Quantization::Decimal { decimals: 0 },
        &EncodeOptions::default(),
    )
    .unwrap();
    assert_eq!(enc.header.family, subwave::Family::Polar);
    assert_eq!(enc.header.levels, 3);
    let full = subwave::decode_slice(&enc.bytes).unwrap();
    assert_eq!(common::fingerprint(&full.mesh), common::fingerprint(&mesh));
    for k in 0..=3u8 {
        let dec = subwave::decode(&enc.bytes, &common::up_to(k)).unwrap();
        // Two poles of valence 7 * 2^k, each with its fan; all other faces quads.
        let triangles = dec.mesh.iter_faces().filter(|f| f.len() == 3).count();
        assert_eq!(triangles, 2 * (7 << k), "level {k}");
        assert!(dec.mesh.iter_faces().all(|f| f.len() == 3 || f.len() == 4));
        for &p in &enc.header.poles {
            let fan = dec.mesh.iter_faces().filter(|f| f.contains(&p)).count();
            assert_eq!(fan, 7 << k, "level {k}: pole {p}");
        }
    }
}

fn cube_levels(levels: u32) -> (Mesh, subwave::Encoded) {
    let mut rng = Rng::new(3);
    let mut p = subwave_corpus::cube().refined(levels);
    p.displace(0.05, 0.002, &mut rng);
    let p = p.shuffled(&mut rng);
    let mesh = common::to_mesh(&p, 1e6);
    let opts = EncodeOptions {
        transform: TransformChoice::Fixed(Wavelet::Lazy),
        ..Default::default()
    };
    let enc = subwave::encode_to_vec(&mesh, &Quantization::Decimal { decimals: 6 }, &opts).unwrap();
    (mesh, enc)
}

#[test]
fn coarser_levels_from_whole_and_cut_files() {
    let (_, enc) = cube_levels(4);
    assert_eq!(enc.header.levels, 4);
    let full = subwave::decode_slice(&enc.bytes).unwrap();
    let info = subwave::inspect(&enc.bytes, &subwave::Limits::default()).unwrap();
    // Byte offsets where each section ends.
    let mut ends = Vec::new();
    let mut at = subwave_container::PREAMBLE_LEN;
    for s in &info.sections {
        at += s.bytes;
        ends.push(at);
    }
    let mut expected_vertices = enc.header.base_vertices as usize;
    let mut expected_faces = enc.header.base_faces as usize;
    let mut corners = enc.header.base_corners as usize;
    for k in 0..=4u8 {
        let opts = common::up_to(k);
        let whole = subwave::decode(&enc.bytes, &opts).unwrap();
        assert_eq!(whole.level, k);
        assert_eq!(whole.mesh.vertex_count(), expected_vertices, "level {k}");
        assert_eq!(whole.mesh.face_count(), expected_faces, "level {k}");
        // Lazy keeps coarse vertices as they are: level k's positions are a prefix.
        assert_eq!(
            whole.mesh.positions[..],
            full.mesh.positions[..expected_vertices]
        );
        // Cut right after level k's section, and in the middle of the next one.
        let cut = ends[1 + k as usize];
        let cut_file = subwave::decode(&enc.bytes[..cut], &opts).unwrap();
        assert_eq!(cut_file.mesh, whole.mesh);
        if k < 4 {
            let mid = subwave::decode(&enc.bytes[..cut + 9], &opts).unwrap();
            assert_eq!(mid.mesh, whole.mesh);
            // Without --max-level the cut file is an error.
            assert!(subwave::decode_slice(&enc.bytes[..cut]).is_err());
            // Asking for a level beyond the cut is an error too.
            assert!(subwave::decode(&enc.bytes[..cut], &common::up_to(k + 1)).is_err());
        }
        // Next level's counts: V + E + F vertices, one quad per corner.
        // A closed mesh: every edge has two faces.
        let edges = corners / 2;
        expected_vertices += edges + expected_faces;
        expected_faces = corners;
        corners = 4 * expected_faces;
    }
}

#[test]
fn bicubic_coarse_levels_are_rescaled_to_the_geometry() {
    let mut rng = Rng::new(9);
    let mut p = subwave_corpus::cube().refined(3);
    p.displace(0.05, 0.0, &mut rng);
    let mesh = common::to_mesh(&p, 1e6);
    let opts = EncodeOptions {
        transform: TransformChoice::Fixed(Wavelet::Bicubic),
        ..Default::default()
    };
    let enc = subwave::encode_to_vec(&mesh, &Quantization::Decimal { decimals: 6 }, &opts).unwrap();
    let l2 = subwave::decode(&enc.bytes, &common::up_to(2)).unwrap();
    let full = subwave::decode_slice(&enc.bytes).unwrap();
    // Level-2 control points lie near the surface: within 10 % of the extent of the
    // fine vertices they become.
    for (i, p) in l2.mesh.positions.iter().enumerate() {
        for k in 0..3 {
            assert!(
                (p[k] - full.mesh.positions[i][k]).abs() < 100_000,
                "{p:?} vs {:?}",
                full.mesh.positions[i]
            );
        }
    }
}

/// A smooth height field `height(x, y)` over a 4 x 4 open grid refined `levels` times,
/// coded with `better` and with `worse`: both decode exactly, `better` is smaller, and its
/// header names it by its transform code `code`.
fn codes_smaller(
    levels: u32,
    height: impl Fn(f64, f64) -> f64,
    (better, worse): (Wavelet, Wavelet),
    code: u8,
) {
    let mut p = subwave_corpus::open_grid(4, 4).refined(levels);
    for v in &mut p.positions {
        v[2] = height(v[0] * 3.7, v[1] * 4.1);
    }
    let mesh = common::to_mesh(&p, 1e4);
    let q = Quantization::Decimal { decimals: 4 };
    let coded = |w: Wavelet| {
        let opts = EncodeOptions {
            transform: TransformChoice::Fixed(w),
            ..Default::default()
        };
        let enc = subwave::encode_to_vec(&mesh, &q, &opts).unwrap();
        let dec = subwave::decode_slice(&enc.bytes).unwrap();
        assert_eq!(
            common::fingerprint(&dec.mesh),
            common::fingerprint(&mesh),
            "{}",
            w.name()
        );
        enc
    };
    let (b, w) = (coded(better), coded(worse));
    assert!(b.header.levels >= levels as u8);
    assert!(
        b.bytes.len() < w.bytes.len(),
        "{} {} B, {} {} B",
        better.name(),
        b.bytes.len(),
        worse.name(),
        w.bytes.len()
    );
    let head = b.header.write();
    let limits = subwave::Limits::default();
    let read = subwave::Header::read(&head, 0, &limits).unwrap();
    assert_eq!(read.transform, subwave::Transform::Wavelet(better));
    assert_eq!(better.code(), code);
}

#[test]
fn interp4_codes_smooth_open_grids_smaller_than_lazy() {
    // A cubic height field: the 4-point rule's details are zero wherever its stencil is
    // complete, so interp4 codes it smaller than the lazy transform.
    codes_smaller(
        3,
        |x, y| x * x * x - 2.0 * x * y * y + 0.5 * y,
        (Wavelet::Interp4, Wavelet::Lazy),
        10,
    );
}

#[test]
fn interp6_codes_smooth_open_grids_smaller_than_interp4() {
    // A quintic height field: the 6-point rule's details are zero wherever its stencil
    // is complete, so interp6 codes it smaller than interp4.
    codes_smaller(
        4,
        |x, y| x.powi(5) - 2.0 * x * x * y.powi(3) + 0.5 * y.powi(4) - x,
        (Wavelet::Interp6, Wavelet::Interp4),
        11,
    );
}

fn random_hierarchy(seed: u64, base: usize, levels: u32, bits: u32) -> Mesh {
    let mut rng = Rng::new(seed);
    let b = match base {
        0 => subwave_corpus::cube(),
        1 => subwave_corpus::mixed_polygons(),
        2 => subwave_corpus::open_grid(2, 1),
        _ => subwave_corpus::union(&[subwave_corpus::cube(), subwave_corpus::open_grid(1, 1)]),
    };
    let fine = b.refined(levels);
    randomised(&fine, &mut rng, bits)
}

/// `fine` shuffled, with random coordinates of up to `bits` bits and an unreferenced
/// vertex riding along.
fn randomised(fine: &PolyMesh, rng: &mut Rng, bits: u32) -> Mesh {
    let mut m = common::to_mesh(&fine.shuffled(rng), 1.0);
    let span = (1i64 << bits) - 1;
    for p in &mut m.positions {
        for c in p.iter_mut() {
            *c = (rng.next_u64() % (2 * span as u64 + 1)) as i64 - span;
        }
    }
    m.positions.push([span, -span, 0]);
    m
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]
    #[test]
    fn random_hierarchies_round_trip_through_every_transform(
        seed in any::<u64>(), base in 0usize..4, levels in 1u32..4, bits in 1u32..45, keep in any::<bool>()
    ) {
        let mesh = random_hierarchy(seed, base, levels, bits);
        for w in Wavelet::ALL {
            let opts = EncodeOptions { transform: TransformChoice::Fixed(w), keep_order: keep, ..Default::default() };
            let enc = subwave::encode_to_vec(&mesh, &Quantization::Decimal { decimals: 0 }, &opts).unwrap();
            prop_assert_eq!(enc.header.levels as u32, levels);
            let dec = subwave::decode_slice(&enc.bytes).unwrap();
            if keep {
                prop_assert_eq!(&dec.mesh, &mesh);
            } else {
                prop_assert_eq!(common::fingerprint(&dec.mesh), common::fingerprint(&mesh));
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// Every Catmull-Clark transform, with and without the polar wavelet in the discs.
    #[test]
    fn random_polar_hierarchies_round_trip_through_every_transform(
        seed in any::<u64>(), base in 0usize..3, levels in 1u32..4, bits in 1u32..45, keep in any::<bool>()
    ) {
        let (mesh, poles) = random_polar_hierarchy(seed, base, levels, bits);
        for (w, d) in Wavelet::ALL.into_iter().flat_map(|w| subwave::DiscTransform::ALL.map(|d| (w, d))) {
            let opts = EncodeOptions {
                transform: TransformChoice::Fixed(w),
                keep_order: keep,
                disc: Some(d),
                ..Default::default()
            };
            let enc = subwave::encode_to_vec(&mesh, &Quantization::Decimal { decimals: 0 }, &opts).unwrap();
            prop_assert_eq!(enc.header.family, subwave::Family::Polar);
            prop_assert_eq!(enc.header.disc, d);
            prop_assert!(enc.header.levels as u32 >= levels);
            prop_assert_eq!(enc.header.poles.len(), poles);
            let dec = subwave::decode_slice(&enc.bytes).unwrap();
            if keep {
                prop_assert_eq!(&dec.mesh, &mesh);
            } else {
                prop_assert_eq!(common::fingerprint(&dec.mesh), common::fingerprint(&mesh));
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]
    /// Random polygon base meshes (degrees 3 to 6, boundaries, several components,
    /// repeated corners), refined 0 to 2 times, shuffled, with coordinates up to the
    /// supported range and a random transform: the fuzz target's property, here on every
    /// CI run.
    #[test]
    fn random_base_meshes_round_trip(data in proptest::collection::vec(any::<u8>(), 16..600)) {
        subwave::fuzz_harness::roundtrip_mesh(&data);
    }
}

#[test]
fn sqrt2_meshes_recover_their_full_depth_in_any_order() {
    let checked = each_manifest_mesh(&["sqrt2"], Wavelet::Sqrt2Lazy, |e, name, enc| {
        let want = e["levels"].as_u64().unwrap();
        assert_eq!(enc.header.family, subwave::Family::Sqrt2, "{name}");
        assert_eq!(enc.header.levels as u64, want, "{name}: sqrt(2) steps");
        // The manifest's base or, with an even step count, its dual (the same
        // refinement; the tie goes to fewer base vertices).
        let (bv, bf) = (
            e["base_vertex_count"].as_u64().unwrap(),
            e["base_face_count"].as_u64().unwrap(),
        );
        let got = (enc.header.base_vertices, enc.header.base_faces);
        assert!(
            got == (bv, bf) || got == (bf, bv) && bf < bv,
            "{name}: base {got:?}"
        );
    });
    if let Some(checked) = checked {
        assert_eq!(checked, 8, "four sqrt2 meshes, ordered and shuffled");
    }
}

#[test]
fn a_catmull_clark_mesh_is_also_a_sqrt2_mesh_of_twice_the_steps() {
    let mut rng = Rng::new(5);
    let mut p = subwave_corpus::mixed_polygons().refined(3);
    p.displace(0.02, 0.001, &mut rng);
    let mesh = common::to_mesh(&p.shuffled(&mut rng), 1e5);
    let q = Quantization::Decimal { decimals: 5 };
    for (w, family, levels) in [
        (Wavelet::Bicubic, subwave::Family::Cc, 3),
        (Wavelet::Ir2w, subwave::Family::Sqrt2, 6),
    ] {
        let opts = EncodeOptions {
            transform: TransformChoice::Fixed(w),
            ..Default::default()
        };
        let enc = subwave::encode_to_vec(&mesh, &q, &opts).unwrap();
        assert_eq!(enc.header.family, family);
        assert_eq!(enc.header.levels, levels);
        let dec = subwave::decode_slice(&enc.bytes).unwrap();
        assert_eq!(common::fingerprint(&dec.mesh), common::fingerprint(&mesh));
    }
}

#[test]
fn sqrt2_coarser_levels_are_the_interpolated_vertices() {
    // sqrt2-lazy is interpolatory: level k's vertices are input vertices.
    let mut rng = Rng::new(9);
    let mut p = subwave_corpus::mixed_polygons().sqrt2_refined(5);
    p.displace(0.02, 0.001, &mut rng);
    let mesh = common::to_mesh(&p, 1e6);
    let opts = EncodeOptions {
        transform: TransformChoice::Fixed(Wavelet::Sqrt2Lazy),
        ..Default::default()
    };
    let enc = subwave::encode_to_vec(&mesh, &Quantization::Decimal { decimals: 6 }, &opts).unwrap();
    assert_eq!(enc.header.levels, 5);
    let all: std::collections::HashSet<[i64; 3]> = mesh.positions.iter().copied().collect();
    let mut last = 0;
    for k in 0..=5u8 {
        let d = subwave::decode(&enc.bytes, &common::up_to(k)).unwrap();
        assert!(d.mesh.vertex_count() > last);
        last = d.mesh.vertex_count();
        assert!(
            d.mesh.positions.iter().all(|p| all.contains(p)),
            "level {k}"
        );
    }
    assert_eq!(last, mesh.vertex_count());
}

fn random_sqrt2_hierarchy(seed: u64, base: usize, steps: u32, bits: u32) -> Mesh {
    let mut rng = Rng::new(seed);
    let b = match base {
        0 => subwave_corpus::cube(),
        1 => subwave_corpus::mixed_polygons(),
        _ => subwave_corpus::union(&[
            subwave_corpus::mixed_polygons(),
            subwave_corpus::mixed_polygons().sqrt2_refined(2),
        ]),
    };
    randomised(&b.sqrt2_refined(steps), &mut rng, bits)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]
    #[test]
    fn random_sqrt2_hierarchies_round_trip_through_every_sqrt2_transform(
        seed in any::<u64>(), base in 0usize..3, steps in 1u32..6, bits in 1u32..45, keep in any::<bool>()
    ) {
        let mesh = random_sqrt2_hierarchy(seed, base, steps, bits);
        for w in Wavelet::SQRT2 {
            let opts = EncodeOptions { transform: TransformChoice::Fixed(w), keep_order: keep, ..Default::default() };
            let enc = subwave::encode_to_vec(&mesh, &Quantization::Decimal { decimals: 0 }, &opts).unwrap();
            prop_assert_eq!(enc.header.family, subwave::Family::Sqrt2);
            prop_assert!(enc.header.levels as u32 >= steps);
            let dec = subwave::decode_slice(&enc.bytes).unwrap();
            if keep {
                prop_assert_eq!(&dec.mesh, &mesh);
            } else {
                prop_assert_eq!(common::fingerprint(&dec.mesh), common::fingerprint(&mesh));
            }
        }
    }
}

#[test]
fn tangent_mode_codes_fitted_sqrt2_levels_exactly() {
    // corpus/prism_sqrt2_5.obj puts every face point at its face's centroid, then
    // displaces the mesh (the corpus crate's sqrt2_refined and displace): its finer
    // levels code smallest in tangent mode (SPEC.md 10.3).
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus/prism_sqrt2_5.obj");
    let m = subwave::load(&std::fs::read(path).unwrap(), None).unwrap();
    for w in Wavelet::SQRT2 {
        let opts = EncodeOptions {
            transform: TransformChoice::Fixed(w),
            keep_order: true,
            ..Default::default()
        };
        let enc = subwave::encode_to_vec(&m.mesh, &m.quantization, &opts).unwrap();
        let modes: Vec<u8> = enc.sections.iter().filter_map(|s| s.mode).collect();
        assert_eq!(modes.len(), 5, "{w:?}");
        if w == Wavelet::Sqrt2Lazy {
            assert!(modes.iter().filter(|&&m| m == 2).count() >= 3, "{modes:?}");
        }
        let info = subwave::inspect(&enc.bytes, &Default::default()).unwrap();
        let read: Vec<u8> = info.sections.iter().filter_map(|s| s.mode).collect();
        assert_eq!(read, modes);
        let dec = subwave::decode_slice(&enc.bytes).unwrap();
        assert_eq!(dec.mesh, m.mesh, "{w:?}");
    }
}

/// A mesh that reaches near the edge of the coordinates' range (|x| <= 2^44 - 1), as
/// binary float quantisation places one (the grid's largest exponent just above the
/// values), coded with the update-step transforms (bicubic, biquintic: their coarse
/// values carry 1/g of the geometry per level and approach the control cage, beyond the
/// smooth surface): every coarser level decodes, its values clamped into the range
/// (SPEC.md 9.4), and the finest level comes back exactly.
#[test]
fn coarser_levels_of_a_mesh_at_the_range_edge_are_clamped_not_refused() {
    let max = (1i64 << 44) - 1;
    let path = common::own_corpus()
        .into_iter()
        .find(|p| p.ends_with("cube_cc4.obj"))
        .unwrap();
    let input = subwave::load(&std::fs::read(path).unwrap(), None).unwrap();
    let mut mesh = input.mesh.clone();
    mesh.attributes.clear();
    // The smooth cube at 8/9 of the range: its octahedral cage passes the edge.
    let reach = mesh
        .positions
        .iter()
        .flatten()
        .map(|v| v.abs())
        .max()
        .unwrap();
    let scale = max / 9 * 8 / reach;
    for v in mesh.positions.iter_mut().flatten() {
        *v *= scale;
    }
    for w in [Wavelet::Bicubic, Wavelet::Biquintic] {
        let opts = EncodeOptions {
            transform: TransformChoice::Fixed(w),
            ..Default::default()
        };
        let enc =
            subwave::encode_to_vec(&mesh, &Quantization::Decimal { decimals: 0 }, &opts).unwrap();
        let levels = enc.header.levels;
        assert!(levels >= 2, "{w:?}: {levels} levels");
        let full = subwave::decode_slice(&enc.bytes).unwrap();
        assert_eq!(
            common::fingerprint(&full.mesh),
            common::fingerprint(&mesh),
            "{w:?}"
        );
        let mut clamped = 0;
        for k in 0..levels {
            let dec = subwave::decode(&enc.bytes, &common::up_to(k))
                .unwrap_or_else(|e| panic!("{w:?} level {k}: {e}"));
            let pos = &dec.mesh.positions;
            assert!(
                pos.iter().flatten().all(|v| v.abs() <= max),
                "{w:?} level {k}"
            );
            clamped += pos.iter().flatten().filter(|v| v.abs() == max).count();
        }
        assert!(
            clamped > 0,
            "{w:?}: no coarser value reached the range's edge"
        );
    }
}

//! The subdivision fit (SPEC.md 9.10, 10.4): subdivided models are coded as fits and
//! decode exactly; the fit decodes exactly on any Catmull-Clark hierarchy, also with a
//! border; coarser levels; hostile fit containers are refused.

mod common;

use std::path::Path;

use proptest::prelude::*;
use subwave::{EncodeOptions, Error, Limits, Mesh, Transform, TransformChoice};
use subwave_container::{ContainerWriter, SectionKind};
use subwave_corpus::{Kept, Rng};

fn own(name: &str, bits: Option<u8>) -> subwave::Loaded {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("corpus")
        .join(name);
    subwave::load(&std::fs::read(path).unwrap(), bits).unwrap()
}

fn encode(mesh: &Mesh, q: &subwave::Quantization, t: TransformChoice) -> subwave::Encoded {
    let opts = EncodeOptions {
        transform: t,
        ..Default::default()
    };
    subwave::encode_to_vec(mesh, q, &opts).unwrap()
}

/// Decodes and checks every position and face against `mesh` (order aside).
fn assert_exact(bytes: &[u8], mesh: &Mesh, what: &str) {
    let dec = subwave::decode_slice(bytes).unwrap();
    assert_eq!(
        common::fingerprint(&dec.mesh),
        common::fingerprint(mesh),
        "{what}"
    );
}

#[test]
fn subdivided_models_are_coded_as_fits_and_decode_exactly() {
    for name in ["subdivided_cc3.obj", "subdivided_open_cc3.obj"] {
        for bits in [None, Some(16), Some(12)] {
            let m = own(name, bits);
            let auto = encode(&m.mesh, &m.quantization, TransformChoice::Auto);
            assert!(
                matches!(auto.header.transform, Transform::Fit { .. }),
                "{name} {bits:?}: auto chose {}",
                auto.header.transform.name()
            );
            assert_eq!(auto.header.levels, 3, "{name}");
            assert_exact(&auto.bytes, &m.mesh, name);
            // Far smaller than the best wavelet on the same hierarchy.
            let cubic = encode(
                &m.mesh,
                &m.quantization,
                TransformChoice::Fixed(subwave::Wavelet::Bicubic),
            );
            assert!(
                2 * auto.bytes.len() < cubic.bytes.len(),
                "{name} {bits:?}: fit {} B, bicubic {} B",
                auto.bytes.len(),
                cubic.bytes.len()
            );
        }
    }
}

#[test]
fn fits_of_meshes_with_detail_still_decode_exactly() {
    // (mesh, whether detail was added after refinement)
    for (name, detail) in [
        ("cube_cc4.obj", true),
        ("open_cc2.obj", true),
        ("mixed_cc2.obj", true),
        ("two_components_cc2.obj", false),
    ] {
        for bits in [None, Some(16), Some(4)] {
            let m = own(name, bits);
            let enc = encode(&m.mesh, &m.quantization, TransformChoice::Fit);
            assert!(
                matches!(enc.header.transform, Transform::Fit { .. }),
                "{name}"
            );
            assert_exact(&enc.bytes, &m.mesh, name);
            // Detail is coded, not dropped, and costs the fit more than a wavelet.
            if detail && bits != Some(4) {
                let auto = encode(&m.mesh, &m.quantization, TransformChoice::Auto);
                assert!(!matches!(auto.header.transform, Transform::Fit { .. }));
                assert!(auto.bytes.len() < enc.bytes.len(), "{name}");
            }
        }
    }
}

#[test]
fn coarser_levels_of_a_fit_are_its_rounded_refinements() {
    let m = own("subdivided_cc3.obj", Some(16));
    let enc = encode(&m.mesh, &m.quantization, TransformChoice::Auto);
    let full = subwave::decode_slice(&enc.bytes).unwrap().mesh;
    let (lo, hi) = bounds(&full);
    let mut prev_nv = 0;
    for k in 0..=enc.header.levels {
        let dec = subwave::decode(&enc.bytes, &common::up_to(k)).unwrap();
        assert_eq!(dec.level, k);
        assert!(dec.mesh.vertex_count() > prev_nv);
        prev_nv = dec.mesh.vertex_count();
        if k == enc.header.levels {
            assert_eq!(common::fingerprint(&dec.mesh), common::fingerprint(&m.mesh));
        } else if k > 0 {
            // A refinement of the control mesh: near the surface, off it by no more
            // than a tenth of its size.
            let (l, h) = bounds(&dec.mesh);
            for a in 0..3 {
                let slack = (hi[a] - lo[a]) / 10;
                assert!(l[a] >= lo[a] - slack && h[a] <= hi[a] + slack, "level {k}");
            }
        }
    }
    // Cut off after level 1, level 1 still decodes; the finest does not.
    let c = subwave_container::Container::parse(&enc.bytes, &Limits::default()).unwrap();
    let cut = c.sections[3].offset as usize;
    assert!(subwave::decode(&enc.bytes[..cut], &common::up_to(1)).is_ok());
    assert!(subwave::decode(&enc.bytes[..cut], &common::up_to(3)).is_err());
}

fn bounds(m: &Mesh) -> ([i64; 3], [i64; 3]) {
    let mut lo = [i64::MAX; 3];
    let mut hi = [i64::MIN; 3];
    for p in &m.positions {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

/// The fit container of `subdivided_cc3.obj` at Q16, rewritten: `head` edits the header
/// payload's bytes, `level` the payload of LEVL section `i` (0-based).
fn rewritten(head: impl Fn(&mut Vec<u8>), level: impl Fn(usize, &mut Vec<u8>)) -> Vec<u8> {
    let m = own("subdivided_cc3.obj", Some(16));
    let enc = encode(&m.mesh, &m.quantization, TransformChoice::Auto);
    let c = subwave_container::Container::parse(&enc.bytes, &Limits::default()).unwrap();
    let mut w = ContainerWriter::new();
    let mut li = 0;
    for s in &c.sections {
        let mut p = s.payload.to_vec();
        match s.kind {
            SectionKind::END => continue,
            SectionKind::HEADER => head(&mut p),
            SectionKind::LEVEL => {
                level(li, &mut p);
                li += 1;
            }
            _ => {}
        }
        w.section(s.kind, &p);
    }
    w.finish()
}

#[test]
fn hostile_fit_containers_are_refused() {
    // Unchanged, the rewritten container decodes.
    assert!(subwave::decode_slice(&rewritten(|_| {}, |_, _| {})).is_ok());
    // Where the precision byte is: the one byte two headers differing in it differ in
    // (the transform code comes just before it).
    let m = own("subdivided_cc3.obj", Some(16));
    let enc = encode(&m.mesh, &m.quantization, TransformChoice::Auto);
    let Transform::Fit {
        bits,
        limit,
        corners,
        linear,
        bilinear,
        limit_corners,
        extra_levels,
        end_caps,
    } = enc.header.transform
    else {
        panic!("not a fit")
    };
    let head = enc.header.write();
    let mut other = enc.header.clone();
    other.transform = Transform::Fit {
        bits: bits + 1,
        limit,
        corners,
        linear,
        bilinear,
        limit_corners,
        extra_levels,
        end_caps,
    };
    let at = head
        .iter()
        .zip(other.write())
        .position(|(a, b)| *a != b)
        .unwrap();
    assert_eq!(head[at - 1], 9);
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("17 extra bits", rewritten(|h| h[at] = 17, |_, _| {})),
        (
            "a fit on sqrt(2) levels",
            rewritten(|h| h[at - 2] = 2, |_, _| {}),
        ),
        (
            "data in a coarser level",
            rewritten(
                |_| {},
                |i, p| {
                    if i == 0 {
                        p.push(0)
                    }
                },
            ),
        ),
        (
            "a wavelet mode byte",
            rewritten(
                |_| {},
                |i, p| {
                    if i == 2 {
                        p[0] = 1
                    }
                },
            ),
        ),
        (
            "an empty residual section",
            rewritten(
                |_| {},
                |i, p| {
                    if i == 2 {
                        p.clear()
                    }
                },
            ),
        ),
        (
            "residuals cut short",
            rewritten(
                |_| {},
                |i, p| {
                    if i == 2 {
                        p.truncate(5)
                    }
                },
            ),
        ),
    ];
    for (what, bytes) in cases {
        match subwave::decode_slice(&bytes) {
            Err(Error::Container(_))
            | Err(Error::CorruptStream { .. })
            | Err(Error::CorruptLevel { .. }) => {}
            other => panic!("{what}: expected a malformed or corrupt container, got {other:?}"),
        }
    }
    // The rules (a varint: one byte below 128) set to `rules`, in two bytes.
    let rules_as = |rules: u64| {
        move |h: &mut Vec<u8>| {
            h[at + 1] = (rules & 0x7f) as u8 | 0x80;
            h.insert(at + 2, (rules >> 7) as u8);
        }
    };
    assert_eq!(head[at + 1] & 0x80, 0, "one byte of fit rules");
    for (what, rules) in [
        ("linear everywhere with kept corners", 128 | 4),
        ("linear everywhere with linear boundaries", 128 | 8),
        ("corners kept at the limit without the limit", 256),
        ("vertex sharpnesses without creased vertices", 512),
        ("extra levels without the limit", 1024),
        ("end caps without the limit", 2048),
        ("end caps with extra levels", 1 | 1024 | 2048),
    ] {
        match subwave::decode_slice(&rewritten(rules_as(rules), |_, _| {})) {
            Err(Error::Container(e)) => {
                let e = e.to_string();
                assert!(
                    e.contains("fit rules") || e.contains("without"),
                    "{what}: {e}"
                )
            }
            other => panic!("{what}: expected a malformed header, got {other:?}"),
        }
    }
    // Extra levels past 3 are malformed (the header's byte follows the rules).
    let extra_as = |e: u8| {
        move |h: &mut Vec<u8>| {
            rules_as(u64::from(h[at + 1]) | 1 | 1024)(h);
            h.insert(at + 3, e);
        }
    };
    match subwave::decode_slice(&rewritten(extra_as(4), |_, _| {})) {
        Err(Error::Container(e)) => assert!(e.to_string().contains("extra levels"), "{e}"),
        other => panic!("4 extra levels: expected a malformed header, got {other:?}"),
    }
    // One extra level is a header the decoder reads: the residuals then meet another
    // prediction, which decodes or fails cleanly.
    match subwave::decode_slice(&rewritten(extra_as(1), |_, _| {})) {
        Ok(_) | Err(Error::CorruptLevel { .. }) => {}
        other => panic!("one extra level: {other:?}"),
    }
    // End caps at level 0, or more than 12 levels below the finest, are malformed;
    // at level 1 the header is read (the residuals meet another prediction).
    let caps_as = |q: u8| {
        move |h: &mut Vec<u8>| {
            rules_as(u64::from(h[at + 1]) | 1 | 2048)(h);
            h.insert(at + 3, q);
        }
    };
    match subwave::decode_slice(&rewritten(caps_as(0), |_, _| {})) {
        Err(Error::Container(e)) => assert!(e.to_string().contains("end caps"), "{e}"),
        other => panic!("end caps at level 0: expected a malformed header, got {other:?}"),
    }
    match subwave::decode_slice(&rewritten(caps_as(1), |_, _| {})) {
        Ok(_) | Err(Error::CorruptLevel { .. }) => {}
        other => panic!("end caps at level 1: {other:?}"),
    }
    // Fit rules the format does not define are unsupported, not guessed at.
    match subwave::decode_slice(&rewritten(rules_as(4096), |_, _| {})) {
        Err(Error::Unsupported(what)) => assert!(what.contains("fit rules"), "{what}"),
        other => panic!("unknown fit rules: {other:?}"),
    }
    // The header names the fit (transform code 9) and its extra bits.
    let h = subwave::Header::read(&head, 0, &Limits::default()).unwrap();
    assert!(
        matches!(h.transform, subwave::Transform::Fit { .. }),
        "{h:?}"
    );
}

/// The pentagonal prism (two pentagon caps, one side split into triangles), its
/// control values moved by a smooth bump, and its ten rim edges (the caps' edges).
fn prism_and_rims() -> (subwave_corpus::PolyMesh, Vec<[u32; 2]>) {
    let mut control = subwave_corpus::mixed_polygons();
    control.displace(0.2, 0.0, &mut Rng::new(1));
    let rims = control.faces[..2]
        .iter()
        .flat_map(|f| (0..f.len()).map(move |i| [f[i], f[(i + 1) % f.len()]]))
        .collect();
    (control, rims)
}

/// The container decodes to `mesh` exactly and its residuals cost under a bit per
/// vertex.
fn exact_with_near_zero_residuals(enc: &subwave::Encoded, mesh: &Mesh, what: &str) {
    assert_exact(&enc.bytes, mesh, what);
    let (n, r) = (mesh.vertex_count(), residual_bytes(&enc.bytes));
    assert!(
        8 * r < n,
        "{what}: {r} B of residuals for {n} vertices ({:?}, {:?} {:?})",
        enc.header.crease_sharpness,
        enc.header.vertex_creases,
        enc.header.vertex_sharpness
    );
}

/// Bytes of a container's finest LEVL section (a fit's residuals).
fn residual_bytes(bytes: &[u8]) -> usize {
    let c = subwave_container::Container::parse(bytes, &Limits::default()).unwrap();
    c.sections
        .iter()
        .rfind(|s| s.kind == SectionKind::LEVEL)
        .unwrap()
        .payload
        .len()
}

#[test]
fn each_rule_set_is_found_and_its_surfaces_code_to_near_zero_residuals() {
    // Surfaces made by the corpus crate's own float evaluation of each rule set
    // (plain, limit, creased, both), rounded: the fit finds the rules (the creases
    // from the data alone), decodes exactly, and its residuals cost next to nothing.
    let (control, rims) = prism_and_rims();
    let q = subwave::Quantization::Decimal { decimals: 0 };
    for (creased, limit) in [(false, false), (false, true), (true, false), (true, true)] {
        let creases: &[[u32; 2]] = if creased { &rims } else { &[] };
        let surface = control.subdivision_surface(4, creases, limit);
        let mesh = common::to_mesh(&surface, 1e5);
        let enc = encode(&mesh, &q, TransformChoice::Fit);
        let what = format!("creased {creased}, limit {limit}");
        match enc.header.transform {
            Transform::Fit { limit: l, .. } => assert_eq!(l, limit, "{what}"),
            t => panic!("{what}: expected a fit, got {}", t.name()),
        }
        assert_eq!(
            enc.header.creases.len(),
            if creased { 10 } else { 0 },
            "{what}"
        );
        assert_exact(&enc.bytes, &mesh, &what);
        let n = mesh.vertex_count();
        let r = residual_bytes(&enc.bytes);
        assert!(8 * r < n, "{what}: {r} B of residuals for {n} vertices");
        // The plain fit of a limit or creased surface misses: its residuals are the
        // difference between the rule sets.
        if creased || limit {
            let plain = control.subdivision_surface(4, &[], false);
            let off = mesh
                .positions
                .iter()
                .zip(&common::to_mesh(&plain, 1e5).positions)
                .filter(|(a, b)| a != b)
                .count();
            assert!(
                off > n / 2,
                "{what}: the rule sets differ at {off} of {n} vertices"
            );
        }
    }
}

#[test]
fn a_vertex_between_two_faces_is_smooth() {
    // A cube whose top face is split through a middle vertex of two edges into two
    // quads (as on Blender's Suzanne): OpenSubdiv refines that vertex by the smooth
    // rule and places it on the limit by the smooth mask. The corpus crate's own
    // float evaluation of those rules, rounded, codes to near-zero residuals and
    // decodes exactly.
    let mut control = subwave_corpus::cube();
    let top = control
        .faces
        .iter()
        .position(|f| f == &[4, 5, 7, 6])
        .unwrap();
    control.positions.push([0.05, -0.1, 0.65]);
    control.faces[top] = vec![4, 5, 7, 8];
    control.faces.push(vec![7, 6, 4, 8]);
    control.displace(0.2, 0.0, &mut Rng::new(2));
    let q = subwave::Quantization::Decimal { decimals: 0 };
    for limit in [false, true] {
        let mesh = common::to_mesh(&control.subdivision_surface(4, &[], limit), 1e5);
        let enc = encode(&mesh, &q, TransformChoice::Fit);
        let what = format!("limit {limit}");
        match enc.header.transform {
            Transform::Fit { limit: l, .. } => assert_eq!(l, limit, "{what}"),
            t => panic!("{what}: expected a fit, got {}", t.name()),
        }
        assert_exact(&enc.bytes, &mesh, &what);
        let n = mesh.vertex_count();
        let r = residual_bytes(&enc.bytes);
        assert!(8 * r < n, "{what}: {r} B of residuals for {n} vertices");
    }
}

#[test]
fn semi_sharp_creases_are_found_with_their_sharpness() {
    // Limit surfaces made by the corpus crate's own float evaluation of OpenSubdiv's
    // semi-sharp rules: the prism's rims at Blender's crease 0.3, 0.5 and 0.8
    // (sharpness 0.9, 2.5 and 6.4 over four levels), and one vertex crease (sharpness
    // 1.6) on a smooth prism. The fit finds the edges or the vertex and the sharpness
    // from the data alone, decodes exactly, and its residuals cost next to nothing;
    // the infinitely sharp rims' fit does not.
    let (control, rims) = prism_and_rims();
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let one = 65536.0;
    let corner = control.faces[0][0];
    for (crease, vertex) in [(0.3, None), (0.5, None), (0.8, None), (0.0, Some(1.6))] {
        let sharpness: f64 = 10.0 * crease * crease;
        let edges: Vec<([u32; 2], f64)> = if vertex.is_none() {
            rims.iter().map(|&e| (e, sharpness)).collect()
        } else {
            Vec::new()
        };
        let vertices: Vec<(u32, f64)> = vertex.map(|s| (corner, s)).into_iter().collect();
        let surface = control.subdivision_surface_sharp(4, &edges, &vertices, true, Kept::Nothing);
        let mesh = common::to_mesh(&surface, 1e5);
        let what = format!("crease {crease}, vertex {vertex:?}");
        let enc = encode(&mesh, &q, TransformChoice::Fit);
        assert!(
            matches!(enc.header.transform, Transform::Fit { limit: true, .. }),
            "{what}: {:?}",
            enc.header.transform
        );
        match vertex {
            None => {
                assert_eq!(enc.header.creases.len(), 10, "{what}");
                assert!(enc.header.vertex_creases.is_empty(), "{what}");
                // Sharpness beyond the four levels is sharp to the limit: the same
                // surface as infinitely sharp, which the header lists without values.
                if sharpness < 4.0 {
                    assert_eq!(enc.header.crease_sharpness.len(), 10, "{what}");
                }
                for &s in &enc.header.crease_sharpness {
                    let s = s as f64 / one;
                    assert!(
                        (s - sharpness).abs() < 0.01 || sharpness > 4.0 && s > 4.0,
                        "{what}: sharpness {s}"
                    );
                }
            }
            Some(v) => {
                assert!(enc.header.creases.is_empty(), "{what}");
                // (numbered as the base mesh the encoder found)
                assert_eq!(enc.header.vertex_creases.len(), 1, "{what}");
                let s = enc.header.vertex_sharpness[0] as f64 / one;
                assert!((s - v).abs() < 0.01, "{what}: sharpness {s}");
            }
        }
        exact_with_near_zero_residuals(&enc, &mesh, &what);
        // Infinitely sharp rules miss these surfaces (but where the sharpness
        // outlasts the four levels).
        let sharp = common::to_mesh(&control.subdivision_surface(4, &rims, true), 1e5);
        assert_eq!(sharp.positions == mesh.positions, sharpness > 4.0, "{what}");
    }
}

#[test]
fn semi_sharp_creases_over_fewer_levels_than_the_isolation_level_are_found() {
    // Blender's default Quality (OpenSubdiv's isolation level 3) over two levels:
    // the limit of three levels' refinement, where a finite sharpness left is smooth
    // (the corpus crate's float evaluation). The prism's rims at crease 0.5 and 0.7
    // (sharpness 2.5 and 4.9) and one vertex crease (sharpness 2.6): the fit finds the
    // creases, their sharpness and the extra level, decodes exactly, and its residuals
    // cost next to nothing; the limit of the two levels alone is another surface.
    // (Seven prisms side by side: two levels of one are too few vertices to weigh a
    // residual against the coder's fixed costs; seven, 910 vertices, stay a mesh
    // small enough that `auto` tries the fit whatever it folds.)
    let (prism, prism_rims) = prism_and_rims();
    let copies = 7u32;
    let nv = prism.positions.len() as u32;
    let control = subwave_corpus::union(
        &(0..copies)
            .map(|i| subwave_corpus::translate(prism.clone(), [3.0 * i as f64, 0.0, 0.0]))
            .collect::<Vec<_>>(),
    );
    let rims: Vec<[u32; 2]> = (0..copies)
        .flat_map(|i| prism_rims.iter().map(move |e| e.map(|v| v + i * nv)))
        .collect();
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let corner = control.faces[0][0];
    for (crease, vertex) in [(0.5, None), (0.7, None), (0.0, Some(2.6))] {
        let sharpness: f64 = 10.0 * crease * crease;
        let edges: Vec<([u32; 2], f64)> = if vertex.is_none() {
            rims.iter().map(|&e| (e, sharpness)).collect()
        } else {
            Vec::new()
        };
        let vertices: Vec<(u32, f64)> = vertex
            .into_iter()
            .flat_map(|s| (0..copies).map(move |i| (corner + i * nv, s)))
            .collect();
        let surface = control.subdivision_surface_isolated(2, 1, &edges, &vertices, Kept::Nothing);
        let mesh = common::to_mesh(&surface, 1e6);
        let what = format!("crease {crease}, vertex {vertex:?}");
        let two = control.subdivision_surface_sharp(2, &edges, &vertices, true, Kept::Nothing);
        assert_ne!(
            common::to_mesh(&two, 1e6).positions,
            mesh.positions,
            "{what}"
        );
        // (`auto` tries the fit on so few vertices, though two levels of a smooth
        // surface fold as much as a scan does.)
        let enc = encode(&mesh, &q, TransformChoice::Auto);
        assert!(
            matches!(
                enc.header.transform,
                Transform::Fit {
                    limit: true,
                    extra_levels: Some(1),
                    ..
                }
            ),
            "{what}: {:?} {:?} {:?} {} B of residuals, {} vertices",
            enc.header.transform,
            enc.header.vertex_creases,
            enc.header.vertex_sharpness,
            residual_bytes(&enc.bytes),
            mesh.vertex_count()
        );
        let found = if vertex.is_none() {
            enc.header.creases.len()
        } else {
            enc.header.vertex_creases.len()
        };
        assert_eq!(
            found,
            if vertex.is_none() {
                rims.len()
            } else {
                vertices.len()
            },
            "{what}"
        );
        exact_with_near_zero_residuals(&enc, &mesh, &what);
    }
}

#[test]
fn auto_tries_the_fit_on_small_smooth_surfaces_with_semi_sharp_creases() {
    // The prism's rims at crease 0.5 (sharpness 2.5): too small and too creased for
    // the roughness screen and the two-level fit, but its finest faces meet at a
    // few degrees at their median, so `auto` tries every rule set on a mesh this
    // small and codes the fit with its creases.
    let (control, rims) = prism_and_rims();
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let edges: Vec<([u32; 2], f64)> = rims.iter().map(|&e| (e, 2.5)).collect();
    let surface = control.subdivision_surface_sharp(4, &edges, &[], true, Kept::Nothing);
    let mesh = common::to_mesh(&surface, 1e5);
    let enc = encode(&mesh, &q, TransformChoice::Auto);
    assert!(
        matches!(enc.header.transform, Transform::Fit { limit: true, .. }),
        "auto chose {}",
        enc.header.transform.name()
    );
    assert_eq!(enc.header.creases.len(), 10);
    assert_exact(&enc.bytes, &mesh, "semi-sharp prism");
}

#[test]
fn end_cap_points_do_not_pull_the_fit() {
    // Blender's default quality evaluates patches beside extraordinary vertices from
    // the fourth level on, not the limit surface: a few points off by thousands of
    // grid units. Here the prism's limit surface, four levels, with the points of
    // the last level inside the level-3 faces beside extraordinary vertices (their
    // face points and the edge points at the extraordinary vertex) moved so. The fit leaves them out of its least squares: the control mesh is the
    // prism's, so every other vertex's residual is the rounding's, and the moved
    // points cost what their offsets do.
    let (control, _) = prism_and_rims();
    let three = control.subdivision_surface(3, &[], false);
    let mut valence = vec![0usize; three.positions.len()];
    for f in &three.faces {
        for &v in f {
            valence[v as usize] += 1;
        }
    }
    let mut surface = control.subdivision_surface(4, &[], true);
    // Blender's order: the level-3 vertices, one per level-3 edge (numbered as the
    // faces first meet them), one per face.
    let mut edge_ids: std::collections::HashMap<(u32, u32), usize> = Default::default();
    for f in &three.faces {
        for i in 0..f.len() {
            let (a, b) = (f[i], f[(i + 1) % f.len()]);
            let n = edge_ids.len();
            edge_ids.entry((a.min(b), a.max(b))).or_insert(n);
        }
    }
    let nv3 = three.positions.len();
    let first_face_point = nv3 + edge_ids.len();
    let mut rng = Rng::new(9);
    let mut shift = |p: &mut [f64; 3]| {
        for x in p.iter_mut() {
            *x += 0.05 * (rng.unit() - 0.5);
        }
    };
    let mut moved = 0;
    for (f, face) in three.faces.iter().enumerate() {
        let Some(&ev) = face.iter().find(|&&v| valence[v as usize] != 4) else {
            continue;
        };
        shift(&mut surface.positions[first_face_point + f]);
        moved += 1;
        // And the edge points of the face's two edges at the extraordinary vertex.
        for i in 0..face.len() {
            let (a, b) = (face[i], face[(i + 1) % face.len()]);
            if a == ev || b == ev {
                shift(&mut surface.positions[nv3 + edge_ids[&(a.min(b), a.max(b))]]);
                moved += 1;
            }
        }
    }
    assert!(moved > 10, "{moved} points moved");
    let mesh = common::to_mesh(&surface, 1e5);
    let enc = limit_fit(&mesh);
    assert_exact(&enc.bytes, &mesh, "end caps");
    let (n, r) = (mesh.vertex_count(), residual_bytes(&enc.bytes));
    // About 3 x 12 bits per moved point, and the rounding's bit or less elsewhere
    // (pulled by them, the fit left 1,439 B here).
    assert!(
        r < 5 * moved + n / 8,
        "{r} B of residuals for {n} vertices, {moved} moved"
    );
}

#[test]
fn auto_finds_a_creased_limit_surface() {
    // A folded sheet (a tent along a column; 5 columns, so that its hierarchy's base
    // is this grid), its fold creased (infinitely sharp, and at Blender's crease 0.5,
    // sharpness 2.5), on the limit: regular patches, so `auto` sees a surface, tries
    // the fit and finds the crease and its sharpness.
    let (control, fold) = subwave_corpus::folded_sheet();
    for sharpness in [subwave_corpus::INFINITELY_SHARP, 2.5] {
        let edges: Vec<([u32; 2], f64)> = fold.iter().map(|&e| (e, sharpness)).collect();
        let surface = control.subdivision_surface_sharp(3, &edges, &[], true, Kept::Nothing);
        let mesh = common::to_mesh(&surface, 1e6);
        let q = subwave::Quantization::Decimal { decimals: 0 };
        let enc = encode(&mesh, &q, TransformChoice::Auto);
        assert!(
            matches!(enc.header.transform, Transform::Fit { limit: true, .. }),
            "{sharpness}: auto chose {}",
            enc.header.transform.name()
        );
        assert_eq!(enc.header.creases.len(), 4);
        // Listed without values when infinitely sharp.
        let want = if sharpness < 3.0 { 4 } else { 0 };
        assert_eq!(enc.header.crease_sharpness.len(), want, "{sharpness}");
        for &s in &enc.header.crease_sharpness {
            let s = s as f64 / 65536.0;
            assert!((s - sharpness).abs() < 1.0 / 1024.0, "sharpness {s}");
        }
        assert_exact(&enc.bytes, &mesh, "folded sheet");
        let n = mesh.vertex_count();
        let r = residual_bytes(&enc.bytes);
        assert!(
            8 * r < n,
            "{sharpness}: {r} B of residuals for {n} vertices"
        );
    }
}

#[test]
fn auto_finds_limit_surfaces_the_roughness_screen_cannot_tell() {
    // One or two levels (Blender's "levels=2", a stand of two 16-gons and a side),
    // smooth, on the limit: no five finest vertices in a row within a level-1 face,
    // so the roughness screen cannot tell; one quick fit does, and `auto` codes the
    // fit. Three and four levels of the same prism, whose every base vertex is
    // extraordinary (valence-3 corners, pentagons), leave few regular runs for the
    // roughness screen: the quick fit decides again (on the first two levels). The
    // same control mesh with detail added after refining keeps its wavelet.
    let (control, _) = prism_and_rims();
    let q = subwave::Quantization::Decimal { decimals: 0 };
    for levels in [1, 2, 3, 4] {
        let surface = control.subdivision_surface(levels, &[], true);
        let mesh = common::to_mesh(&surface, 1e6);
        let enc = encode(&mesh, &q, TransformChoice::Auto);
        assert!(
            matches!(enc.header.transform, Transform::Fit { limit: true, .. }),
            "{levels} levels: auto chose {}",
            enc.header.transform.name()
        );
        assert_exact(&enc.bytes, &mesh, "shallow limit surface");
        let mut rough = surface.clone();
        rough.displace(0.05, 0.0, &mut Rng::new(7));
        let mesh = common::to_mesh(&rough, 1e6);
        let enc = encode(&mesh, &q, TransformChoice::Auto);
        assert!(
            !matches!(enc.header.transform, Transform::Fit { .. }),
            "{levels} levels, displaced: auto chose the fit"
        );
        assert_exact(&enc.bytes, &mesh, "shallow displaced surface");
    }
}

#[test]
fn kept_boundary_corners_are_found() {
    // An open sheet with Blender's "Keep Corners": its four corners stay, which plain
    // boundary rules would round off; the fit finds the rule, with and without the
    // limit surface.
    let (control, _) = subwave_corpus::folded_sheet();
    let q = subwave::Quantization::Decimal { decimals: 0 };
    for limit in [false, true] {
        let surface = control.subdivision_surface_with(3, &[], limit, Kept::Corners);
        let mesh = common::to_mesh(&surface, 1e6);
        let enc = encode(&mesh, &q, TransformChoice::Fit);
        assert!(
            matches!(
                enc.header.transform,
                Transform::Fit {
                    corners: true,
                    limit: l,
                    ..
                } if l == limit
            ),
            "limit {limit}: {:?}",
            enc.header.transform
        );
        assert_exact(&enc.bytes, &mesh, "kept corners");
        let (n, r) = (mesh.vertex_count(), residual_bytes(&enc.bytes));
        assert!(
            8 * r < n,
            "limit {limit}: {r} B of residuals for {n} vertices"
        );
        // The corners are where the control mesh's are.
        let plain = common::to_mesh(&control.subdivision_surface(3, &[], limit), 1e6);
        assert_ne!(plain.positions, mesh.positions);
    }
}

#[test]
fn a_sheet_is_fitted_on_its_own_control_mesh() {
    // A 4 x 4 sheet of quads, bent, refined four times on the limit with either
    // boundary rule (Blender's "Keep Corners" and "All"): a 65 x 65 grid, which the
    // recovery takes for one quad refined six times. The fit is tried with levels
    // left out and finds the 4 x 4 control mesh: near-zero residuals, exact.
    let mut control = subwave_corpus::open_grid(4, 4);
    for p in &mut control.positions {
        p[2] = 0.3 * (2.0 * p[0]).sin() * (1.5 * p[1]).cos();
    }
    let q = subwave::Quantization::Decimal { decimals: 0 };
    for kept in [Kept::Corners, Kept::Nothing] {
        let surface = control.subdivision_surface_with(4, &[], true, kept);
        let mesh = common::to_mesh(&surface, 1e6);
        let enc = encode(&mesh, &q, TransformChoice::Auto);
        let what = format!("{kept:?}");
        assert!(
            matches!(enc.header.transform, Transform::Fit { limit: true, .. }),
            "{what}: auto chose {}",
            enc.header.transform.name()
        );
        assert_eq!(enc.header.levels, 4, "{what}");
        assert_exact(&enc.bytes, &mesh, &what);
        let (n, r) = (mesh.vertex_count(), residual_bytes(&enc.bytes));
        assert!(8 * r < n, "{what}: {r} B of residuals for {n} vertices");
    }
}

/// A fit container whose header was changed to other rules (`what`) decodes to another
/// surface than `mesh`, or its residuals, coded for other predictions, run out.
fn assert_other_surface(bytes: &[u8], mesh: &Mesh, what: &str) {
    match subwave::decode_slice(bytes) {
        Ok(other) => assert_ne!(
            common::fingerprint(&other.mesh),
            common::fingerprint(mesh),
            "{what}: the same surface"
        ),
        Err(Error::CorruptLevel { .. }) => {}
        Err(e) => panic!("{what}: {e}"),
    }
}

#[test]
fn hostile_crease_lists_are_refused() {
    let (control, rims) = prism_and_rims();
    let mesh = common::to_mesh(&control.subdivision_surface(2, &rims, true), 1e5);
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let enc = encode(&mesh, &q, TransformChoice::Fit);
    assert!(!enc.header.creases.is_empty());
    let with_header = |h: &subwave::Header| common::with_header(&enc.bytes, h);
    assert!(subwave::decode_slice(&with_header(&enc.header)).is_ok());
    // An edge number the base mesh does not have (below the corner count, so only
    // the base mesh can tell), and one past every corner.
    for (e, what) in [
        (enc.header.base_corners as u32 - 1, "not a base edge"),
        (1000, "past"),
    ] {
        let mut h = enc.header.clone();
        h.creases = vec![e];
        match subwave::decode_slice(&with_header(&h)) {
            Err(err) => assert!(err.to_string().contains(what), "{e}: {err}"),
            Ok(_) => panic!("crease {e} decoded"),
        }
    }
    // Sharpnesses: in range they decode (to another mesh); 0, past infinitely sharp,
    // without creases, or a creased vertex past the base mesh's are malformed.
    let n = enc.header.creases.len();
    let one = 1u32 << 16;
    let mut h = enc.header.clone();
    h.crease_sharpness = vec![one * 3 / 2; n];
    h.vertex_creases = vec![0];
    h.vertex_sharpness = vec![one * 10];
    assert_other_surface(&with_header(&h), &mesh, "sharpnesses in range");
    let bad = |f: &dyn Fn(&mut subwave::Header), what: &str| {
        let mut h = enc.header.clone();
        f(&mut h);
        match subwave::decode_slice(&with_header(&h)) {
            Err(Error::Container(err)) => assert!(err.to_string().contains(what), "{err}"),
            other => panic!("{what}: {other:?}"),
        }
    };
    bad(&|h| h.crease_sharpness = vec![0; n], "crease sharpness 0");
    bad(
        &|h| h.crease_sharpness = vec![one * 10 + 1; n],
        "crease sharpness 655361",
    );
    bad(
        &|h| {
            h.creases.clear();
            h.crease_sharpness = vec![one];
        },
        "without creases",
    );
    bad(
        &|h| {
            h.vertex_creases = vec![h.base_vertices as u32];
            h.vertex_sharpness = vec![one];
        },
        "past",
    );
}

/// The prism's limit surface, four levels, cut at a seam as a PLY exporter cuts a mesh
/// at its UV seams: the top cap is its own piece (its five corners doubled), so every
/// vertex along its rim is written twice with the same values.
fn prism_cut_at_a_seam() -> Mesh {
    let (control, _) = prism_and_rims();
    let surface = control.subdivision_surface(4, &[], true);
    common::to_mesh(&subwave_corpus::cut_off(&control, &[1], &surface, 4), 1e5)
}

/// `mesh` (integers) coded by `--transform fit`, which must find the limit surface.
fn limit_fit(mesh: &Mesh) -> subwave::Encoded {
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let enc = encode(mesh, &q, TransformChoice::Fit);
    assert!(
        matches!(enc.header.transform, Transform::Fit { limit: true, .. }),
        "{:?}",
        enc.header.transform
    );
    enc
}

#[test]
fn surfaces_cut_at_seams_are_fitted_glued() {
    // Glued at its seam the cut surface is the fit's limit surface again: its residuals
    // are the rounding's, and it decodes exactly, every copy along the seam included.
    let mesh = prism_cut_at_a_seam();
    let enc = limit_fit(&mesh);
    assert_eq!(enc.header.seams.len(), 5, "{:?}", enc.header.seams);
    assert!(enc.header.seams.iter().all(|&(c, p)| p < c));
    assert_exact(&enc.bytes, &mesh, "cut at a seam");
    let n = mesh.vertex_count();
    let r = residual_bytes(&enc.bytes);
    assert!(8 * r < n, "{r} B of residuals for {n} vertices");
    // `auto` takes the glued fit too, and coarser levels decode (the glued
    // refinement, rounded) with every copy equal to its partner.
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let auto = encode(&mesh, &q, TransformChoice::Auto);
    assert_eq!(auto.header.seams, enc.header.seams);
    let coarse = subwave::decode(&enc.bytes, &common::up_to(1)).unwrap().mesh;
    for &(c, p) in &enc.header.seams {
        assert_eq!(coarse.positions[c as usize], coarse.positions[p as usize]);
    }
    // Without the seams the same fit misses along the cut.
    let mut h = enc.header.clone();
    h.seams.clear();
    assert_other_surface(&common::with_header(&enc.bytes, &h), &mesh, "without seams");
}

#[test]
fn blender_subdivision_exports_are_fitted_also_cut_at_seams() {
    // Blender's undisplaced subdivision exports (the dev set): the OBJs' geometry is a
    // fit on the limit surface, and so is the binary PLY's, which Blender cut at its UV
    // seam, glued there; each decodes to its own values, and its geometry sections
    // (base mesh and levels) stay under 4 bits per vertex. The cylinder (four levels,
    // Blender's default quality 3) takes OpenSubdiv's end caps from level 3.
    let Some(dir) = common::shared_corpus().map(|d| d.join("blender")) else {
        eprintln!("../shared/corpus not found; skipping");
        return;
    };
    for (name, cut, caps) in [
        ("cylinder8_crease_cc4.obj", false, Some(3)),
        ("vase_lathe_cc3_vcol.obj", false, None),
        ("vase_lathe_cc3_vcol.ply", true, None),
    ] {
        let bytes = std::fs::read(dir.join(name)).unwrap();
        let m = subwave::load(&bytes, None).unwrap();
        let mesh = m.mesh.without_attributes();
        let enc =
            subwave::encode_to_vec(&mesh, &m.quantization, &EncodeOptions::default()).unwrap();
        let h = &enc.header;
        assert!(
            matches!(h.transform, Transform::Fit { limit: true, .. }),
            "{name}: {}",
            h.transform.name()
        );
        assert_eq!(!h.seams.is_empty(), cut, "{name}: {:?}", h.seams);
        assert!(
            matches!(h.transform, Transform::Fit { end_caps, .. } if end_caps == caps),
            "{name}: {:?}",
            h.transform
        );
        assert_exact(&enc.bytes, &mesh, name);
        let info = subwave::inspect(&enc.bytes, &Default::default()).unwrap();
        let geometry: usize = info
            .sections
            .iter()
            .filter(|s| s.kind == "BASE" || s.kind == "LEVL")
            .map(|s| s.bytes)
            .sum();
        let n = mesh.vertex_count();
        assert!(
            8 * geometry < 4 * n,
            "{name}: {geometry} B for {n} vertices"
        );
    }
}

#[test]
fn pieces_that_touch_at_a_point_are_not_glued() {
    // Two limit-surface sheets, the second moved so that one of its corners lies on
    // one of the first's: their boundaries share a position but no edge, so there is no
    // seam to glue, and each is fitted on its own.
    let (control, _) = subwave_corpus::folded_sheet();
    let sheet = common::to_mesh(&control.subdivision_surface(3, &[], true), 1e5);
    let n = sheet.vertex_count();
    // Base vertices 0 and 5 are the sheet's corners (0, 0) and (1, 0).
    let t: [i64; 3] = std::array::from_fn(|k| sheet.positions[5][k] - sheet.positions[0][k]);
    let mut mesh = sheet.clone();
    mesh.positions.extend(
        sheet
            .positions
            .iter()
            .map(|p| std::array::from_fn(|k| p[k] + t[k])),
    );
    for f in sheet.iter_faces() {
        let moved: Vec<u32> = f.iter().map(|&v| v + n as u32).collect();
        mesh.push_face(&moved);
    }
    assert_eq!(mesh.positions[n], mesh.positions[5]);
    let enc = limit_fit(&mesh);
    assert!(enc.header.seams.is_empty(), "{:?}", enc.header.seams);
    assert_exact(&enc.bytes, &mesh, "two sheets touching");
}

#[test]
fn hostile_seam_lists_are_refused() {
    let mesh = prism_cut_at_a_seam();
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let enc = encode(&mesh, &q, TransformChoice::Fit);
    assert!(!enc.header.seams.is_empty());
    let decode = |f: &dyn Fn(&mut subwave::Header)| {
        let mut h = enc.header.clone();
        f(&mut h);
        subwave::decode_slice(&common::with_header(&enc.bytes, &h))
    };
    let malformed = |f: &dyn Fn(&mut subwave::Header), what: &str| match decode(f) {
        Err(Error::Container(err)) => assert!(err.to_string().contains(what), "{err}"),
        other => panic!("{what}: {other:?}"),
    };
    let nb = enc.header.base_vertices as u32;
    // A copy past the base mesh, a partner not below its copy.
    malformed(&|h| h.seams = vec![(nb, 0)], "past");
    malformed(&|h| h.seams = vec![(3, 3)], "partner");
    // Gluing a face's neighbouring corners (a repeated corner), or every base vertex
    // into one: corrupt, found when the base mesh is decoded.
    let base = subwave::decode(&enc.bytes, &common::up_to(0)).unwrap().mesh;
    let face = &base.faces[..base.face_starts[1] as usize];
    let (a, b) = (face[0].min(face[1]), face[0].max(face[1]));
    for seams in [vec![(b, a)], (1..nb).map(|c| (c, c - 1)).collect()] {
        let what = format!("{} seams", seams.len());
        match decode(&|h| h.seams = seams.clone()) {
            Err(e) => assert!(e.to_string().contains("glued"), "{what}: {e}"),
            Ok(_) => panic!("{what} decoded"),
        }
    }
    // A creased vertex the glued mesh does not have (the last base vertices are
    // copies).
    match decode(&|h| {
        h.vertex_creases = vec![nb - 1];
        h.vertex_sharpness = vec![1 << 16];
    }) {
        Err(e) => assert!(e.to_string().contains("not a base vertex"), "{e}"),
        Ok(_) => panic!("a creased vertex past the glued mesh decoded"),
    }
}

#[test]
fn fits_near_the_coordinate_limit_keep_their_values_in_range() {
    // Values near 2^44: the control values of B = 8 and 10 would pass 2^52, so fewer
    // extra bits are taken, and the mesh still decodes exactly.
    let mut control = subwave_corpus::mixed_polygons();
    control.displace(0.2, 0.05, &mut Rng::new(3));
    let mesh = common::to_mesh(&control.refined(2), (1u64 << 43) as f64);
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let enc = encode(&mesh, &q, TransformChoice::Fit);
    match enc.header.transform {
        Transform::Fit { bits, .. } => assert!(bits <= 6, "{bits}"),
        t => panic!("expected a fit, got {}", t.name()),
    }
    assert_exact(&enc.bytes, &mesh, "near 2^44");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Random subdivided models (a random control mesh, refined 1 to 3 times, then a
    /// random fraction of vertices nudged) round trip exactly through the fit and auto.
    #[test]
    fn random_subdivided_models_round_trip(
        seed in any::<u64>(),
        levels in 1u32..=3,
        scale in prop_oneof![Just(1e2), Just(1e5), Just(1e9)],
        nudge in 0usize..50,
        open in any::<bool>(),
    ) {
        let mut rng = Rng::new(seed);
        let mut control = if open {
            subwave_corpus::open_grid(3, 2)
        } else {
            subwave_corpus::mixed_polygons()
        };
        control.displace(0.3, 0.2, &mut rng);
        let mut fine = common::to_mesh(&control.refined(levels), scale);
        let n = fine.positions.len();
        for _ in 0..nudge {
            let i = rng.below(n);
            fine.positions[i][rng.below(3)] += rng.below(7) as i64 - 3;
        }
        let q = subwave::Quantization::Decimal { decimals: 0 };
        for t in [TransformChoice::Fit, TransformChoice::Auto] {
            let enc = encode(&fine, &q, t);
            let dec = subwave::decode_slice(&enc.bytes).unwrap();
            prop_assert_eq!(common::fingerprint(&dec.mesh), common::fingerprint(&fine));
            // A changed byte: an error or some mesh, never a panic.
            let mut bad = enc.bytes.clone();
            let i = rng.below(bad.len());
            bad[i] ^= 1 << rng.below(8);
            let _ = subwave::decode_slice(&bad);
        }
    }
}

/// Two UV charts cut at their seams (a jittered 5 x 4 grid and a strip beside it),
/// flat (the third axis 0, as ATTR codes a UV map).
fn uv_charts() -> subwave_corpus::PolyMesh {
    let mut rng = Rng::new(9);
    let mut chart = subwave_corpus::open_grid(5, 4);
    for p in &mut chart.positions {
        p[0] += 0.04 * (rng.unit() - 0.5);
        p[1] += 0.04 * (rng.unit() - 0.5);
    }
    let strip = subwave_corpus::translate(subwave_corpus::open_grid(6, 1), [1.3, 0.0, 0.0]);
    subwave_corpus::union(&[chart, strip])
}

#[test]
fn each_uv_smoothing_option_is_found_and_codes_to_near_zero_residuals() {
    // Blender's UV smoothing options other than "Keep Boundaries" (below), each made
    // by the project's own evaluation of its rules on the same charts: "None" (linear
    // everywhere), "All" (smooth corners, kept on the limit), "Keep Corners", and
    // "Keep Corners, Junctions" (two boundary vertices where other charts would meet
    // this one, kept: vertex creases the encoder finds). `auto` finds each rule,
    // decodes exactly, and leaves under a bit per vertex of residuals.
    let control = uv_charts();
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let junctions: &[(u32, f64)] = &[(2, 10.0), (12, 10.0)];
    let cases = [
        ("none", Kept::Everything, &[][..], false),
        ("all", Kept::LimitCorners, &[], true),
        ("keep corners", Kept::Corners, &[], true),
        ("keep corners, junctions", Kept::Corners, junctions, true),
    ];
    let mut made = Vec::new();
    for (what, kept, vertices, limit) in cases {
        let surface = control.subdivision_surface_sharp(3, &[], vertices, limit, kept);
        let mesh = common::to_mesh(&surface, 1e6);
        assert!(
            !made.contains(&mesh.positions),
            "{what}: another option's surface"
        );
        made.push(mesh.positions.clone());
        let enc = encode(&mesh, &q, TransformChoice::Auto);
        let Transform::Fit {
            limit: l,
            corners,
            bilinear,
            limit_corners,
            ..
        } = enc.header.transform
        else {
            panic!("{what}: not a fit but {:?}", enc.header.transform)
        };
        assert_eq!(
            (l, bilinear, limit_corners, corners),
            (
                limit,
                kept == Kept::Everything,
                kept == Kept::LimitCorners,
                kept == Kept::Corners
            ),
            "{what}"
        );
        assert_eq!(enc.header.vertex_creases.len(), vertices.len(), "{what}");
        assert_exact(&enc.bytes, &mesh, what);
        let (n, r) = (mesh.vertex_count(), residual_bytes(&enc.bytes));
        assert!(8 * r < n, "{what}: {r} B of residuals for {n} vertices");
    }
}

#[test]
fn uv_charts_with_linear_boundaries_are_found_by_auto() {
    // A UV map as Blender's Subdivision Surface writes it (UV Smooth "Keep
    // Boundaries"): charts cut at their seams, every boundary vertex kept, the limit
    // surface inside (`uv_charts`): `auto` tries that rule set, finds it, and the
    // residuals cost next to nothing; the other rules predict it worse.
    let control = uv_charts();
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let surface = control.subdivision_surface_with(3, &[], true, Kept::Boundary);
    let mesh = common::to_mesh(&surface, 1e6);
    assert!(mesh.positions.iter().all(|p| p[2] == 0));
    let enc = encode(&mesh, &q, TransformChoice::Auto);
    assert!(
        matches!(
            enc.header.transform,
            Transform::Fit {
                linear: true,
                limit: true,
                ..
            }
        ),
        "{:?}",
        enc.header.transform
    );
    assert_exact(&enc.bytes, &mesh, "linear boundaries");
    let (n, r) = (mesh.vertex_count(), residual_bytes(&enc.bytes));
    assert!(8 * r < n, "{r} B of residuals for {n} vertices");
    // Kept corners alone (B-spline boundaries between them) are another surface.
    let corners = control.subdivision_surface_with(3, &[], true, Kept::Corners);
    assert_ne!(common::to_mesh(&corners, 1e6).positions, mesh.positions);
}

/// Edge and vertex creases on one mesh, as a modelling tool's user sets them (a face's
/// edges and two corners elsewhere; Blender's `cube_mixed_creases` in the rules set):
/// the creased corners pull the smooth surface off along their own edges too, so the
/// edge sets found from the smooth surface miss. The fit finds the four edges and the
/// two corners (from the vertex creases' fit), decodes exactly and codes to near-zero
/// residuals.
#[test]
fn edge_and_vertex_creases_together_are_found() {
    let control = subwave_corpus::cube();
    // The top face's edges (z = 0.5: vertices 4 to 7) and two bottom corners.
    let top: Vec<([u32; 2], f64)> = [[4, 5], [5, 7], [7, 6], [6, 4]]
        .iter()
        .map(|&e| (e, 3.0))
        .collect();
    let corners = [(0, 3.0), (2, 3.0)];
    let surface = control.subdivision_surface_sharp(4, &top, &corners, true, Kept::Nothing);
    let mesh = common::to_mesh(&surface, 1e5);
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let enc = encode(&mesh, &q, TransformChoice::Fit);
    let what = "cube with creased top edges and two creased corners";
    assert!(
        matches!(enc.header.transform, Transform::Fit { limit: true, .. }),
        "{what}: {:?}",
        enc.header.transform
    );
    assert_eq!(enc.header.creases.len(), 4, "{what}");
    assert_eq!(enc.header.vertex_creases.len(), 2, "{what}");
    exact_with_near_zero_residuals(&enc, &mesh, what);
}

#[test]
fn end_cap_patches_are_found_at_each_quality() {
    // Surfaces made by the codec's own integer rules with OpenSubdiv's end caps
    // (Gregory patches beside extraordinary vertices, Blender's Quality) from level 1
    // and from level 3, four levels: `auto` finds the end caps' level (and a sharp
    // corner, and creases that outlast the level), the container decodes exactly and
    // its residuals are near zero.
    use subwave_codec::topology::{Level, Topo};
    use subwave_codec::transform::fit::{refine, Rules};
    let (control, _) = prism_and_rims();
    let mut t = Topo::new(control.positions.len());
    for f in &control.faces {
        t.push(f);
    }
    let mut levels = Vec::new();
    for _ in 0..4 {
        let l = Level::new(&t).unwrap();
        t = l.fine();
        levels.push(l);
    }
    let finest = levels.last().unwrap().next();
    // (And from level 3 with an infinitely sharp vertex: OpenSubdiv's sharp corner.)
    let mut corner = vec![0; control.positions.len()];
    corner[0] = subwave_codec::transform::fit::SHARP_INFINITE;
    // (And from level 3 with the rims creased at 4.5 levels, past it: OpenSubdiv drops
    // what is left there and makes their faces end caps.)
    let (_, rims) = prism_and_rims();
    let base = &levels[0];
    let rim_sharpness: Vec<u32> = base
        .edges
        .iter()
        .map(|&[a, b]| {
            let rim = rims
                .iter()
                .any(|&[c, d]| (a, b) == (c, d) || (a, b) == (d, c));
            if rim {
                subwave_codec::transform::fit::SHARP_ONE * 9 / 2
            } else {
                0
            }
        })
        .collect();
    for (q, vertex_sharpness, sharpness) in [
        (1u8, Vec::new(), Vec::new()),
        (3, Vec::new(), Vec::new()),
        (3, corner, Vec::new()),
        (3, Vec::new(), rim_sharpness),
    ] {
        let corners = vertex_sharpness.len().min(1);
        let creases = sharpness.iter().filter(|&&s| s > 0).count();
        let rules = Rules {
            limit: true,
            end_caps: Some(q),
            vertex_sharpness,
            sharpness,
            ..Rules::default()
        };
        let mut x: [Vec<i64>; 3] = std::array::from_fn(|k| {
            control
                .positions
                .iter()
                .map(|p| (p[k] * 1e5 * 256.0).round() as i64)
                .collect()
        });
        // (Refined at 8 extra bits and rounded, as a fit at 8 bits predicts.)
        refine(&levels, &finest, &rules, &mut x).unwrap();
        let mut mesh = Mesh::new();
        mesh.positions = (0..finest.nv)
            .map(|v| std::array::from_fn(|k| (x[k][v] + 128) >> 8))
            .collect();
        for f in 0..t.nf() {
            mesh.push_face(t.face(f));
        }
        let q0 = subwave::Quantization::Decimal { decimals: 0 };
        let enc = encode(&mesh, &q0, TransformChoice::Auto);
        assert!(
            matches!(enc.header.transform, Transform::Fit { limit: true, end_caps: Some(e), .. } if e == q),
            "quality {q}: {:?}",
            enc.header.transform
        );
        assert_eq!(enc.header.vertex_creases.len(), corners, "quality {q}");
        assert_eq!(enc.header.creases.len(), creases, "quality {q}");
        exact_with_near_zero_residuals(&enc, &mesh, &format!("end caps from level {q}"));
    }
}

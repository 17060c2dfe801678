//! Per-axis value maps (SPEC.md 3.1): axes whose values are sparse in their range are
//! coded as ranks when that is smaller; every path (flat, Catmull-Clark, sqrt(2), polar,
//! fit) decodes exactly through a map; coarser levels; hostile maps are refused.

mod common;

use std::path::Path;

use subwave::{EncodeOptions, Error, Limits, Mesh};
use subwave_container::{Container, ContainerWriter, SectionKind};

fn own(name: &str, bits: Option<u8>) -> subwave::Loaded {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("corpus")
        .join(name);
    subwave::load(&std::fs::read(path).unwrap(), bits).unwrap()
}

fn encode(m: &subwave::Loaded, value_map: Option<bool>, keep_order: bool) -> subwave::Encoded {
    let opts = EncodeOptions {
        value_map,
        keep_order,
        ..Default::default()
    };
    subwave::encode_to_vec(&m.mesh, &m.quantization, &opts).unwrap()
}

/// A terrain: a (2^k + 1)^2 grid with spacings that are no whole number of grid steps
/// and heights in whole metres, as a DEM stores them; quantised to `bits`.
fn terrain(k: u32, bits: u8) -> subwave::Loaded {
    let n = (1usize << k) + 1;
    let mut obj = String::new();
    for r in 0..n {
        for c in 0..n {
            let (x, y) = (c as f64 * 74.484353, r as f64 * 92.116667);
            let h = 500.0
                + 40.0 * ((c as f64) * 0.11).sin() * ((r as f64) * 0.07).cos()
                + ((r * 7 + c * 13) % 5) as f64;
            obj += &format!("v {x:.6} {y:.6} {:.0}\n", h.round());
        }
    }
    for r in 0..n - 1 {
        for c in 0..n - 1 {
            let v = |r: usize, c: usize| r * n + c + 1;
            obj += &format!(
                "f {} {} {} {}\n",
                v(r, c),
                v(r, c + 1),
                v(r + 1, c + 1),
                v(r + 1, c)
            );
        }
    }
    subwave::load(obj.as_bytes(), Some(bits)).unwrap()
}

#[test]
fn a_terrain_is_coded_as_ranks_and_decodes_exactly() {
    for bits in [16, 12] {
        let m = terrain(6, bits);
        let auto = encode(&m, None, true);
        let off = encode(&m, Some(false), true);
        assert!(auto.header.has_value_map, "Q{bits}: auto kept no map");
        assert!(!off.header.has_value_map);
        assert!(
            auto.bytes.len() < off.bytes.len(),
            "Q{bits}: {} vs {}",
            auto.bytes.len(),
            off.bytes.len()
        );
        assert_eq!(auto.sections[1].kind, "VMAP");
        for enc in [&auto, &off] {
            let dec = subwave::decode_slice(&enc.bytes).unwrap();
            assert!(dec.input_order);
            assert_eq!(dec.mesh, m.mesh, "Q{bits}");
        }
    }
}

#[test]
fn every_path_decodes_exactly_through_a_map() {
    // Catmull-Clark, polar, sqrt(2), the fit, and (levels 0) the flat path.
    for (name, levels) in [
        ("cube_cc4.obj", 16),
        ("open_cc2.obj", 16),
        ("sphere_polar3.obj", 16),
        ("prism_sqrt2_5.obj", 16),
        ("subdivided_cc3.obj", 16),
        ("unstructured.obj", 16),
        ("mixed_cc2.obj", 0),
    ] {
        for bits in [None, Some(16), Some(9)] {
            let m = own(name, bits);
            let opts = EncodeOptions {
                value_map: Some(true),
                keep_order: true,
                max_levels: levels,
                ..Default::default()
            };
            let enc = subwave::encode_to_vec(&m.mesh, &m.quantization, &opts).unwrap();
            assert!(enc.header.has_value_map, "{name}");
            let dec = subwave::decode_slice(&enc.bytes).unwrap();
            assert_eq!(dec.mesh, m.mesh, "{name} {bits:?}");
            // Without keeping the order, the same mesh up to order.
            let opts = EncodeOptions {
                keep_order: false,
                ..opts
            };
            let enc = subwave::encode_to_vec(&m.mesh, &m.quantization, &opts).unwrap();
            let dec = subwave::decode_slice(&enc.bytes).unwrap();
            assert_eq!(
                common::fingerprint(&dec.mesh),
                common::fingerprint(&m.mesh),
                "{name} {bits:?}"
            );
        }
    }
}

#[test]
fn coarser_levels_take_values_from_the_map() {
    let m = terrain(5, 16);
    // The lazy wavelet interpolates, so every coarser level is a subset of the vertices
    // (`auto` may choose an approximating transform).
    let opts = EncodeOptions {
        value_map: Some(true),
        transform: subwave::TransformChoice::Fixed(subwave::Wavelet::Lazy),
        ..Default::default()
    };
    let enc = subwave::encode_to_vec(&m.mesh, &m.quantization, &opts).unwrap();
    assert!(enc.header.levels >= 3);
    let axis = |k: usize| {
        let mut v: Vec<i64> = m.mesh.positions.iter().map(|p| p[k]).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let values = [axis(0), axis(1), axis(2)];
    for level in 0..enc.header.levels {
        let dec = subwave::decode(&enc.bytes, &common::up_to(level)).unwrap();
        assert_eq!(dec.level, level);
        for p in &dec.mesh.positions {
            for k in 0..3 {
                assert!(
                    values[k].binary_search(&p[k]).is_ok(),
                    "level {level}: {p:?}"
                );
            }
        }
    }
    // The base mesh's corners are the terrain's corners.
    let base = subwave::decode(&enc.bytes, &common::up_to(0)).unwrap();
    let mut corners = base.mesh.positions.clone();
    corners.sort_unstable();
    let mut want: Vec<[i64; 3]> = [0, 32, 33 * 32, 33 * 33 - 1]
        .iter()
        .map(|&i| m.mesh.positions[i])
        .collect();
    want.sort_unstable();
    assert_eq!(corners, want);
}

/// `enc`'s container with its VMAP payload replaced.
fn with_vmap(enc: &subwave::Encoded, payload: &[u8]) -> Vec<u8> {
    let c = Container::parse(&enc.bytes, &Limits::default()).unwrap();
    let mut w = ContainerWriter::new();
    for s in &c.sections {
        if s.kind == SectionKind::END {
            continue;
        }
        let p = if s.kind == SectionKind::VALUE_MAP {
            payload
        } else {
            s.payload
        };
        w.section(s.kind, p);
    }
    w.finish()
}

#[test]
fn hostile_value_maps_are_refused() {
    let m = terrain(4, 16);
    let enc = encode(&m, Some(true), false);
    let bad = |bytes: &[u8], what: &str| match subwave::decode_slice(bytes) {
        Err(Error::CorruptStream { .. }) | Err(Error::Container(_)) => {}
        other => panic!("{what}: expected a corrupt container, got {other:?}"),
    };
    // A map of one value per axis: ranks past its end.
    let one = subwave_codec::sections::vmap::ValueMap {
        axes: [Some(vec![7]), Some(vec![7]), Some(vec![7])],
    };
    bad(&with_vmap(&enc, &one.encode()), "ranks outside the map");
    // More values than vertices.
    let nv = m.mesh.vertex_count() as i64;
    let many = subwave_codec::sections::vmap::ValueMap {
        axes: [Some((0..=nv).collect()), None, None],
    };
    bad(&with_vmap(&enc, &many.encode()), "too many values");
    // Garbage and an empty payload.
    bad(&with_vmap(&enc, &[0x5a; 12]), "garbage");
    bad(&with_vmap(&enc, &[]), "empty");
    // The section missing, or where the base mesh belongs.
    let c = Container::parse(&enc.bytes, &Limits::default()).unwrap();
    let mut w = ContainerWriter::new();
    for s in c
        .sections
        .iter()
        .filter(|s| s.kind != SectionKind::VALUE_MAP && s.kind != SectionKind::END)
    {
        w.section(s.kind, s.payload);
    }
    bad(&w.finish(), "no VMAP");
    // Every single flipped byte: an error or the mesh, never a panic.
    for i in 12..enc.bytes.len() {
        let mut b = enc.bytes.clone();
        b[i] ^= 0x21;
        let _ = subwave::decode_slice(&b);
    }
    // An unknown flag is unsupported.
    let mut head = c.sections[0].payload.to_vec();
    let h = subwave::Header::read(&head, 0, &Limits::default()).unwrap();
    assert!(h.has_value_map);
    head = h.write();
    // The flags varint comes right before the end of a Catmull-Clark header.
    let at = head.len() - 1;
    assert_eq!(head[at], 2);
    head[at] = 2 | 64;
    match subwave::Header::read(&head, 0, &Limits::default()) {
        Err(Error::Unsupported(what)) => assert!(what.contains("flags"), "{what}"),
        other => panic!("expected unsupported, got {other:?}"),
    }
}

#[test]
fn every_flipped_bit_or_cut_of_a_lattice_map_is_an_error_or_a_valid_mesh() {
    // At 16 bits a terrain's whole-metre heights lie on a lattice, coded as one (format
    // 23, SPEC.md 3.1; its rows and columns, 17 each, code smaller as gaps): the VMAP
    // payload flipped bit by bit and cut byte by byte, checksums valid.
    let m = terrain(4, 16);
    let enc = encode(&m, Some(true), true);
    let d = subwave::decode_slice(&enc.bytes).unwrap();
    assert_eq!(d.mesh.positions, m.mesh.positions);
    let c = Container::parse(&enc.bytes, &Limits::default()).unwrap();
    let map = c
        .sections
        .iter()
        .find(|s| s.kind == SectionKind::VALUE_MAP)
        .unwrap()
        .payload
        .to_vec();
    let mut changed = 0;
    let mut check = |payload: &[u8]| {
        if let Ok(d) = subwave::decode_slice(&with_vmap(&enc, payload)) {
            d.mesh.validate().unwrap();
            changed += (d.mesh.positions != m.mesh.positions) as usize;
        }
    };
    for bit in 0..map.len() * 8 {
        let mut p = map.clone();
        p[bit / 8] ^= 1 << (bit % 8);
        check(&p);
    }
    for len in 0..map.len() {
        check(&map[..len]);
    }
    // Some of the edits decode to other meshes: the map is read, not skipped.
    assert!(changed > 0);
}

/// How many hierarchy codings (each reports its coarsest level once) an encode of `m`
/// at `effort` with `value_map` makes, and its container.
fn codings(m: &subwave::Loaded, value_map: Option<bool>, effort: u8) -> (usize, Vec<u8>) {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    let count = Arc::new(AtomicUsize::new(0));
    let seen = count.clone();
    let opts = EncodeOptions {
        value_map,
        effort,
        keep_order: true,
        threads: 1,
        progress: subwave::Progress::new(move |s| {
            if let subwave::Stage::Level { level: 1, .. } = s {
                seen.fetch_add(1, Ordering::Relaxed);
            }
        }),
        ..Default::default()
    };
    let out = subwave::encode_to_vec(&m.mesh, &m.quantization, &opts).unwrap();
    (count.load(Ordering::Relaxed), out.bytes)
}

/// At the default effort a terrain whose ranks' details estimate well below its
/// values' is coded once, as ranks (the same container as a map asked for), where
/// effort 9 codes both and keeps the smaller; both decode exactly. (129 x 129: above
/// the size up to which the fit's screen lets a smooth mesh's values through.)
#[test]
fn the_default_effort_chooses_the_map_by_estimate() {
    let m = terrain(7, 16);
    let (forced, forced_bytes) = codings(&m, Some(true), subwave::DEFAULT_EFFORT);
    let (auto, auto_bytes) = codings(&m, None, subwave::DEFAULT_EFFORT);
    let (nine, nine_bytes) = codings(&m, None, 9);
    let (forced9, _) = codings(&m, Some(true), 9);
    assert!(forced > 0);
    assert_eq!(auto, forced, "codings at the default effort");
    assert_eq!(auto_bytes, forced_bytes);
    assert!(nine > forced9, "effort 9 codes both: {nine} vs {forced9}");
    assert!(nine_bytes.len() <= auto_bytes.len());
    for bytes in [&auto_bytes, &nine_bytes] {
        assert!(subwave::decode_slice(bytes).unwrap().mesh == m.mesh);
    }
}

#[test]
fn corpus_grids_are_mapped_and_decode_exactly() {
    let Some(dir) = common::shared_corpus() else {
        eprintln!("../shared/corpus not found: skipped");
        return;
    };
    let path = dir.join("jacksboro_grid65.obj");
    let Ok(bytes) = std::fs::read(&path) else {
        eprintln!("{} not found: skipped", path.display());
        return;
    };
    for bits in [16, 12] {
        let m = subwave::load(&bytes, Some(bits)).unwrap();
        let auto = encode(&m, None, true);
        let off = encode(&m, Some(false), true);
        assert!(auto.header.has_value_map, "Q{bits}");
        assert!(auto.bytes.len() < off.bytes.len(), "Q{bits}");
        let dec = subwave::decode_slice(&auto.bytes).unwrap();
        assert_eq!(dec.mesh, m.mesh, "Q{bits}");
    }
}

#[test]
fn meshes_without_sparse_axes_are_unchanged() {
    // Dense axes: no candidate, so auto writes exactly what "off" writes.
    let mut mesh = Mesh::new();
    mesh.positions = vec![[0, 0, 0], [1, 0, 1], [1, 1, 2], [0, 1, 1]];
    mesh.push_face(&[0, 1, 2, 3]);
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let a = subwave::encode_to_vec(&mesh, &q, &EncodeOptions::default()).unwrap();
    let opts = EncodeOptions {
        value_map: Some(false),
        ..Default::default()
    };
    let b = subwave::encode_to_vec(&mesh, &q, &opts).unwrap();
    assert_eq!(a.bytes, b.bytes);
    assert!(!a.header.has_value_map);
}

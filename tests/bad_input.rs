//! Malformed containers and mesh files each give a specific error, never a panic.

mod common;

use subwave::{DecodeOptions, EncodeOptions, Error, Limits};
use subwave_container::{ContainerWriter, SectionKind, PREAMBLE_LEN};

fn sample() -> Vec<u8> {
    let obj = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0.5\nv 2 0 0\nf 1 2 3 4\nf 2 5 3\n";
    let m = subwave::load(obj, None).unwrap();
    subwave::encode_to_vec(
        &m.mesh,
        &m.quantization,
        &EncodeOptions {
            keep_order: true,
            ..Default::default()
        },
    )
    .unwrap()
    .bytes
}

fn container_err(bytes: &[u8]) -> subwave_container::Error {
    match subwave::decode_slice(bytes) {
        Err(Error::Container(e)) => e,
        other => panic!("expected a container error, got {other:?}"),
    }
}

#[test]
fn wrong_magic() {
    let mut b = sample();
    b[1] = b'X';
    assert_eq!(container_err(&b), subwave_container::Error::BadMagic);
    assert_eq!(
        container_err(b"v 0 0 0\n"),
        subwave_container::Error::BadMagic
    );
    assert_eq!(container_err(b""), subwave_container::Error::BadMagic);
}

#[test]
fn newer_format_version() {
    let mut b = sample();
    b[8..10].copy_from_slice(&(subwave::FORMAT_VERSION + 1).to_le_bytes());
    assert!(matches!(
        container_err(&b),
        subwave_container::Error::NewerVersion { found, .. } if found == subwave::FORMAT_VERSION + 1
    ));
}

/// Before the first release only the current format is read: a container of an older
/// development format (a current container with its version field set to an older one)
/// is refused with an error that names its version, not misread.
#[test]
fn older_format_versions_are_refused_by_name() {
    for old in [1u16, 18, 25] {
        let mut b = sample();
        b[8..10].copy_from_slice(&old.to_le_bytes());
        let e = subwave::decode_slice(&b).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(&format!("format version {old} "))
                && text.contains(&format!("format {} only", subwave::FORMAT_VERSION)),
            "{text}"
        );
        assert!(subwave::inspect(&b, &Limits::default()).is_err());
    }
}

#[test]
fn every_truncation_is_rejected() {
    let b = sample();
    for n in 0..b.len() {
        match subwave::decode_slice(&b[..n]) {
            Err(Error::Container(
                subwave_container::Error::Truncated { .. } | subwave_container::Error::BadMagic,
            )) => {}
            other => panic!("cut at {n} of {}: {other:?}", b.len()),
        }
    }
}

#[test]
fn every_bit_flip_is_rejected() {
    let b = sample();
    for bit in 0..b.len() * 8 {
        let mut x = b.clone();
        x[bit / 8] ^= 1 << (bit % 8);
        assert!(
            subwave::decode_slice(&x).is_err(),
            "flip of bit {bit} decoded silently"
        );
    }
}

/// A container with a valid checksum around a header declaring `vertices`.
fn with_header(vertices: u64, faces: u64, corners: u64) -> Vec<u8> {
    let mut h = subwave_container::ByteWriter::new();
    for v in [vertices, faces, corners, vertices, faces, corners] {
        h.varint(v);
    }
    h.out.extend_from_slice(&[0, 0, 0, 0, 6, 1, 0]);
    let mut w = ContainerWriter::new();
    w.section(SectionKind::HEADER, &h.out);
    w.section(SectionKind::BASE, &[0; 8]);
    w.finish()
}

#[test]
fn huge_declared_counts_hit_limits_before_allocation() {
    let b = with_header(1 << 40, 1, 3);
    assert!(matches!(
        container_err(&b),
        subwave_container::Error::Limit { what: "vertices", requested, .. } if requested == 1 << 40
    ));
    let b = with_header(10, 1 << 35, 3 << 35);
    assert!(matches!(
        container_err(&b),
        subwave_container::Error::Limit { what: "faces", .. }
    ));
    // Within the default limits but over tight ones.
    let b = with_header(1 << 24, 1 << 24, 1 << 26);
    let tight = DecodeOptions {
        limits: Limits::tight(),
        ..DecodeOptions::default()
    };
    assert!(matches!(
        subwave::decode(&b, &tight),
        Err(Error::Container(subwave_container::Error::Limit { .. }))
    ));
}

#[test]
fn lying_counts_are_corrupt_not_a_panic() {
    // Plausible counts over a stream of zeros: the decoder runs out of consistent data.
    for (v, f, c) in [(4, 1, 4), (100, 50, 200), (3, 0, 0), (5, 2, 7)] {
        let b = with_header(v, f, c);
        match subwave::decode_slice(&b) {
            Err(Error::CorruptStream { .. }) | Err(Error::Container(_)) => {}
            Ok(d) => {
                // Any mesh that does come out must at least be well formed.
                d.mesh.validate().unwrap();
            }
            Err(e) => panic!("unexpected error {e}"),
        }
    }
}

#[test]
fn section_order_is_enforced() {
    let b = sample();
    // Drop the BASE section: HEAD then ORDR.
    let c = subwave_container::Container::parse(&b, &Limits::default()).unwrap();
    let mut w = ContainerWriter::new();
    for s in &c.sections {
        if s.kind != SectionKind::BASE && s.kind != SectionKind::END {
            w.section(s.kind, s.payload);
        }
    }
    assert!(matches!(
        container_err(&w.finish()),
        subwave_container::Error::Malformed { .. }
    ));
    assert!(b.len() > PREAMBLE_LEN);
}

fn mesh_err(text: &[u8]) -> String {
    match subwave::load(text, None) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("{} loaded", String::from_utf8_lossy(text)),
    }
}

#[test]
fn bad_mesh_files() {
    assert!(mesh_err(b"v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").contains("not a finite number"));
    assert!(mesh_err(b"v 0 0 inf\n").contains("not a finite number"));
    assert!(mesh_err(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").contains("refers to vertex 4"));
    // An OBJ face of two corners is a line, not a polygon: reported, not coded.
    let line = subwave::load(b"v 0 0 0\nv 1 0 0\nf 1 2\n", None).unwrap();
    assert_eq!(line.mesh.face_count(), 0);
    assert!(line.dropped.iter().any(|d| d.contains("fewer than 3")));
    assert!(mesh_err(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n").contains("at least 3"));
    // STL: a solid that never ends, a vertex of two numbers, an unknown statement.
    assert!(mesh_err(b"solid a\nfacet normal 0 0 1\n").contains("ends inside a solid"));
    assert!(mesh_err(b"solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0\n").contains("needs 3"));
    assert!(mesh_err(
        b"solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n"
    )
    .contains("at least 3"));
    assert!(mesh_err(b"solid a\nbogus\nendsolid a\n").contains("unexpected 'bogus'"));
    // A binary STL with a NaN corner.
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&1u32.to_le_bytes());
    for x in [0f32, 0., 1., 0., 0., 0., 1., 0., 0., f32::NAN, 1., 0.] {
        stl.extend_from_slice(&x.to_le_bytes());
    }
    stl.extend_from_slice(&[0, 0]);
    assert!(mesh_err(&stl).contains("not a finite number"));
    // One byte short of its count: neither a binary STL nor text.
    stl.pop();
    assert!(!mesh_err(&stl).is_empty());
    assert!(mesh_err(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n").contains("out of range"));
    assert!(mesh_err(b"v 0 0\n").contains("needs 3"));
    assert!(mesh_err(b"ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n")
        .contains("more than the"));
    assert!(mesh_err(b"OFF\n4000000000 1 0\n0 0 0\n").contains("more than the file"));
    assert!(mesh_err(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n").contains("below 3"));
    let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    for v in [[0f32, 0., 0.], [1., 0., 0.], [f32::NAN, 1., 0.]] {
        for c in v {
            ply.extend_from_slice(&c.to_le_bytes());
        }
    }
    ply.push(3);
    for i in [0i32, 1, 2] {
        ply.extend_from_slice(&i.to_le_bytes());
    }
    assert!(mesh_err(&ply).contains("NaN"));
    // Exact values no decimal grid in the range holds: the floats they denote.
    let m = subwave::load(b"v 1e30 1e-30 0\n", None).unwrap();
    assert_eq!(
        m.mesh.floats,
        vec![[1e30f32, 1e-30, 0.0].map(|x| x.to_bits() as u64)]
    );
}

#[test]
fn counts_within_limits_but_beyond_the_bytes_are_refused_before_allocation() {
    // 2^26 vertices and faces fit the default count limits, but a container of a few
    // dozen bytes may not ask for gigabytes (SPEC.md 2.5, the expansion guard) ...
    let b = with_header(1 << 26, 1 << 26, 1 << 28);
    let start = std::time::Instant::now();
    match subwave::decode_slice(&b) {
        Err(Error::Container(subwave_container::Error::Limit { what, .. })) => {
            assert!(what.contains("max_expansion"), "{what}")
        }
        other => panic!("expected the expansion limit, got {other:?}"),
    }
    // ... and with that guard lifted, 8 bytes of BASE still cannot hold them (SPEC.md
    // 2.6): refused at once, without reserving gigabytes.
    let mut limits = Limits::default();
    limits.max_expansion = u64::MAX;
    let opts = DecodeOptions {
        limits,
        ..DecodeOptions::default()
    };
    match subwave::decode(&b, &opts) {
        Err(Error::CorruptStream {
            section: "BASE",
            what,
        }) => assert!(what.contains("cannot hold"), "{what}"),
        other => panic!("expected a density error, got {other:?}"),
    }
    assert!(start.elapsed().as_secs() < 5);
}

#[test]
fn streams_that_run_out_are_corrupt() {
    // Plausible counts, a payload of random words: decoding stops at the end of the data
    // instead of inventing symbols from nothing.
    let mut h = subwave_container::ByteWriter::new();
    for v in [3000u64, 3000, 12000, 3000, 3000, 12000] {
        h.varint(v);
    }
    h.out.extend_from_slice(&[0, 0, 0, 0, 6, 1, 0]);
    let mut w = ContainerWriter::new();
    w.section(SectionKind::HEADER, &h.out);
    let noise: Vec<u8> = (0..64u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    w.section(SectionKind::BASE, &noise);
    assert!(matches!(
        subwave::decode_slice(&w.finish()),
        Err(Error::CorruptStream { .. })
    ));
}

fn hierarchical_sample() -> Vec<u8> {
    let mut rng = subwave_corpus::Rng::new(5);
    let mut p = subwave_corpus::mixed_polygons().refined(2);
    p.displace(0.03, 0.001, &mut rng);
    let text = p.to_obj(4);
    let m = subwave::load(text.as_bytes(), None).unwrap();
    let enc = subwave::encode_to_vec(
        &m.mesh,
        &m.quantization,
        &EncodeOptions {
            keep_order: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(enc.header.levels, 2);
    enc.bytes
}

#[test]
fn every_bit_flip_of_a_hierarchy_is_rejected() {
    let b = hierarchical_sample();
    let mut n = 0;
    let mut coarser = 0;
    for bit in 0..b.len() * 8 {
        let mut x = b.clone();
        x[bit / 8] ^= 1 << (bit % 8);
        assert!(
            subwave::decode_slice(&x).is_err(),
            "flip of bit {bit} decoded silently"
        );
        // A coarser level may still come out (a flipped length in a later section looks
        // like a cut), but only ever the right one.
        for k in 0..=2u8 {
            let opts = DecodeOptions {
                max_level: Some(k),
                ..Default::default()
            };
            if let Ok(d) = subwave::decode(&x, &opts) {
                let right = subwave::decode(&b, &opts).unwrap();
                assert_eq!(
                    common::fingerprint(&d.mesh),
                    common::fingerprint(&right.mesh),
                    "flip of bit {bit} gave a different level-{k} mesh"
                );
                coarser += 1;
            }
        }
        n += 1;
    }
    eprintln!("{n} single-bit flips of a {}-byte container: all rejected whole; {coarser} coarser-level decodes, all the right mesh", b.len());
}

#[test]
fn every_truncation_of_a_hierarchy_is_rejected_or_a_correct_coarser_level() {
    let b = hierarchical_sample();
    let whole: Vec<subwave::Mesh> = (0..=2)
        .map(|k| {
            subwave::decode(
                &b,
                &DecodeOptions {
                    max_level: Some(k),
                    ..Default::default()
                },
            )
            .unwrap()
            .mesh
        })
        .collect();
    let mut coarser = 0;
    for cut in 0..b.len() {
        assert!(
            subwave::decode_slice(&b[..cut]).is_err(),
            "cut at {cut} decoded as whole"
        );
        for k in 0..=2u8 {
            let opts = DecodeOptions {
                max_level: Some(k),
                ..Default::default()
            };
            if let Ok(d) = subwave::decode(&b[..cut], &opts) {
                // Without the (cut) order section the vertices come in canonical order.
                if d.input_order {
                    assert_eq!(
                        d.mesh, whole[k as usize],
                        "cut at {cut}, level {k}: a different mesh"
                    );
                } else {
                    assert_eq!(
                        common::fingerprint(&d.mesh),
                        common::fingerprint(&whole[k as usize]),
                        "cut at {cut}, level {k}: a different mesh"
                    );
                }
                coarser += 1;
            }
        }
    }
    assert!(coarser > 0);
    eprintln!(
        "{} truncations: all rejected whole; {coarser} decodes of a coarser level, all exact",
        b.len()
    );
}

/// `bytes` with the payload of LEVL section number `level` rewritten by `edit`, every
/// checksum valid.
fn with_level(bytes: &[u8], level: usize, edit: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let c = subwave_container::Container::parse(bytes, &Limits::default()).unwrap();
    let mut w = ContainerWriter::new();
    let mut edit = Some(edit);
    let mut n = 0;
    for s in &c.sections {
        if s.kind == SectionKind::END {
            continue;
        }
        let mut p = s.payload.to_vec();
        if s.kind == SectionKind::LEVEL {
            if n == level {
                (edit.take().unwrap())(&mut p);
            }
            n += 1;
        }
        w.section(s.kind, &p);
    }
    assert!(edit.is_none(), "no level {level}");
    w.finish()
}

/// The payloads of a container's LEVL sections, in order.
fn level_payloads(bytes: &[u8]) -> Vec<Vec<u8>> {
    let c = subwave_container::Container::parse(bytes, &Limits::default()).unwrap();
    c.sections
        .iter()
        .filter(|s| s.kind == SectionKind::LEVEL)
        .map(|s| s.payload.to_vec())
        .collect()
}

#[test]
fn modes_a_level_cannot_have_are_corrupt() {
    // Modes 2 and 7 (SPEC.md 10.3, 10.7) exist for sqrt(2) levels only, modes 6 and 9
    // (10.6, 10.9) for levels with phases: a bicubic Catmull-Clark level claims each of them,
    // checksums kept valid.
    let obj = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/corpus/mixed_cc2.obj")).unwrap();
    let m = subwave::load(&obj, None).unwrap();
    let enc = subwave::encode_to_vec(&m.mesh, &m.quantization, &EncodeOptions::default()).unwrap();
    assert_eq!(enc.header.family, subwave::Family::Cc);
    assert_eq!(
        enc.header.transform,
        subwave::Transform::Wavelet(subwave::Wavelet::Bicubic)
    );
    for (mode, want) in [
        (2, "tangent"),
        (7, "tangent"),
        (6, "phase"),
        (9, "phase"),
        (10, "unknown"),
    ] {
        let b = with_level(&enc.bytes, 0, |p| {
            assert!(p[0] <= 1);
            p[0] = mode;
        });
        // The error names the level and where its section starts.
        let offset = subwave_container::Container::parse(&b, &Limits::default())
            .unwrap()
            .sections
            .iter()
            .find(|s| s.kind == SectionKind::LEVEL)
            .unwrap()
            .offset;
        match subwave::decode_slice(&b) {
            Err(e @ Error::CorruptLevel { level: 1, .. }) => {
                let Error::CorruptLevel {
                    offset: at, what, ..
                } = &e
                else {
                    unreachable!()
                };
                assert_eq!(*at, offset, "mode {mode}");
                assert!(what.contains(want), "mode {mode}: {what}");
                let text = e.to_string();
                assert!(
                    text.contains("level 1") && text.contains(&format!("byte {offset}")),
                    "{text}"
                );
            }
            other => panic!("mode {mode}: expected a corrupt level, got {other:?}"),
        }
    }
}

/// `corpus/subdivided_open_cc3.obj` at 12 bits with the lazy transform, in its own order:
/// the input, and a container with a level in mode 9 (SPEC.md 10.9), unbinned (10.1).
fn mesh_in_mode_9() -> (subwave::Loaded, Vec<u8>) {
    let obj = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/corpus/subdivided_open_cc3.obj"
    ))
    .unwrap();
    let m = subwave::load(&obj, Some(12)).unwrap();
    let enc = subwave::encode_to_vec(
        &m.mesh,
        &m.quantization,
        &EncodeOptions {
            keep_order: true,
            transform: subwave::TransformChoice::Fixed(subwave::Wavelet::Lazy),
            ..Default::default()
        },
    )
    .unwrap();
    (m, enc.bytes)
}

#[test]
fn corrected_phased_levels_round_trip() {
    let (m, bytes) = mesh_in_mode_9();
    // (Format 22: the mode byte's top bit is the unbinned flag, SPEC.md 10.1.)
    assert!(level_payloads(&bytes).iter().any(|p| p[0] == 0x89));
    let dec = subwave::decode_slice(&bytes).unwrap();
    assert!(dec.mesh == m.mesh);
    let level = level_payloads(&bytes)
        .iter()
        .position(|p| p[0] == 0x89)
        .unwrap();
    // Binned (0x09), or read as mode 8 (the same weights, no phases) or as mode 6
    // (phases, no weights), binned or not: an error or another mesh, never this one.
    for other in [0x09u8, 0x88, 0x86, 0x08, 0x06] {
        let x = with_level(&bytes, level, |p| p[0] = other);
        if let Ok(d) = subwave::decode_slice(&x) {
            assert!(d.mesh != m.mesh, "mode 9 read as {other:#x}");
        }
    }
}

/// A frozen container of `corpus/terrain_grid33.obj` on the 10-bit grid, and that mesh.
fn frozen_terrain_q10(file: &str) -> (Vec<u8>, subwave::Loaded) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/corpus/");
    let b = std::fs::read(format!("{dir}golden/{file}")).unwrap();
    let obj = std::fs::read(format!("{dir}terrain_grid33.obj")).unwrap();
    (b, subwave::load(&obj, Some(10)).unwrap())
}

/// The frozen terrain at 10 bits (interp6) has a level in mode 9 with joint rounding
/// (SPEC.md 10.9): it decodes exactly; its flag cleared (rounding apart) gives an error or
/// another mesh, never this one; the mask's top bit, or the flag on mode 8, is corrupt.
#[test]
fn joint_rounding_levels_need_their_flag() {
    let (b, m) = frozen_terrain_q10("terrain_grid33.interp6.q10.swv");
    let info = subwave::inspect(&b, &Limits::default()).unwrap();
    assert!(info.sections.iter().any(|s| s.mode == Some(9) && s.joint));
    assert!(subwave::decode_slice(&b).unwrap().mesh == m.mesh);
    let level = level_payloads(&b)
        .iter()
        .position(|p| p[0] & 0x0f == 9 && p[1] & 0x40 != 0)
        .unwrap();
    let apart = with_level(&b, level, |p| p[1] &= !0x40);
    if let Ok(d) = subwave::decode_slice(&apart) {
        assert!(d.mesh != m.mesh, "read with its corrections rounded apart");
    }
    for edit in [(|p: &mut Vec<u8>| p[1] |= 0x80) as fn(&mut Vec<u8>), |p| {
        p[0] = p[0] & 0xf0 | 8
    }] {
        match subwave::decode_slice(&with_level(&b, level, edit)) {
            Err(Error::CorruptLevel { what, level: l, .. }) if l as usize == level + 1 => {
                assert!(what.contains("bad correction weights"), "{what}")
            }
            other => panic!("expected bad weights, got {other:?}"),
        }
    }
}

/// Zero slots (SPEC.md 10.1): the frozen terrain container's levels leave x and y out.
/// Read with a level's flags cleared, that level's stream is read as if it held them: an
/// error or another mesh, never this one. With a flag cleared but another added (z left
/// out instead of y), the same.
#[test]
fn zero_slots_are_left_out_only_with_their_flags() {
    let (b, m) = frozen_terrain_q10("terrain_grid33.interp6.q10.swv");
    let info = subwave::inspect(&b, &Limits::default()).unwrap();
    let levels: Vec<_> = info.sections.iter().filter(|s| s.kind == "LEVL").collect();
    assert!(!levels.is_empty());
    assert!(levels.iter().all(|s| s.zero_slots == [0, 1]), "{levels:?}");
    assert!(subwave::decode_slice(&b).unwrap().mesh == m.mesh);
    let payloads = level_payloads(&b);
    for (level, p) in payloads.iter().enumerate() {
        assert_eq!(p[0] & 0x70, 0x30, "level {level}");
        for edit in [
            (|p: &mut Vec<u8>| p[0] &= !0x70) as fn(&mut Vec<u8>),
            |p| p[0] &= !0x10,
            |p| p[0] ^= 0x60,
        ] {
            if let Ok(d) = subwave::decode_slice(&with_level(&b, level, edit)) {
                assert!(d.mesh != m.mesh, "level {level} read with other zero slots");
            }
        }
    }
}

#[test]
fn every_bit_flip_inside_a_phased_level_is_an_error_or_a_valid_mesh() {
    // The frozen containers with a level in mode 6 (Catmull-Clark), mode 7 (sqrt(2)),
    // mode 8 (its weights included) unbinned and with slots 0 and 1 left out, mode 8
    // unbinned, mode 9 unbinned, mode 6 unbinned on interp6, mode 9 with slots 0 and 1
    // left out, and with joint rounding:
    // every bit of those levels' payloads flipped, checksums made valid, so the phases,
    // shifts, corrections and their bounds meet hostile values.
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/corpus/golden/");
    let mut tried = 0;
    for (file, mode) in [
        ("open_cc2.swv", 6u8),
        ("prism_sqrt2_5.swv", 7),
        ("terrain_grid33.interp4.swv", 0xb8),
        ("cube_cc4.bicubic.swv", 0x88),
        ("subdivided_open_cc3.lazy.q12.swv", 0x89),
        ("subdivided_open_cc3.interp6.q12.swv", 0x86),
        ("terrain_grid33.lazy.q16.swv", 0xb9),
        ("terrain_grid33.interp6.q10.swv", 0xb9),
    ] {
        let b = std::fs::read(format!("{dir}{file}")).unwrap();
        let payloads = level_payloads(&b);
        let level = payloads
            .iter()
            .position(|p| p[0] == mode)
            .expect("a phased level");
        let len = payloads[level].len();
        for bit in 8..len * 8 {
            let x = with_level(&b, level, |p| p[bit / 8] ^= 1 << (bit % 8));
            if let Ok(d) = subwave::decode_slice(&x) {
                d.mesh.validate().unwrap();
            }
            tried += 1;
        }
        // And the mode byte turned into every other value.
        for m in 0..=255u8 {
            let x = with_level(&b, level, |p| p[0] = m);
            if let Ok(d) = subwave::decode_slice(&x) {
                d.mesh.validate().unwrap();
            }
        }
    }
    assert!(tried > 1000, "{tried}");
}

/// The sphere_polar3 container with its header rewritten by `edit` (checksums valid).
fn polar_with_header(edit: impl FnOnce(&mut subwave::Header)) -> Vec<u8> {
    let obj = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/corpus/sphere_polar3.obj"
    ))
    .unwrap();
    let m = subwave::load(&obj, None).unwrap();
    let enc = subwave::encode_to_vec(&m.mesh, &m.quantization, &EncodeOptions::default()).unwrap();
    assert_eq!(enc.header.family, subwave::Family::Polar);
    let c = subwave_container::Container::parse(&enc.bytes, &Limits::default()).unwrap();
    let mut h = enc.header.clone();
    edit(&mut h);
    let mut w = ContainerWriter::new();
    for s in &c.sections {
        match s.kind {
            SectionKind::END => {}
            SectionKind::HEADER => w.section(s.kind, &h.write()),
            _ => w.section(s.kind, s.payload),
        }
    }
    w.finish()
}

#[test]
fn polar_headers_that_do_not_fit_their_base_mesh_are_refused() {
    // Unchanged, the rewritten container decodes.
    assert!(subwave::decode_slice(&polar_with_header(|_| {})).is_ok());
    let base = |h: &subwave::Header| h.base_vertices as u32;
    type Edit = Box<dyn FnOnce(&mut subwave::Header)>;
    let cases: Vec<(&str, Edit)> = vec![
        ("no poles", Box::new(|h| h.poles.clear())),
        (
            "not a base vertex",
            Box::new(move |h| h.poles = vec![base(h)]),
        ),
        ("a ring vertex (quads)", Box::new(|h| h.poles = vec![5])),
        ("one pole of two", Box::new(|h| h.poles.truncate(1))),
        (
            "a sqrt(2) transform",
            Box::new(|h| h.transform = subwave::Transform::Wavelet(subwave::Wavelet::Ir2w)),
        ),
    ];
    for (what, edit) in cases {
        match subwave::decode_slice(&polar_with_header(edit)) {
            Err(Error::Container(_))
            | Err(Error::CorruptStream { .. })
            | Err(Error::CorruptLevel { .. }) => {}
            other => panic!("{what}: expected a malformed or corrupt container, got {other:?}"),
        }
    }
    // An unknown disc transform (the header's last byte) is unsupported.
    let bytes = polar_with_header(|h| h.disc = subwave::DiscTransform::LazyCircularFirst);
    assert!(subwave::decode_slice(&bytes).is_ok());
    let c = subwave_container::Container::parse(&bytes, &Limits::default()).unwrap();
    let mut head = c.sections[0].payload.to_vec();
    *head.last_mut().unwrap() = 9;
    match subwave::Header::read(&head, 0, &Limits::default()) {
        Err(Error::Unsupported(what)) => assert!(what.contains("disc transform code 9"), "{what}"),
        other => panic!("expected unsupported, got {other:?}"),
    }
    // The lifted polar wavelet (codes 3 and 4).
    for code in [3u8, 4] {
        *head.last_mut().unwrap() = code;
        assert!(subwave::Header::read(&head, 0, &Limits::default()).is_ok());
    }
}

/// The frozen float container (`corpus/floats_cc2.ply`: -0.0, tiny and subnormal
/// values) with its FBIT payload edited, re-framed with valid checksums.
fn with_float_bits(edit: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let bytes = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus/golden/floats_cc2.swv"),
    )
    .unwrap();
    let c = subwave_container::Container::parse(&bytes, &Limits::default()).unwrap();
    let mut w = ContainerWriter::new();
    let mut edit = Some(edit);
    for s in c.sections.iter().filter(|s| s.kind != SectionKind::END) {
        let mut p = s.payload.to_vec();
        if s.kind == SectionKind::FLOAT_BITS {
            (edit.take().unwrap())(&mut p);
        }
        w.section(s.kind, &p);
    }
    assert!(edit.is_none(), "no FBIT section");
    w.finish()
}

#[test]
fn float_bits_that_do_not_fit_their_integers_are_corrupt() {
    let ok = with_float_bits(|_| {});
    let want = subwave::decode_slice(&ok).unwrap();
    assert!(!want.mesh.floats.is_empty());
    let corrupt = |b: &[u8], what: &str| match subwave::decode_slice(b) {
        Err(Error::CorruptStream {
            section: "FBIT", ..
        }) => {}
        other => panic!("{what}: expected corrupt FBIT data, got {other:?}"),
    };
    corrupt(&with_float_bits(|p| p.push(0)), "a byte more");
    corrupt(&with_float_bits(|p| p.truncate(p.len() - 1)), "a byte less");
    corrupt(&with_float_bits(|p| p.clear()), "no bits");
    // Every bit flipped in turn: an error, or other floats with the same integers.
    let n = with_float_bits(|_| {}).len();
    let mut payload_len = 0;
    let _ = with_float_bits(|p| payload_len = p.len());
    assert!(n > payload_len);
    for bit in 0..payload_len * 8 {
        let b = with_float_bits(|p| p[bit / 8] ^= 0x80 >> (bit % 8));
        if let Ok(d) = subwave::decode_slice(&b) {
            assert_eq!(d.mesh.positions, want.mesh.positions, "bit {bit}");
            assert_ne!(d.mesh.floats, want.mesh.floats, "bit {bit}");
            assert!(
                d.mesh
                    .floats
                    .iter()
                    .flatten()
                    .all(|&f| f32::from_bits(f as u32).is_finite()),
                "bit {bit}"
            );
        }
    }
    // The float bits flag needs binary float quantisation.
    let mut h = subwave::decode_slice(&ok).unwrap().header;
    h.quantization = subwave::Quantization::Decimal { decimals: 6 };
    assert!(matches!(
        subwave::decode_slice(&common::with_header(&ok, &h)),
        Err(Error::Container(subwave_container::Error::Malformed { .. }))
    ));
}

#[test]
fn files_with_no_mesh_are_errors_and_empty_meshes_are_meshes() {
    assert!(mesh_err(b"").contains("empty"));
    assert!(mesh_err(b"  \n\n").contains("empty"));
    assert!(mesh_err(b"Hello, world\n").contains("not an OBJ file"));
    assert!(mesh_err(b"solid\n").contains("STL"));
    assert!(mesh_err(&[0x80, 0x81, 0x00, 0xff]).contains("not an OBJ file"));
    // An OFF whose first lines are comments is an OFF.
    let off = subwave::load(
        b"# made by hand\n\nOFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        None,
    )
    .unwrap();
    assert_eq!(off.format, subwave::Format::Off);
    assert_eq!((off.mesh.vertex_count(), off.mesh.face_count()), (3, 1));
    // A valid mesh file without vertices is an empty mesh, and round-trips as one.
    for text in [&b"# nothing yet\n"[..], b"o empty\n"] {
        let m = subwave::load(text, None).unwrap();
        assert_eq!(m.mesh.vertex_count(), 0);
        let enc =
            subwave::encode_to_vec(&m.mesh, &m.quantization, &EncodeOptions::default()).unwrap();
        assert_eq!(
            subwave::decode_slice(&enc.bytes)
                .unwrap()
                .mesh
                .vertex_count(),
            0
        );
    }
}

/// `bytes` with the payload of its section of `kind` rewritten by `edit` (checksums
/// made valid).
fn with_section(bytes: &[u8], kind: SectionKind, edit: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let c = subwave_container::Container::parse(bytes, &Limits::default()).unwrap();
    let mut w = ContainerWriter::new();
    let mut edit = Some(edit);
    for s in &c.sections {
        if s.kind == SectionKind::END {
            continue;
        }
        let mut p = s.payload.to_vec();
        if s.kind == kind {
            (edit.take().expect("one section of the kind"))(&mut p);
        }
        w.section(s.kind, &p);
    }
    assert!(edit.is_none(), "no {kind} section");
    w.finish()
}

/// The frozen textured OBJ's container (ORDR walks, CIDX, NRML and an ATTR).
fn frozen_textured() -> Vec<u8> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/corpus/golden/textured_cc3.file.swv"
    );
    std::fs::read(path).unwrap()
}

#[test]
fn every_bit_flip_or_cut_of_the_order_corner_indices_and_normals_is_an_error_or_a_valid_file() {
    // The frozen textured OBJ (walks in ORDR, vt and vn channels in CIDX, normals in
    // NRML, the vt table in an ATTR): every bit of
    // those payloads flipped and every cut of them, checksums made valid, so the walks'
    // candidates and escapes and the channels' predictions meet hostile values. The
    // result is an error, or a mesh and a file that the decoder could make.
    let b = frozen_textured();
    let d = subwave::decode_slice(&b).unwrap();
    assert!(d.file().is_some(), "the frozen container keeps its file");
    let mut tried = 0;
    let mut refused = 0;
    for kind in [
        SectionKind::ORDER,
        SectionKind::CORNER_INDICES,
        SectionKind::NORMALS,
        SectionKind::ATTRIBUTE,
    ] {
        let c = subwave_container::Container::parse(&b, &Limits::default()).unwrap();
        let len = c
            .sections
            .iter()
            .find(|s| s.kind == kind)
            .unwrap()
            .payload
            .len();
        let mut variants: Vec<Vec<u8>> = (0..len * 8)
            .map(|bit| with_section(&b, kind, |p| p[bit / 8] ^= 1 << (bit % 8)))
            .collect();
        variants.extend((0..len).map(|n| with_section(&b, kind, |p| p.truncate(n))));
        for x in variants {
            match subwave::decode_slice(&x) {
                Ok(d) => {
                    d.mesh.validate().unwrap();
                    // The file, or an error saying why not.
                    let _ = d.file().unwrap();
                }
                Err(e) => {
                    assert!(!e.to_string().is_empty());
                    refused += 1;
                }
            }
            tried += 1;
        }
    }
    assert!(
        tried > 500 && refused > 0,
        "{tried} tried, {refused} refused"
    );
}

#[test]
fn attribute_sections_that_nest_files_or_claim_what_is_not_there_are_errors() {
    // An ATTR whose nested container keeps a file of its own (which could nest again),
    // one with an unknown flag, one with a width of 4, one that says its order is the
    // main container's when the nested container has its own ORDR as well: each an
    // error naming ATTR.
    let b = frozen_textured();
    assert!(subwave::decode_slice(&b).is_ok());
    let nested_file = b.clone();
    type Edit = Box<dyn Fn(&mut Vec<u8>)>;
    let cases: [(&str, Edit); 4] = [
        (
            "nests a file",
            Box::new(move |p: &mut Vec<u8>| {
                p.truncate(2);
                p.extend_from_slice(&nested_file);
            }),
        ),
        ("unknown flag", Box::new(|p: &mut Vec<u8>| p[1] |= 2)),
        ("width 4", Box::new(|p: &mut Vec<u8>| p[0] = 4)),
        ("order twice", Box::new(|p: &mut Vec<u8>| p[1] |= 1)),
    ];
    for (what, edit) in cases {
        let x = with_section(&b, SectionKind::ATTRIBUTE, |p| edit(p));
        match subwave::decode_slice(&x) {
            Ok(_) => panic!("{what}: decoded"),
            Err(e) => assert!(e.to_string().contains("ATTR"), "{what}: {e}"),
        }
    }
}

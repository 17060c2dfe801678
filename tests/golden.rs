//! Golden vectors: the encoder is deterministic, so the hash of every encoded corpus mesh
//! is committed (`corpus/golden/hashes.txt`), and frozen containers must keep decoding to
//! the same mesh. A bitstream change updates them deliberately, with SPEC.md and the
//! format version: run `SUBWAVE_BLESS=1 cargo test --test golden` and commit the result.

mod common;

use std::fmt::Write;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};
use subwave::{EncodeOptions, Format};

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus/golden")
}

fn hashes() -> String {
    let mut out = String::new();
    for path in common::own_corpus() {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let bytes = std::fs::read(&path).unwrap();
        for (mode, bits, keep) in [
            ("exact", None, false),
            ("exact-keep-order", None, true),
            ("q16", Some(16), false),
        ] {
            let m = subwave::load(&bytes, bits).unwrap();
            let enc = subwave::encode_to_vec(
                &m.mesh,
                &m.quantization,
                &EncodeOptions {
                    keep_order: keep,
                    source: m.source(),
                    ..Default::default()
                },
            )
            .unwrap();
            let h = Sha256::digest(&enc.bytes);
            let hex: String = h.iter().fold(String::new(), |mut s, b| {
                let _ = write!(s, "{b:02x}");
                s
            });
            let _ = writeln!(out, "{name} {mode} {} {hex}", enc.bytes.len());
        }
    }
    out
}

#[test]
fn encoded_bytes_match_the_golden_hashes() {
    let file = golden_dir().join("hashes.txt");
    let now = hashes();
    if std::env::var_os("SUBWAVE_BLESS").is_some() {
        std::fs::write(&file, &now).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&file).expect("corpus/golden/hashes.txt");
    for (a, b) in committed.lines().zip(now.lines()) {
        assert_eq!(a, b, "the bitstream changed: see tests/golden.rs");
    }
    assert_eq!(committed.lines().count(), now.lines().count());
}

#[test]
fn frozen_containers_still_decode() {
    // (container, the mesh file it must decode to, written as OBJ)
    let frozen = [
        ("mixed_cc2.v1.swv", "mixed_cc2.obj"),
        ("terrain_grid33.v1.swv", "terrain_grid33.obj"),
        ("cube_cc4.v2.swv", "cube_cc4.obj"),
        ("unstructured.v2.swv", "unstructured.obj"),
        ("cube_cc4.v3.swv", "cube_cc4.obj"),
        ("terrain_grid33.v3.swv", "terrain_grid33.obj"),
        ("cube_cc4.v4.swv", "cube_cc4.obj"),
        ("two_components_cc2.v4.swv", "two_components_cc2.obj"),
        ("unstructured.v5.swv", "unstructured.obj"),
        ("cube_cc4.flat.v5.swv", "cube_cc4.obj"),
        ("prism_sqrt2_5.v6.swv", "prism_sqrt2_5.obj"),
        ("prism_sqrt2_5.v7.swv", "prism_sqrt2_5.obj"),
        ("sphere_polar3.v8.swv", "sphere_polar3.obj"),
        ("sphere_polar3.disc.v8.swv", "sphere_polar3.obj"),
        ("subdivided_cc3.v9.swv", "subdivided_cc3.obj"),
        ("sphere_polar3.lifted.v10.swv", "sphere_polar3.obj"),
        ("terrain_grid33.vmap.v11.swv", "terrain_grid33.obj"),
        ("cube_cc4.v12.swv", "cube_cc4.obj"),
        ("terrain_grid33.vmap.v12.swv", "terrain_grid33.obj"),
        ("cube_cc4.interp4.v13.swv", "cube_cc4.obj"),
        ("terrain_grid33.interp4.v13.swv", "terrain_grid33.obj"),
        ("cube_cc4.v14.swv", "cube_cc4.obj"),
        ("unstructured.v14.swv", "unstructured.obj"),
        ("sphere_polar3.v14.swv", "sphere_polar3.obj"),
        ("cube_cc4.v15.swv", "cube_cc4.obj"),
        ("prism_sqrt2_5.v15.swv", "prism_sqrt2_5.obj"),
        ("terrain_grid33.interp4.v15.swv", "terrain_grid33.obj"),
        ("cube_cc4.v16.swv", "cube_cc4.obj"),
        ("sphere_polar3.v16.swv", "sphere_polar3.obj"),
        ("prism_sqrt2_5.v16.swv", "prism_sqrt2_5.obj"),
        ("cube_cc4.v17.swv", "cube_cc4.obj"),
        ("sphere_polar3.v17.swv", "sphere_polar3.obj"),
        ("mixed_cc2.v17.swv", "mixed_cc2.obj"),
        ("prism_sqrt2_5.v18.swv", "prism_sqrt2_5.obj"),
        ("open_cc2.v18.swv", "open_cc2.obj"),
        ("cube_cc4.v19.swv", "cube_cc4.obj"),
        ("terrain_grid33.vmap.v19.swv", "terrain_grid33.obj"),
        ("terrain_grid33.interp4.v20.swv", "terrain_grid33.obj"),
        ("terrain_grid33.lazy.q16.v21.swv", "terrain_grid33.obj"),
        (
            "subdivided_open_cc3.lazy.q12.v22.swv",
            "subdivided_open_cc3.obj",
        ),
        ("terrain_grid33.q16.v23.swv", "terrain_grid33.obj"),
        (
            "subdivided_open_cc3.interp6.q12.v24.swv",
            "subdivided_open_cc3.obj",
        ),
        ("terrain_grid33.interp6.q10.v25.swv", "terrain_grid33.obj"),
        ("terrain_grid33.interp6.q10.v26.swv", "terrain_grid33.obj"),
    ];
    for (swv, obj) in frozen {
        let path = golden_dir().join(swv);
        let source = std::fs::read(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("corpus")
                .join(obj),
        )
        .unwrap();
        // A ".q16." (".q12.", ".q10.") container holds the mesh on Draco's 16-bit
        // (12-bit, 10-bit) grid: it decodes to that.
        let bits = swv
            .split('.')
            .find_map(|p| p.strip_prefix('q')?.parse::<u8>().ok());
        let m = subwave::load(&source, bits).unwrap();
        if !path.exists() && std::env::var_os("SUBWAVE_BLESS").is_some() {
            // A ".flat." container is coded without levels (the flat path), a ".disc."
            // one with the lazy polar wavelet in its discs (radial first), a ".lifted."
            // one with the lifted polar wavelet (circular first), a ".vmap." one with
            // every axis's value map, an ".interp4." (".interp6.") one with the interp4
            // (interp6) transform, a ".lazy." one with the lazy transform.
            let enc = subwave::encode_to_vec(
                &m.mesh,
                &m.quantization,
                &EncodeOptions {
                    keep_order: true,
                    source: m.source(),
                    max_levels: if swv.contains(".flat.") { 0 } else { 16 },
                    disc: if swv.contains(".disc.") {
                        Some(subwave::DiscTransform::LazyRadialFirst)
                    } else if swv.contains(".lifted.") {
                        Some(subwave::DiscTransform::LiftedCircularFirst)
                    } else {
                        None
                    },
                    value_map: swv.contains(".vmap.").then_some(true),
                    // On two threads: the container is the same for every count.
                    threads: 2,
                    transform: if swv.contains(".interp4.") {
                        subwave::TransformChoice::Fixed(subwave::Wavelet::Interp4)
                    } else if swv.contains(".interp6.") {
                        subwave::TransformChoice::Fixed(subwave::Wavelet::Interp6)
                    } else if swv.contains(".lazy.") {
                        subwave::TransformChoice::Fixed(subwave::Wavelet::Lazy)
                    } else {
                        Default::default()
                    },
                },
            )
            .unwrap();
            std::fs::write(&path, enc.bytes).unwrap();
        }
        let bytes = std::fs::read(&path).unwrap_or_else(|_| panic!("missing frozen {swv}"));
        let dec = subwave::decode_slice(&bytes).unwrap();
        let mut out = Vec::new();
        subwave::write_mesh(&mut out, &dec.mesh, &dec.quantization, Format::Obj).unwrap();
        let want = match bits {
            None => source,
            Some(_) => {
                let mut w = Vec::new();
                subwave::write_mesh(&mut w, &m.mesh, &m.quantization, Format::Obj).unwrap();
                w
            }
        };
        assert!(out == want, "{swv} no longer decodes to {obj}");
    }
}

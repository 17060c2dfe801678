//! Golden vectors: the encoder is deterministic, so the hash of every encoded corpus mesh
//! is committed (`corpus/golden/hashes.txt`), and frozen containers (one per family,
//! transform and level mode, [`FROZEN`]) must decode to their mesh. A bitstream change
//! updates them deliberately, with SPEC.md and the format version: run
//! `SUBWAVE_BLESS=1 cargo test --test golden` and commit the result.

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
                    // The exhaustive search (as before efforts existed): the
                    // hashes do not move with the default effort.
                    effort: subwave::MAX_EFFORT,
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

/// The frozen containers: one per family and transform, and one per level mode and flag
/// the other tests read (`tests/bad_input.rs`, `cli/tests/cli.rs`). A name's parts say how
/// it was coded: a transform's name (`bicubic`, `sqrt2-sym`, ...) fixes the transform,
/// `flat` codes without levels, `disc` (`lifted`) codes the pole discs with the lazy
/// (lifted) polar wavelet, `vmap` codes every axis's value map, `q16` (`q12`, `q10`)
/// holds the mesh on Draco's 16-bit (12-bit, 10-bit) grid, `file` keeps the file's own
/// bytes (`encode_file`, a TMPL section); the first part names the
/// corpus mesh it decodes to. Before the first release the decoder reads the current
/// format only, so a format change blesses them anew (`SUBWAVE_BLESS=1`), deliberately.
const FROZEN: [&str; 35] = [
    "cube_cc4.swv",
    "cube_cc4.flat.swv",
    "cube_cc4.lazy.swv",
    "cube_cc4.bilinear.swv",
    "cube_cc4.bicubic.swv",
    "cube_cc4.biquintic.swv",
    "cube_cc4.dyadic-sym.swv",
    "cube_cc4.interp4.swv",
    "cube_cc4.interp6.swv",
    "mixed_cc2.swv",
    "open_cc2.swv",
    "two_components_cc2.swv",
    "unstructured.swv",
    "prism_sqrt2_5.swv",
    "prism_sqrt2_5.sqrt2-lazy.swv",
    "prism_sqrt2_5.ir2w.swv",
    "prism_sqrt2_5.sqrt2-sym.swv",
    "sphere_polar3.swv",
    "sphere_polar3.disc.swv",
    "sphere_polar3.lifted.swv",
    "subdivided_cc3.swv",
    "terrain_grid33.vmap.swv",
    "terrain_grid33.interp4.swv",
    "terrain_grid33.lazy.q16.swv",
    "terrain_grid33.interp6.q10.swv",
    "subdivided_open_cc3.lazy.q12.swv",
    "subdivided_open_cc3.interp6.q12.swv",
    "floats_cc2.swv",
    "floats_cc2.file.swv",
    "two_components_cc2.file.swv",
    "cube_cc2.swv",
    "cube_cc2.file.swv",
    "textured_cc3.file.swv",
    "limit_creased_cc3.swv",
    "limit_seams_cc3.file.swv",
];

/// Codes a frozen container as its name says (see [`FROZEN`]).
fn freeze(swv: &str, m: &subwave::Loaded, source: &[u8]) -> Vec<u8> {
    let parts: Vec<&str> = swv.split('.').collect();
    let has = |p: &str| parts.contains(&p);
    let transform = parts
        .iter()
        .find_map(|p| subwave::Wavelet::from_name(p))
        .map_or(Default::default(), subwave::TransformChoice::Fixed);
    let opts = EncodeOptions {
        keep_order: true,
        source: m.source(),
        max_levels: if has("flat") { 0 } else { 16 },
        disc: if has("disc") {
            Some(subwave::DiscTransform::LazyRadialFirst)
        } else if has("lifted") {
            Some(subwave::DiscTransform::LiftedCircularFirst)
        } else {
            None
        },
        value_map: has("vmap").then_some(true),
        // On two threads: the container is the same for every count.
        threads: 2,
        transform,
        effort: subwave::MAX_EFFORT,
        ..Default::default()
    };
    let (mesh, q) = (&m.mesh, &m.quantization);
    match has("file") {
        true => subwave::encode_file(mesh, q, &opts, source, m.format),
        false => subwave::encode_to_vec(mesh, q, &opts),
    }
    .unwrap()
    .bytes
}

#[test]
fn frozen_containers_still_decode() {
    let bless = std::env::var_os("SUBWAVE_BLESS").is_some();
    for swv in FROZEN {
        // The corpus mesh: an OBJ, a binary PLY (float positions) or a binary STL.
        let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus");
        let stem = swv.split('.').next().unwrap();
        let obj = ["obj", "ply", "stl"]
            .iter()
            .map(|e| format!("{stem}.{e}"))
            .find(|f| corpus.join(f).exists())
            .unwrap();
        let path = golden_dir().join(swv);
        let source = std::fs::read(corpus.join(&obj)).unwrap();
        let bits = swv
            .split('.')
            .find_map(|p| p.strip_prefix('q')?.parse::<u8>().ok());
        let m = subwave::load(&source, bits).unwrap();
        let fresh = freeze(swv, &m, &source);
        if bless {
            std::fs::write(&path, &fresh).unwrap();
        }
        let bytes = std::fs::read(&path).unwrap_or_else(|_| panic!("missing frozen {swv}"));
        // Frozen, and still what the encoder writes: a change of either is deliberate.
        assert!(bytes == fresh, "{swv}: the encoder writes other bytes now");
        let dec = subwave::decode_slice(&bytes).unwrap();
        if swv.contains(".file.") {
            // The file itself, byte for byte.
            let file = dec.file().expect("a file template").unwrap();
            assert!(file == source, "{swv} no longer gives back {obj}");
            continue;
        }
        if obj.ends_with(".ply") || obj.ends_with(".stl") {
            // Every value, bit for bit, in the file's order.
            assert!(dec.mesh == m.mesh, "{swv} no longer decodes to {obj}");
            continue;
        }
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

/// Every file in `corpus/golden/` is a frozen container of [`FROZEN`] or the hashes: none
/// left behind by an older format.
#[test]
fn no_stale_frozen_containers() {
    for entry in std::fs::read_dir(golden_dir()).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().to_string();
        assert!(
            name == "hashes.txt" || FROZEN.contains(&name.as_str()),
            "{name} is not a frozen container of this format"
        );
    }
}

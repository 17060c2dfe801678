//! Exact round trips of every mesh in `corpus/` and, when it is there, in
//! `../shared/corpus` (ordered and shuffled copies), exact and at Q16 / Q12.

mod common;

use std::path::Path;

use subwave::{EncodeOptions, Format};

/// Round-trips one file in every mode; returns a description of any failure.
fn check_file(path: &Path) -> Result<(), String> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| format!("{name}: {e}"))?;
    for bits in [None, Some(16), Some(12)] {
        let input = subwave::load(&bytes, bits).map_err(|e| format!("{name}: {e}"))?;
        // With the stored order: identical vertex for vertex and face for face.
        let enc = subwave::encode_to_vec(
            &input.mesh,
            &input.quantization,
            &EncodeOptions {
                keep_order: true,
                source: input.source(),
                ..Default::default()
            },
        )
        .map_err(|e| format!("{name}: {e}"))?;
        let dec = subwave::decode_slice(&enc.bytes).map_err(|e| format!("{name}: {e}"))?;
        if !dec.input_order || dec.mesh != input.mesh {
            return Err(format!(
                "{name} bits={bits:?}: keep-order round trip differs"
            ));
        }
        if dec.quantization != input.quantization {
            return Err(format!("{name} bits={bits:?}: quantisation differs"));
        }
        // Without it: the same mesh up to vertex order, checked independently of the
        // encoder's permutation.
        let enc2 =
            subwave::encode_to_vec(&input.mesh, &input.quantization, &EncodeOptions::default())
                .map_err(|e| format!("{name}: {e}"))?;
        let dec2 = subwave::decode_slice(&enc2.bytes).map_err(|e| format!("{name}: {e}"))?;
        if common::fingerprint(&dec2.mesh) != common::fingerprint(&input.mesh) {
            return Err(format!(
                "{name} bits={bits:?}: canonical-order round trip differs"
            ));
        }
        subwave::compare_up_to_order(&input.mesh, &dec2.mesh, &enc2.order)
            .map_err(|e| format!("{name} bits={bits:?}: {e}"))?;
        if bits.is_none() {
            // Writing the decoded mesh and reading it back gives the same integers: as
            // OBJ text for decimals, in the file's own (binary) format for floats, whose
            // shortest text would read back as decimals.
            let format = match input.quantization {
                subwave::Quantization::Float { .. } => {
                    subwave::default_output_format(input.source())
                }
                _ => Format::Obj,
            };
            let mut out = Vec::new();
            subwave::write_mesh(&mut out, &dec.mesh, &dec.quantization, format)
                .map_err(|e| e.to_string())?;
            let again = subwave::load(&out, None).map_err(|e| format!("{name}: reread: {e}"))?;
            if again.mesh != input.mesh {
                return Err(format!("{name}: written {format:?} reads back differently"));
            }
        }
    }
    Ok(())
}

#[test]
fn own_corpus_round_trips_exactly() {
    let files = common::own_corpus();
    assert!(files.len() >= 6, "corpus/ holds {} meshes", files.len());
    for f in &files {
        check_file(f).unwrap();
    }
}

#[test]
fn shared_corpus_round_trips_exactly() {
    let Some(dir) = common::shared_corpus() else {
        eprintln!("../shared/corpus not found; skipping");
        return;
    };
    let files = common::list(&dir);
    let failures: Vec<String> = files.iter().filter_map(|f| check_file(f).err()).collect();
    let shuffled = files
        .iter()
        .filter(|f| f.to_string_lossy().contains(".shuffled."))
        .count();
    eprintln!(
        "shared corpus: {} of {} meshes round-trip exactly ({} shuffled copies)",
        files.len() - failures.len(),
        files.len(),
        shuffled
    );
    assert!(files.len() >= 40, "only {} meshes found", files.len());
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn obj_text_with_fixed_decimals_comes_back_byte_identical() {
    let text =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus/cube_cc4.obj")).unwrap();
    let input = subwave::load(&text, None).unwrap();
    let enc = subwave::encode_to_vec(
        &input.mesh,
        &input.quantization,
        &EncodeOptions {
            keep_order: true,
            ..Default::default()
        },
    )
    .unwrap();
    let dec = subwave::decode_slice(&enc.bytes).unwrap();
    let mut out = Vec::new();
    subwave::write_mesh(&mut out, &dec.mesh, &dec.quantization, Format::Obj).unwrap();
    assert_eq!(out, text);
}

#[test]
fn our_obj_reader_agrees_with_tobj() {
    // tobj renumbers vertices per object in first-use order; compare faces by the
    // positions of their corners.
    let mut files: Vec<_> = common::own_corpus()
        .into_iter()
        .filter(|f| f.extension().is_some_and(|e| e == "obj"))
        .collect();
    if let Some(dir) = common::shared_corpus() {
        files.push(dir.join("fertility_cc2_small.shuffled.obj"));
    }
    for f in files {
        let bytes = std::fs::read(&f).unwrap();
        let ours = subwave::read_mesh(&bytes).unwrap();
        let subwave::RawCoords::Decimal(coords) = &ours.coords else {
            panic!("OBJ gives decimals")
        };
        let opts = tobj::LoadOptions {
            triangulate: false,
            single_index: true,
            ..Default::default()
        };
        let (models, _) = tobj::load_obj(&f, &opts).unwrap();
        let mut theirs = Vec::new();
        for m in &models {
            let mesh = &m.mesh;
            let mut at = 0usize;
            let arities: Vec<u32> = if mesh.face_arities.is_empty() {
                vec![3; mesh.indices.len() / 3]
            } else {
                mesh.face_arities.clone()
            };
            for a in arities {
                let face: Vec<[f64; 3]> = mesh.indices[at..at + a as usize]
                    .iter()
                    .map(|&i| {
                        let i = i as usize * 3;
                        [
                            mesh.positions[i],
                            mesh.positions[i + 1],
                            mesh.positions[i + 2],
                        ]
                    })
                    .collect();
                theirs.push(face);
                at += a as usize;
            }
        }
        let mine: Vec<Vec<[f64; 3]>> = ours
            .topology
            .iter_faces()
            .map(|face| {
                face.iter()
                    .map(|&v| coords[v as usize].map(|d| d.to_f64()))
                    .collect()
            })
            .collect();
        assert_eq!(mine, theirs, "{}", f.display());
    }
}

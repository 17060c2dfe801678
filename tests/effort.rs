//! `EncodeOptions::effort`: every effort codes every mesh of `corpus/` so that it decodes
//! exactly (the stored order kept: vertex for vertex), the container is the same on one
//! and two threads, and the efforts' searches really differ: on the project's own corpus
//! the most effort is never larger than the least, and smaller on some mesh.

mod common;

use subwave::{EncodeOptions, DEFAULT_EFFORT, MAX_EFFORT};

#[test]
fn every_effort_decodes_exactly_and_the_same_on_any_thread_count() {
    let files = common::own_corpus();
    assert!(files.len() >= 10, "only {} meshes", files.len());
    let (mut least, mut most) = (0usize, 0usize);
    for path in &files {
        let bytes = std::fs::read(path).unwrap();
        let input = subwave::load(&bytes, Some(12)).unwrap();
        let code = |effort: u8, threads: usize| {
            let opts = EncodeOptions {
                keep_order: true,
                source: input.source(),
                effort,
                threads,
                ..Default::default()
            };
            subwave::encode_to_vec(&input.mesh, &input.quantization, &opts)
                .unwrap()
                .bytes
        };
        let mut sizes = Vec::new();
        for effort in [1, 3, 5, DEFAULT_EFFORT, 8, MAX_EFFORT] {
            let one = code(effort, 1);
            let dec = subwave::decode_slice(&one).unwrap();
            assert!(
                dec.input_order && dec.mesh == input.mesh,
                "{} effort {effort}: the round trip differs",
                path.display()
            );
            assert!(
                code(effort, 2) == one,
                "{} effort {effort}: two threads differ",
                path.display()
            );
            sizes.push(one.len());
        }
        least += sizes[0];
        most += sizes[sizes.len() - 1];
        assert!(
            sizes[sizes.len() - 1] <= sizes[0],
            "{}: effort 9 ({} B) larger than effort 1 ({} B)",
            path.display(),
            sizes[sizes.len() - 1],
            sizes[0]
        );
    }
    assert!(
        most < least,
        "the efforts made the same containers: {most} B"
    );
}

/// Out-of-range efforts are clamped, not refused: 0 is the least, anything above the
/// most is the most.
#[test]
fn efforts_out_of_range_are_clamped() {
    let bytes = std::fs::read(&common::own_corpus()[0]).unwrap();
    let input = subwave::load(&bytes, Some(12)).unwrap();
    let code = |effort: u8| {
        let opts = EncodeOptions {
            source: input.source(),
            effort,
            ..Default::default()
        };
        subwave::encode_to_vec(&input.mesh, &input.quantization, &opts)
            .unwrap()
            .bytes
    };
    assert!(code(0) == code(1));
    assert!(code(200) == code(MAX_EFFORT));
}

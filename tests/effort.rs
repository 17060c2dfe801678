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

/// The default effort ranks the other transforms by their details' bits without coding
/// them: of each family it codes the first transform and the one ranked best (a mesh of
/// two components may want one more), where effort 7 codes each one it ranks; on the
/// project's corpus the containers are no larger in all than effort 7's by more than 1 %.
#[test]
fn the_default_effort_ranks_transforms_without_coding_them() {
    use std::collections::BTreeSet;
    use std::sync::{Arc, Mutex};
    let (mut coded6, mut coded7, mut size6, mut size7) = (0, 0, 0, 0);
    for path in common::own_corpus() {
        let bytes = std::fs::read(&path).unwrap();
        let input = subwave::load(&bytes, Some(12)).unwrap();
        let code = |effort: u8| {
            let seen = Arc::new(Mutex::new(BTreeSet::new()));
            let log = seen.clone();
            let opts = EncodeOptions {
                source: input.source(),
                effort,
                threads: 1,
                progress: subwave::Progress::new(move |s| {
                    if let subwave::Stage::Level { transform, .. } = s {
                        log.lock().unwrap().insert(transform);
                    }
                }),
                ..Default::default()
            };
            let out = subwave::encode_to_vec(&input.mesh, &input.quantization, &opts).unwrap();
            let seen = seen.lock().unwrap();
            let sqrt2 = seen
                .iter()
                .filter(|t| t.contains("sqrt2") || **t == "ir2w")
                .count();
            (seen.len() - sqrt2, sqrt2, out.bytes.len(), seen.clone())
        };
        let ((cc6, r6, s6, seen6), (cc7, r7, s7, _)) = (code(DEFAULT_EFFORT), code(7));
        // (Coding the short list's three, as effort 6 did before, would show four
        // Catmull-Clark transforms: the first and the three ranked.)
        assert!(
            cc6 <= 3 && r6 <= 2,
            "{}: {cc6} Catmull-Clark and {r6} sqrt(2) transforms coded ({seen6:?})",
            path.display()
        );
        let (n6, n7) = (cc6 + r6, cc7 + r7);
        (coded6, coded7, size6, size7) = (coded6 + n6, coded7 + n7, size6 + s6, size7 + s7);
    }
    assert!(coded6 < coded7, "as many transforms coded: {coded6}");
    assert!(
        size6 * 100 <= size7 * 101,
        "{size6} B at 6 against {size7} B at 7"
    );
}

//! The encoder's thread count changes nothing in the container: every mesh of `corpus/`
//! (Catmull-Clark, polar, sqrt(2), fit, grid and flat, shuffled too; cube_cc4 is both a
//! Catmull-Clark and a sqrt(2) hierarchy, so its two families code at once; the fits'
//! rule sets are fitted at once) coded on one, two and three threads, exact and at 12
//! bits, with and without the stored order.

use subwave::EncodeOptions;

#[test]
fn containers_are_the_same_for_every_thread_count() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/corpus");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "obj"))
        .collect();
    files.sort();
    assert!(files.len() >= 10, "only {} meshes in {dir}", files.len());
    for path in &files {
        let bytes = std::fs::read(path).unwrap();
        for bits in [None, Some(12)] {
            let input = subwave::load(&bytes, bits).unwrap();
            for keep_order in [false, true] {
                let code = |threads: usize| {
                    let opts = EncodeOptions {
                        keep_order,
                        source: input.source(),
                        threads,
                        ..Default::default()
                    };
                    subwave::encode_to_vec(&input.mesh, &input.quantization, &opts)
                        .unwrap()
                        .bytes
                };
                let one = code(1);
                for threads in [2, 3] {
                    assert!(
                        code(threads) == one,
                        "{} bits={bits:?} keep_order={keep_order}: {threads} threads differ",
                        path.display()
                    );
                }
            }
        }
    }
}

/// The decoder's thread count changes nothing in the mesh: a displaced cube refined six
/// times (24,578 vertices: levels large enough for the work beside the reading) coded
/// with every family's transforms and its order kept, decoded on one, two and three threads, exactly the
/// input each time. The codings must include rotated levels (modes 4 and 5: rotations
/// made on another thread) and levels read beside their transform.
#[test]
fn meshes_are_the_same_for_every_decoder_thread_count() {
    use subwave::{DecodeOptions, TransformChoice, Wavelet};
    let obj = subwave_corpus::large_cube(6).to_obj(6);
    let (mut rotated, mut beside) = (0, 0);
    for bits in [Some(12), Some(16)] {
        let input = subwave::load(obj.as_bytes(), bits).unwrap();
        for transform in [
            TransformChoice::Auto,
            TransformChoice::Fixed(Wavelet::Interp6),
            TransformChoice::Fixed(Wavelet::Bicubic),
            TransformChoice::Fixed(Wavelet::Sqrt2Sym),
        ] {
            let bytes = encoded(&input, transform, true);
            let info = subwave::inspect(&bytes, &Default::default()).unwrap();
            for s in info.sections.iter().filter(|s| s.kind == "LEVL") {
                match s.mode {
                    Some(4 | 5) => rotated += 1,
                    Some(0 | 1 | 8) => beside += 1,
                    _ => {}
                }
            }
            let decode = |threads: usize| {
                let opts = DecodeOptions {
                    threads,
                    ..Default::default()
                };
                subwave::decode(&bytes, &opts).unwrap().mesh
            };
            let one = decode(1);
            assert!(
                one == input.mesh,
                "bits={bits:?} {transform:?}: not the input"
            );
            for threads in [2, 3] {
                assert!(
                    decode(threads) == one,
                    "bits={bits:?} {transform:?}: {threads} decoder threads differ"
                );
            }
        }
    }
    assert!(
        rotated >= 4 && beside >= 4,
        "rotated {rotated}, beside {beside}"
    );
}

/// A damaged rotated level (its checksum made again, so that its values are read)
/// decodes the same way on one thread and on two: the same mesh or the same error,
/// whichever block of the level (its rotations made and undone on the other thread) the
/// damage reaches first.
#[test]
fn damaged_levels_fail_the_same_on_every_decoder_thread_count() {
    use subwave::{DecodeOptions, TransformChoice, Wavelet};
    use subwave_container::{Container, ContainerWriter, Limits, SectionKind};
    let obj = subwave_corpus::large_cube(6).to_obj(6);
    let input = subwave::load(obj.as_bytes(), Some(16)).unwrap();
    let bytes = encoded(&input, TransformChoice::Fixed(Wavelet::Interp6), false);
    let info = subwave::inspect(&bytes, &Default::default()).unwrap();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    // The largest rotated level (mode 4 or 5), by its place among the sections.
    let (at, _) = info
        .sections
        .iter()
        .enumerate()
        .filter(|(_, s)| s.kind == "LEVL" && matches!(s.mode, Some(4 | 5)))
        .max_by_key(|(_, s)| s.bytes)
        .expect("a rotated level");
    let payload = c.sections[at].payload;
    assert!(payload.len() > 1000, "{} bytes", payload.len());
    let decode = |b: &[u8], threads: usize| {
        let opts = DecodeOptions {
            threads,
            ..Default::default()
        };
        subwave::decode(b, &opts)
            .map(|d| d.mesh)
            .map_err(|e| e.to_string())
    };
    let mut failed = 0;
    for k in 0..40usize {
        // Past the mode byte and its parameters, across the stream.
        let byte = 8 + k * 7919 % (payload.len() - 8);
        let mut damaged = payload.to_vec();
        damaged[byte] ^= 1 << (k % 8);
        let mut w = ContainerWriter::new();
        for (i, s) in c.sections.iter().enumerate() {
            if s.kind != SectionKind::END {
                w.section(s.kind, if i == at { &damaged } else { s.payload });
            }
        }
        let b = w.finish();
        let one = decode(&b, 1);
        failed += one.is_err() as usize;
        assert!(
            decode(&b, 2) == one,
            "byte {byte}: two threads differ from one"
        );
    }
    assert!(failed >= 10, "only {failed} of 40 damaged levels failed");
}

/// `input` coded with `transform`, its order kept or not.
fn encoded(
    input: &subwave::Loaded,
    transform: subwave::TransformChoice,
    keep_order: bool,
) -> Vec<u8> {
    let opts = EncodeOptions {
        transform,
        keep_order,
        source: input.source(),
        ..Default::default()
    };
    subwave::encode_to_vec(&input.mesh, &input.quantization, &opts)
        .unwrap()
        .bytes
}

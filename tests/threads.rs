//! The encoder's thread count changes nothing in the container: every mesh of `corpus/`
//! (Catmull-Clark, polar, sqrt(2), fit, grid and flat, shuffled too; cube_cc4 is both a
//! Catmull-Clark and a sqrt(2) hierarchy, so its two families code at once) coded on
//! one, two and three threads, exact and at 12 bits, with and without the stored order.

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

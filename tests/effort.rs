//! `EncodeOptions::effort`: every effort codes every mesh of `corpus/` so that it decodes
//! exactly (the stored order kept: vertex for vertex), the container is the same on one
//! and two threads, and the efforts' searches really differ: on the project's own corpus
//! the most effort is never larger than the least, and smaller on some mesh.

mod common;

use subwave::{EncodeOptions, TransformChoice, Wavelet, DEFAULT_EFFORT, MAX_EFFORT};

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

/// The default effort ranks the transforms by their details' bits without coding them:
/// on a small mesh it codes of the Catmull-Clark family at most the first and the two
/// ranked best, of the sqrt(2) family the first alone, where effort 7 codes each one it
/// ranks; on the project's corpus the containers are
/// no larger in all than effort 7's by more than 1 %.
#[test]
fn the_default_effort_ranks_transforms_without_coding_them() {
    use std::collections::BTreeSet;
    use std::sync::{Arc, Mutex};
    let (mut coded6, mut coded7, mut size6, mut size7) = (0, 0, 0, 0);
    for path in common::own_corpus() {
        let bytes = std::fs::read(&path).unwrap();
        let input = subwave::load(&bytes, Some(12)).unwrap();
        // Per search (an encode may search twice: with and without value maps), the
        // transforms it codes.
        let code = |effort: u8| {
            let seen = Arc::new(Mutex::new(vec![BTreeSet::new()]));
            let log = seen.clone();
            let opts = EncodeOptions {
                source: input.source(),
                effort,
                threads: 1,
                progress: subwave::Progress::new(move |s| {
                    let mut log = log.lock().unwrap();
                    match s {
                        subwave::Stage::Recovering => log.push(BTreeSet::new()),
                        subwave::Stage::Level { transform, .. } => {
                            log.last_mut().unwrap().insert(transform);
                        }
                        _ => {}
                    }
                }),
                ..Default::default()
            };
            let out = subwave::encode_to_vec(&input.mesh, &input.quantization, &opts).unwrap();
            let seen = seen.lock().unwrap();
            let is_sqrt2 = |t: &&str| t.contains("sqrt2") || *t == "ir2w";
            let most = |f: &dyn Fn(&&str) -> bool| {
                seen.iter()
                    .map(|s| s.iter().filter(|t| f(t)).count())
                    .max()
                    .unwrap_or(0)
            };
            let all: BTreeSet<&str> = seen.iter().flatten().copied().collect();
            (
                most(&|t| !is_sqrt2(t)),
                most(&|t| is_sqrt2(t)),
                out.bytes.len(),
                all,
            )
        };
        let ((cc6, r6, s6, seen6), (cc7, r7, s7, _)) = (code(DEFAULT_EFFORT), code(7));
        // (Coding the short list's three would show four Catmull-Clark transforms:
        // the first and the three ranked.)
        assert!(
            cc6 <= 3 && r6 <= 1,
            "{}: {cc6} Catmull-Clark and {r6} sqrt(2) transforms coded in a search ({seen6:?})",
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

/// The transforms `auto` (or `transform`) codes on `mesh` at `effort` (one thread), in
/// the order coded, and the container.
fn coded_transforms(
    mesh: &subwave::Mesh,
    effort: u8,
    transform: TransformChoice,
) -> (Vec<&'static str>, Vec<u8>) {
    use std::sync::{Arc, Mutex};
    let seen = Arc::new(Mutex::new(Vec::new()));
    let log = seen.clone();
    let opts = EncodeOptions {
        effort,
        transform,
        threads: 1,
        progress: subwave::Progress::new(move |s| {
            if let subwave::Stage::Level {
                transform,
                level: 1,
                ..
            } = s
            {
                log.lock().unwrap().push(transform);
            }
        }),
        ..Default::default()
    };
    let q = subwave::Quantization::Decimal { decimals: 0 };
    let out = subwave::encode_to_vec(mesh, &q, &opts).unwrap().bytes;
    let seen = seen.lock().unwrap().clone();
    (seen, out)
}

/// On a large mesh (over 32,768 vertices) the default effort codes one Catmull-Clark
/// transform, the one its estimate ranks first of the short list (bicubic, interp6,
/// interp4, lazy), and its large levels choose their mode on a sample of their
/// details: the file decodes exactly and is within 1 % of the smallest coding with
/// each of the short list's transforms at effort 7 (every level mode coded whole).
#[test]
fn on_a_large_mesh_the_default_effort_codes_one_transform_per_family() {
    let mut rng = subwave_corpus::Rng::new(7);
    let mut cube = subwave_corpus::cube().refined(7);
    cube.displace(0.05, 0.0005, &mut rng);
    let mesh = common::to_mesh(&cube, 1e5);
    assert!(mesh.vertex_count() > 32_768);
    let (six, bytes6) = coded_transforms(&mesh, DEFAULT_EFFORT, TransformChoice::Auto);
    let cc = six
        .iter()
        .filter(|t| !t.contains("sqrt2") && **t != "ir2w")
        .count();
    assert_eq!(cc, 1, "coded {six:?}");
    let dec = subwave::decode_slice(&bytes6).unwrap();
    assert_eq!(
        common::fingerprint(&dec.mesh),
        common::fingerprint(&mesh),
        "the round trip differs"
    );
    let listed = [
        Wavelet::Bicubic,
        Wavelet::Interp6,
        Wavelet::Interp4,
        Wavelet::Lazy,
    ];
    let best = listed
        .iter()
        .map(|&w| {
            coded_transforms(&mesh, 7, TransformChoice::Fixed(w))
                .1
                .len()
        })
        .min()
        .unwrap();
    assert!(
        bytes6.len() * 100 <= best * 101,
        "{} B at the default, {best} B at 7 with the short list",
        bytes6.len()
    );
}

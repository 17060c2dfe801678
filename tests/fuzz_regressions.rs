//! Replays every saved fuzz input (`fuzz/regressions/<target>/<name>`) through the same
//! harness function its fuzz target calls, and runs each harness on a fixed set of
//! inputs, so the properties are checked on every CI run even without a fuzzer.

use std::path::Path;

use subwave::fuzz_harness as h;

type Harness = fn(&[u8]);

const TARGETS: [(&str, Harness); 7] = [
    ("decode_tight", h::decode_tight),
    ("container_parse", h::container_parse),
    ("roundtrip_mesh", h::roundtrip_mesh),
    ("lifting_roundtrip", h::lifting_roundtrip),
    ("coder_roundtrip", h::coder_roundtrip),
    ("decode_twice", h::decode_twice),
    ("whole_file", h::whole_file),
];

#[test]
fn saved_fuzz_inputs_still_pass() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions");
    let mut replayed = 0;
    for (name, harness) in TARGETS {
        let dir = root.join(name);
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let data = std::fs::read(e.path()).unwrap();
            harness(&data);
            replayed += 1;
        }
    }
    eprintln!("replayed {replayed} saved fuzz inputs");
}

#[test]
fn harnesses_hold_on_fixed_inputs() {
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus/golden");
    let mut inputs: Vec<Vec<u8>> = std::fs::read_dir(&golden)
        .unwrap()
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "swv"))
        .map(|e| std::fs::read(e.path()).unwrap())
        .collect();
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    for len in 0..160usize {
        let bytes: Vec<u8> = (0..len * 3)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                s as u8
            })
            .collect();
        inputs.push(bytes);
    }
    // Mesh files: the project's own, and each cut short.
    for e in std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus"))
        .unwrap()
        .flatten()
        .filter(|e| {
            let mesh = subwave::Format::from_path(&e.path().to_string_lossy()).is_some();
            mesh && e.metadata().is_ok_and(|m| m.len() < 20_000)
        })
    {
        let file = std::fs::read(e.path()).unwrap();
        for cut in (0..file.len()).step_by(97).chain([file.len()]) {
            h::whole_file(&file[..cut]);
        }
    }
    for data in &inputs {
        for (_, harness) in TARGETS {
            harness(data);
        }
        // Every truncation of the containers too.
        if data.starts_with(&subwave_container::MAGIC) {
            for cut in (0..data.len()).step_by(7) {
                h::decode_tight(&data[..cut]);
                h::decode_twice(&data[..cut]);
            }
        }
    }
}

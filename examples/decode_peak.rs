//! Peak memory of an in-memory decode (issue 4's target: at most 2 x the decoded mesh's
//! own size + 32 MiB). Run under `/usr/bin/time -v`, once with `--read-only` (reads the
//! container, decodes nothing) for the process's baseline:
//! `/usr/bin/time -v target/release/examples/decode_peak FILE.swv [--read-only]`.
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .expect("usage: decode_peak FILE.swv [--read-only]");
    let bytes = std::fs::read(path).expect("read");
    if args.iter().any(|a| a == "--read-only") {
        println!("read {} bytes", bytes.len());
        return;
    }
    let dec = subwave::decode_slice(&bytes).expect("decode");
    let m = &dec.mesh;
    // The mesh's own arrays: positions (3 x i64), face starts and corners (u32).
    let own = m.positions.len() * 24 + m.face_starts.len() * 4 + m.faces.len() * 4;
    println!(
        "{} vertices, {} faces; mesh arrays {:.1} MiB; limit 2 x that + 32 MiB = {:.1} MiB",
        m.vertex_count(),
        m.face_count(),
        own as f64 / 1048576.0,
        (2 * own) as f64 / 1048576.0 + 32.0
    );
}

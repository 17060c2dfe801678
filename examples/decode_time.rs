//! Wall-clock time of an in-memory decode (issue 4's decode speed), single-threaded:
//! the container is read once, then decoded `ROUNDS` times (default 15); prints the
//! median, the fastest and the slowest decode in milliseconds.
//! `target/release/examples/decode_time FILE.swv [ROUNDS] [THREADS]` (the decoder's
//! threads, default 1).
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().expect("usage: decode_time FILE.swv [ROUNDS]");
    let rounds: usize = args.get(1).map_or(15, |r| r.parse().expect("ROUNDS"));
    let opts = subwave::DecodeOptions {
        threads: args.get(2).map_or(1, |t| t.parse().expect("THREADS")),
        ..Default::default()
    };
    let bytes = std::fs::read(path).expect("read");
    let mut ms: Vec<f64> = (0..rounds.max(1))
        .map(|_| {
            let t = Instant::now();
            let dec = subwave::decode(&bytes, &opts).expect("decode");
            let dt = t.elapsed().as_secs_f64() * 1e3;
            std::hint::black_box(dec);
            dt
        })
        .collect();
    ms.sort_by(f64::total_cmp);
    println!(
        "{path}: median {:.2} ms (min {:.2}, max {:.2}) over {} decodes",
        ms[ms.len() / 2],
        ms[0],
        ms[ms.len() - 1],
        ms.len()
    );
}

//! Criterion benches on a generated mesh of 1.57 M vertices (a displaced cube refined 9
//! times, `subwave_corpus::large_cube(9)`), quantised to 16 bits: the lifting
//! transforms alone, the entropy coder alone, and the whole codec.
//!
//! `cargo bench --bench codec` (set SUBWAVE_BENCH_LEVELS=7 for a quicker 98 K-vertex run).

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use subwave::{EncodeOptions, TransformChoice, Wavelet};
use subwave_codec::entropy::{Decoder, Encoder, IntModel};
use subwave_codec::topology::{canonicalise, cc, Topo};
use subwave_codec::transform::{analyse, synthesise};

fn mesh() -> subwave::Loaded {
    let levels = std::env::var("SUBWAVE_BENCH_LEVELS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(9);
    let text = subwave_corpus::large_cube(levels).to_obj(6);
    subwave::load(text.as_bytes(), Some(16)).unwrap()
}

fn benches(c: &mut Criterion) {
    let m = mesh();
    let n = m.mesh.vertex_count() as u64;
    eprintln!("bench mesh: {n} vertices");

    // Transforms: analysis and synthesis of every level, one axis.
    let mut topo = Topo::new(m.mesh.vertex_count());
    topo.idx = m.mesh.faces.clone();
    topo.starts = m.mesh.face_starts.clone();
    let rec = cc::recover(topo.nv, &topo, 16).unwrap();
    let canon = canonicalise(&rec, true).unwrap();
    let x: Vec<i64> = canon
        .order
        .iter()
        .map(|&o| m.mesh.positions[o as usize][2])
        .collect();
    let mut g = c.benchmark_group("transform");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n));
    for w in [Wavelet::Bilinear, Wavelet::Bicubic] {
        g.bench_function(format!("{}_analyse_one_axis", w.name()), |b| {
            b.iter_batched(
                || x.clone(),
                |mut v| {
                    for l in canon.levels.iter().rev() {
                        analyse(l, w, &mut v[..l.fine_nv()]);
                    }
                    v
                },
                BatchSize::LargeInput,
            )
        });
        let mut lifted = x.clone();
        for l in canon.levels.iter().rev() {
            analyse(l, w, &mut lifted[..l.fine_nv()]);
        }
        g.bench_function(format!("{}_synthesise_one_axis", w.name()), |b| {
            b.iter_batched(
                || lifted.clone(),
                |mut v| {
                    for l in &canon.levels {
                        synthesise(l, w, &mut v[..l.fine_nv()]);
                    }
                    v
                },
                BatchSize::LargeInput,
            )
        });
    }
    g.finish();

    // The entropy coder: one million small integers.
    let values: Vec<i64> = (0..1_000_000i64).map(|i| ((i * 7919) % 41) - 20).collect();
    let mut g = c.benchmark_group("coder");
    g.sample_size(10);
    g.throughput(Throughput::Elements(values.len() as u64));
    g.bench_function("encode_1M_ints", |b| {
        b.iter(|| {
            let mut e = Encoder::new();
            let mut m = IntModel::new();
            for &v in &values {
                e.int(&mut m, v);
            }
            e.finish()
        })
    });
    let mut e = Encoder::new();
    let mut im = IntModel::new();
    for &v in &values {
        e.int(&mut im, v);
    }
    let stream = e.finish();
    g.bench_function("decode_1M_ints", |b| {
        b.iter(|| {
            let mut d = Decoder::new(&stream, "bench").unwrap();
            let mut m = IntModel::new();
            let mut s = 0i64;
            for _ in 0..values.len() {
                s += d.int(&mut m).unwrap();
            }
            s
        })
    });
    // The range decoder with the cheapest model there is (8 raw bits per symbol: a
    // shift and a mask): what constriction's decoder costs per symbol by itself.
    let mut e = Encoder::new();
    for &v in &values {
        e.bits((v + 20) as u64, 8);
    }
    let raw = e.finish();
    g.bench_function("decode_1M_raw_symbols", |b| {
        b.iter(|| {
            let mut d = Decoder::new(&raw, "bench").unwrap();
            let mut s = 0u64;
            for _ in 0..values.len() {
                s += d.bits(8).unwrap();
            }
            s
        })
    });
    g.finish();

    // The whole codec.
    let mut g = c.benchmark_group("codec");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n));
    let fixed = EncodeOptions {
        transform: TransformChoice::Fixed(Wavelet::Bicubic),
        ..Default::default()
    };
    g.bench_function("encode_bicubic", |b| {
        b.iter(|| subwave::encode_to_vec(&m.mesh, &m.quantization, &fixed).unwrap())
    });
    g.bench_function("encode_auto", |b| {
        b.iter(|| {
            subwave::encode_to_vec(&m.mesh, &m.quantization, &EncodeOptions::default()).unwrap()
        })
    });
    let enc = subwave::encode_to_vec(&m.mesh, &m.quantization, &EncodeOptions::default()).unwrap();
    eprintln!(
        "bench mesh: {} bytes, {:.3} bpv, {}",
        enc.bytes.len(),
        enc.bytes.len() as f64 * 8.0 / n as f64,
        enc.header.transform.name()
    );
    g.bench_function("decode", |b| {
        b.iter(|| subwave::decode_slice(&enc.bytes).unwrap())
    });
    g.finish();
}

criterion_group!(codec, benches);
criterion_main!(codec);

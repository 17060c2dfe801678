//! Times the phases of encoding and decoding one mesh, to see where time goes:
//! `cargo run --release --example phases -- MESH.obj [Q]`.

use std::time::Instant;

use subwave_codec::topology::{canonicalise, cc, Level, Topo};
use subwave_codec::transform::{analyse, synthesise, Wavelet};

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().expect("usage: phases MESH [Q]");
    let bits = args.get(1).and_then(|q| q.parse().ok()).or(Some(16));
    let bytes = std::fs::read(path).expect("read");
    let t = Instant::now();
    let m = subwave::load(&bytes, bits).expect("load");
    println!("load+quantise      {:8.1} ms", ms(t));
    let mut topo = Topo::new(m.mesh.vertex_count());
    topo.idx = m.mesh.faces.clone();
    topo.starts = m.mesh.face_starts.clone();
    let t = Instant::now();
    let recs = cc::recover_all(topo.nv, &topo, 16);
    println!("recover ({} alt)    {:8.1} ms", recs.len(), ms(t));
    let t = Instant::now();
    let canon = canonicalise(&recs[0], true).expect("canon");
    println!("canonicalise       {:8.1} ms", ms(t));
    let x: Vec<i64> = canon
        .order
        .iter()
        .map(|&o| m.mesh.positions[o as usize][0])
        .collect();
    for w in Wavelet::ALL {
        let mut v = x.clone();
        let t = Instant::now();
        for l in canon.levels.iter().rev() {
            analyse(l, w, &mut v[..l.fine_nv()]);
        }
        let a = ms(t);
        let t = Instant::now();
        for l in &canon.levels {
            synthesise(l, w, &mut v[..l.fine_nv()]);
        }
        println!(
            "{:10} 1 axis   analyse {:6.1} ms  synthesise {:6.1} ms",
            w.name(),
            a,
            ms(t)
        );
    }
    let t = Instant::now();
    let mut tp = canon.base.clone();
    for _ in 0..canon.levels.len() {
        let l = Level::new(&tp).expect("level");
        tp = l.fine();
    }
    println!(
        "refine topology    {:8.1} ms (Level::new + fine, all levels)",
        ms(t)
    );
    let opts = subwave::EncodeOptions {
        transform: subwave::TransformChoice::Fixed(Wavelet::Bicubic),
        ..Default::default()
    };
    let t = Instant::now();
    let enc = subwave::encode_to_vec(&m.mesh, &m.quantization, &opts).expect("encode");
    println!("encode bicubic     {:8.1} ms", ms(t));
    let t = Instant::now();
    let auto =
        subwave::encode_to_vec(&m.mesh, &m.quantization, &Default::default()).expect("encode");
    println!(
        "encode auto        {:8.1} ms ({})",
        ms(t),
        auto.header.transform.name()
    );
    let t = Instant::now();
    let _ = subwave::decode_slice(&enc.bytes).expect("decode");
    println!("decode bicubic     {:8.1} ms", ms(t));
}

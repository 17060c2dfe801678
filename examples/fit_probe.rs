//! How well Catmull-Clark refinement of a least-squares control mesh predicts a mesh's
//! finest positions (SPEC.md 9.10), per recovered hierarchy and per rule set (plain,
//! limit surface; no creases): the fit's residual RMS per axis, then per precision B
//! the share of nonzero residuals and their order-0 entropy.
//! `cargo run --release --example fit_probe -- MESH [Q | exact]`
use subwave_codec::topology::{canonicalise, cc, Topo};
use subwave_codec::transform::fit::{defect, refine, Operator, Rules, Runs};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().expect("usage: fit_probe MESH [Q | exact]");
    // Q bits, or `exact` for the file's own values.
    let bits: Option<u8> = match args.get(1).map(String::as_str) {
        Some("exact") => None,
        q => Some(q.map_or(16, |q| q.parse().expect("Q or exact"))),
    };
    let mesh = subwave::load(&std::fs::read(path).expect("read"), bits)
        .expect("load")
        .mesh;
    let mut topo = Topo::new(mesh.vertex_count());
    topo.idx = mesh.faces.clone();
    topo.starts = mesh.face_starts.clone();
    for rec in cc::recover_all(topo.nv, &topo, 16) {
        let canon = canonicalise(&rec, true).expect("canonical");
        let nb = canon.base.nv;
        let y: Vec<Vec<i64>> = (0..3)
            .map(|k| {
                canon
                    .order
                    .iter()
                    .map(|&o| mesh.positions[o as usize][k])
                    .collect()
            })
            .collect();
        let last = canon.levels.last().expect("a level");
        let finest = last.next();
        let d: Vec<f64> = y
            .iter()
            .map(|x| defect(last, x).unwrap_or(f64::NAN))
            .collect();
        let runs = Runs::new(&canon.levels, &finest);
        let r: Vec<f64> = y
            .iter()
            .map(|x| {
                runs.as_ref()
                    .and_then(|r| r.roughness(x))
                    .unwrap_or(f64::NAN)
            })
            .collect();
        println!(
            "V {} base {nb} levels {}: defect {d:.2?}, roughness {r:.2?}",
            topo.nv,
            canon.levels.len()
        );
        for limit in [false, true] {
            let rules = Rules {
                limit,
                ..Rules::default()
            };
            println!(" limit {limit}");
            let op = Operator::new(&canon.levels, &finest, &rules);
            let fine: Vec<[f64; 3]> = (0..topo.nv)
                .map(|i| std::array::from_fn(|k| y[k][i] as f64))
                .collect();
            let t = std::time::Instant::now();
            let b = op.fit(&fine, &fine[..nb], &[], 400, 1e-5);
            let p = op.apply(&b);
            let rms: Vec<f64> = (0..3)
                .map(|k| {
                    let s: f64 = fine
                        .iter()
                        .zip(&p)
                        .map(|(f, q)| (f[k] - q[k]).powi(2))
                        .sum();
                    (s / fine.len() as f64).sqrt()
                })
                .collect();
            println!(
                "  fit {:.1} ms, residual rms {rms:.4?}",
                t.elapsed().as_secs_f64() * 1e3
            );
            for extra in [0u32, 4, 6, 8, 10, 12] {
                let (mut nonzero, mut entropy) = (0usize, 0.0);
                let s = (1i64 << extra) as f64;
                let mut xs: [Vec<i64>; 3] =
                    std::array::from_fn(|k| b.iter().map(|v| (v[k] * s).round() as i64).collect());
                refine(&canon.levels, &finest, &rules, &mut xs).expect("within bounds");
                for (k, x) in xs.iter().enumerate() {
                    let half = (1i64 << extra) >> 1;
                    let mut hist = std::collections::BTreeMap::new();
                    for (i, &v) in x.iter().enumerate() {
                        *hist
                            .entry(y[k][i] - ((v + half) >> extra))
                            .or_insert(0usize) += 1;
                    }
                    for (&r, &c) in &hist {
                        let q = c as f64 / x.len() as f64;
                        entropy -= q * q.log2();
                        nonzero += if r != 0 { c } else { 0 };
                    }
                }
                println!(
                    "  B {extra:2}: nonzero {:.4}, order-0 entropy {:.3} bits per value",
                    nonzero as f64 / (3 * topo.nv) as f64,
                    entropy / 3.0
                );
            }
        }
    }
}

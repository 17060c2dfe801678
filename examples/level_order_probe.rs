//! How a file's vertex order relates to its recovered hierarchy level by level
//! (informative, for ORDR's design): per level, whether the level's edge points and face
//! points are each one contiguous range of input numbers, and how their order within
//! that range follows their coarse edges' and faces' input numbers.
//! `cargo run --release --example level_order_probe -- MESH`
use subwave_codec::topology::{canonicalise, cc, Topo};

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: level_order_probe MESH");
    let mesh = subwave::load(&std::fs::read(&path).expect("read"), None)
        .expect("load")
        .mesh;
    let mut topo = Topo::new(mesh.vertex_count());
    topo.idx = mesh.faces.clone();
    topo.starts = mesh.face_starts.clone();
    for rec in cc::recover_all(topo.nv, &topo, 16).into_iter().take(1) {
        let canon = canonicalise(&rec, false).expect("canonical");
        let inp = &canon.order;
        for (l, level) in canon.levels.iter().enumerate() {
            let (nv, ne, nf) = (level.nv, level.ne(), level.nf());
            let range = |lo: usize, hi: usize| {
                let v: Vec<u32> = (lo..hi).map(|c| inp[c]).collect();
                (v.iter().min().copied(), v.iter().max().copied(), v)
            };
            let (emin, emax, ev) = range(nv, nv + ne);
            let (fmin, fmax, fv) = range(nv + ne, nv + ne + nf);
            println!("level {l}: nv {nv} ne {ne} nf {nf}; edge points input {emin:?}..{emax:?}, face points {fmin:?}..{fmax:?}");
            // Edge points sorted by input number: their edges' ends' input numbers.
            let mut by: Vec<(u32, usize)> = ev.iter().enumerate().map(|(e, &i)| (i, e)).collect();
            by.sort_unstable();
            let ends: Vec<(u32, u32)> = by
                .iter()
                .take(24)
                .map(|&(_, e)| {
                    let [a, b] = level.edges[e];
                    (inp[a as usize], inp[b as usize])
                })
                .collect();
            println!("  first edges in input order (ends' input numbers): {ends:?}");
            let mut fby: Vec<(u32, usize)> = fv.iter().enumerate().map(|(f, &i)| (i, f)).collect();
            fby.sort_unstable();
            let corners: Vec<Vec<u32>> = fby
                .iter()
                .take(8)
                .map(|&(_, f)| {
                    level
                        .coarse
                        .face(f)
                        .iter()
                        .map(|&c| inp[c as usize])
                        .collect()
                })
                .collect();
            println!("  first faces in input order (corners' input numbers): {corners:?}");
        }
    }
}

//! How a file's vertex and face order relates to its recovered Catmull-Clark hierarchy's
//! base elements (base vertices, base edges, base faces): whether each element's points
//! come as one block, and in which order within it (informative, for ORDR's design).
//! `cargo run --release --example order_probe -- MESH`
use subwave_codec::topology::{canonicalise, cc, Topo};

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum El {
    V(u32),
    E(u32),
    F(u32),
}

fn main() {
    let path = std::env::args().nth(1).expect("usage: order_probe MESH");
    let mesh = subwave::load(&std::fs::read(&path).expect("read"), None)
        .expect("load")
        .mesh;
    let mut topo = Topo::new(mesh.vertex_count());
    topo.idx = mesh.faces.clone();
    topo.starts = mesh.face_starts.clone();
    for rec in cc::recover_all(topo.nv, &topo, 16) {
        let canon = canonicalise(&rec, false).expect("canonical");
        probe(&topo, &canon);
    }
}

fn probe(topo: &Topo, canon: &subwave_codec::topology::Canonical) {
    let levels = &canon.levels;
    let base = &levels[0];
    let l = levels.len() as u32;
    let s = 1i64 << l;
    let nb = base.nv;
    let quads = (0..base.nf())
        .filter(|&f| base.coarse.face(f).len() == 4)
        .count();
    println!(
        "V {} base: {} vertices, {} edges, {} faces ({} quads), {} levels",
        topo.nv,
        nb,
        base.ne(),
        base.nf(),
        quads,
        l
    );
    // Per vertex: its element and coordinates (t along a base edge from its first end,
    // or (u, v) in a quad base face's frame, corner 0 at (0, 0), corner 1 at (s, 0)).
    let mut el: Vec<El> = (0..nb as u32).map(El::V).collect();
    let mut uv: Vec<[i64; 2]> = vec![[0, 0]; nb];
    let corner = [[0, 0], [s, 0], [s, s], [0, s]];
    let t_on = |el: &[El], uv: &[[i64; 2]], v: usize, e: u32| -> i64 {
        match el[v] {
            El::V(x) => {
                if base.edges[e as usize][0] == x {
                    0
                } else {
                    s
                }
            }
            El::E(_) => uv[v][0],
            El::F(_) => panic!("face point on an edge"),
        }
    };
    let frame = |el: &[El], uv: &[[i64; 2]], f: u32, v: usize| -> [i64; 2] {
        let c = base.coarse.face(f as usize);
        if c.len() != 4 {
            return [-1, -1];
        }
        match el[v] {
            El::F(_) => uv[v],
            El::V(x) => corner[c.iter().position(|&y| y == x).expect("a corner")],
            El::E(e) => {
                let st = base.coarse.starts[f as usize] as usize;
                let i = (0..4)
                    .find(|&i| base.face_edges[st + i] == e)
                    .expect("a side");
                let (p, q) = (corner[i], corner[(i + 1) % 4]);
                let t = uv[v][0];
                let (p, q) = if base.edges[e as usize][0] == c[i] {
                    (p, q)
                } else {
                    (q, p)
                };
                [p[0] + (q[0] - p[0]) * t / s, p[1] + (q[1] - p[1]) * t / s]
            }
        }
    };
    for level in levels {
        let (nv, ne) = (level.nv, level.ne());
        el.truncate(nv);
        uv.truncate(nv);
        let mut new_el = Vec::with_capacity(ne + level.nf());
        let mut new_uv = Vec::with_capacity(ne + level.nf());
        for (j, &[a, b]) in level.edges.iter().enumerate() {
            let (a, b) = (a as usize, b as usize);
            let owner = match (el[a], el[b]) {
                (El::F(f), _) | (_, El::F(f)) => El::F(f),
                (El::E(e), _) | (_, El::E(e)) => El::E(e),
                (El::V(_), El::V(_)) => El::E(j as u32),
            };
            let c = match owner {
                El::E(e) => [(t_on(&el, &uv, a, e) + t_on(&el, &uv, b, e)) / 2, 0],
                El::F(f) => {
                    let (p, q) = (frame(&el, &uv, f, a), frame(&el, &uv, f, b));
                    [(p[0] + q[0]) / 2, (p[1] + q[1]) / 2]
                }
                El::V(_) => unreachable!(),
            };
            new_el.push(owner);
            new_uv.push(c);
        }
        for g in 0..level.nf() {
            let cs = level.coarse.face(g);
            let f = cs
                .iter()
                .find_map(|&v| match el[v as usize] {
                    El::F(f) => Some(f),
                    _ => None,
                })
                .unwrap_or(g as u32);
            let mut sum = [0i64; 2];
            for &v in cs {
                let p = frame(&el, &uv, f, v as usize);
                sum[0] += p[0];
                sum[1] += p[1];
            }
            let k = cs.len() as i64;
            new_el.push(El::F(f));
            new_uv.push([sum[0] / k, sum[1] / k]);
        }
        el.extend(new_el);
        uv.extend(new_uv);
    }
    assert_eq!(el.len(), topo.nv);
    // The elements in input order.
    let mut input = vec![0usize; topo.nv];
    for (c, &o) in canon.order.iter().enumerate() {
        input[o as usize] = c;
    }
    let seq: Vec<El> = input.iter().map(|&c| el[c]).collect();
    let blocks = 1 + seq.windows(2).filter(|w| w[0] != w[1]).count();
    let elements = nb + base.ne() + base.nf();
    println!("vertex blocks {blocks} for {elements} elements");
    let kinds: Vec<char> = seq
        .iter()
        .map(|e| match e {
            El::V(_) => 'v',
            El::E(_) => 'e',
            El::F(_) => 'f',
        })
        .collect();
    let mut runs = Vec::new();
    for (i, &k) in kinds.iter().enumerate() {
        if i == 0 || k != kinds[i - 1] {
            runs.push((k, 1));
        } else {
            runs.last_mut().unwrap().1 += 1;
        }
    }
    println!("kinds in input order: {:?}", &runs[..runs.len().min(12)]);
    // Element order: ranks of first appearance.
    let firsts: Vec<El> = {
        let mut seen = std::collections::HashSet::new();
        seq.iter()
            .filter(|e| seen.insert(format!("{e:?}")))
            .copied()
            .collect()
    };
    let show: Vec<String> = firsts.iter().take(40).map(|e| format!("{e:?}")).collect();
    println!("elements, first 40: {}", show.join(" "));
    // Faces in input order: the base face each lies in (the face element among its
    // corners'), as blocks.
    let face_el: Vec<Option<u32>> = (0..topo.nf())
        .map(|f| {
            topo.face(f)
                .iter()
                .find_map(|&v| match el[input[v as usize]] {
                    El::F(b) => Some(b),
                    _ => None,
                })
        })
        .collect();
    let face_blocks = 1 + face_el.windows(2).filter(|w| w[0] != w[1]).count();
    println!("face blocks {face_blocks} for {} base faces", base.nf());
    // Base elements by the input ranks of their base vertices.
    let vrank: std::collections::HashMap<u32, usize> = firsts
        .iter()
        .filter_map(|e| match e {
            El::V(v) => Some(*v),
            _ => None,
        })
        .enumerate()
        .map(|(i, v)| (v, i))
        .collect();
    let es: Vec<String> = firsts
        .iter()
        .filter_map(|e| match e {
            El::E(e) => Some(*e),
            _ => None,
        })
        .take(60)
        .map(|e| {
            let [a, b] = base.edges[e as usize];
            format!("{}-{}", vrank[&a], vrank[&b])
        })
        .collect();
    println!("edges by vertex rank: {}", es.join(" "));
    let fs: Vec<String> = firsts
        .iter()
        .filter_map(|e| match e {
            El::F(f) => Some(*f),
            _ => None,
        })
        .take(40)
        .map(|f| {
            let c: Vec<String> = base
                .coarse
                .face(f as usize)
                .iter()
                .map(|v| vrank[v].to_string())
                .collect();
            c.join(",")
        })
        .collect();
    println!("faces by vertex rank: {}", fs.join(" "));
    // Within edge blocks: t sequence of the first few; within face blocks, the (u, v).
    let mut shown = 0;
    let mut i = 0;
    while i < seq.len() && shown < 6 {
        let j = (i..seq.len())
            .find(|&j| seq[j] != seq[i])
            .unwrap_or(seq.len());
        if let El::E(e) = seq[i] {
            if shown < 3 {
                let ts: Vec<i64> = (i..j).map(|k| uv[input[k]][0]).collect();
                println!("edge {e} {:?}: t {ts:?}", base.edges[e as usize]);
                shown += 1;
            }
        }
        if let El::F(f) = seq[i] {
            if shown >= 3 || !matches!(seq[0], El::E(_)) {
                let ts: Vec<[i64; 2]> = (i..j).take(20).map(|k| uv[input[k]]).collect();
                println!("face {f} {:?}: uv {ts:?}", base.coarse.face(f as usize));
                shown += 1;
            }
        }
        i = j;
    }
}

//! How far a Blender export is from the project's integer subdivision rules (SPEC.md
//! 9.10) applied to Blender's own control mesh: no fit, so a miss is a rule's.
//! `cargo run --release --example rules_probe -- FINE.obj CONTROL.txt [plain] [extra=N]
//! [caps=Q]`
//! (`extra=N`: the rules' extra levels, `Rules::extra_levels`: N more levels refined
//! before the limit, where a finite sharpness left is smooth, as OpenSubdiv's patches
//! are past their isolation level, Blender's Quality; `caps=Q`: OpenSubdiv's end-cap
//! patches from level Q, `Rules::end_caps`.)
//! CONTROL.txt (written by `benches/blender/make_rules_set.py --control`): lines
//! `v x y z` (the control mesh in the exported file's frame, its vertices first in the
//! export), `e a b crease` and `c a crease` (edge and vertex creases, Blender's 0..1).
//! Prints, per kind of finest vertex (base, edge, face points of the levels), how many
//! miss by more than the rounding and the largest miss, on the file's 1e-6 grid.
use subwave_codec::topology::{canonicalise, cc, Topo};
use subwave_codec::transform::fit::{refine, Rules, SHARP_INFINITE, SHARP_ONE};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (fine_path, control_path) = (&args[0], &args[1]);
    let limit = !args.iter().any(|a| a == "plain");
    let corners = args.iter().any(|a| a == "corners");
    let mesh = subwave::load(&std::fs::read(fine_path).expect("read"), None)
        .expect("load")
        .mesh;
    let text = std::fs::read_to_string(control_path).expect("control");
    let mut control: Vec<[i64; 3]> = Vec::new();
    let mut edges: Vec<(u32, u32, f64)> = Vec::new();
    let mut verts: Vec<(u32, f64)> = Vec::new();
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.first().copied() {
            Some("v") => control.push(std::array::from_fn(|k| {
                (w[k + 1].parse::<f64>().expect("x") * 1e6).round() as i64
            })),
            Some("e") => edges.push((
                w[1].parse().unwrap(),
                w[2].parse().unwrap(),
                w[3].parse().unwrap(),
            )),
            Some("c") => verts.push((w[1].parse().unwrap(), w[2].parse().unwrap())),
            _ => {}
        }
    }
    let sharp = |c: f64| -> u32 {
        let s = 10.0 * c * c;
        if s >= 10.0 {
            SHARP_INFINITE
        } else {
            (s * SHARP_ONE as f64).round() as u32
        }
    };
    let mut topo = Topo::new(mesh.vertex_count());
    topo.idx = mesh.faces.clone();
    topo.starts = mesh.face_starts.clone();
    let nb_in = control.len();
    for rec in cc::recover_all(topo.nv, &topo, 16) {
        let canon = canonicalise(&rec, true).expect("canonical");
        let nb = canon.base.nv;
        // The control mesh's vertices are the input's first: this hierarchy's base?
        if nb != nb_in || canon.order[..nb].iter().any(|&o| o as usize >= nb) {
            println!("hierarchy with base {nb}: not the control mesh's");
            continue;
        }
        let mut to_canon = vec![0u32; nb];
        for (c, &o) in canon.order[..nb].iter().enumerate() {
            to_canon[o as usize] = c as u32;
        }
        let base = &canon.levels[0];
        let mut rules = Rules {
            limit,
            corners,
            ..Rules::default()
        };
        if !edges.is_empty() {
            rules.sharpness = vec![0; base.ne()];
            for &(a, b, c) in &edges {
                let (a, b) = (to_canon[a as usize], to_canon[b as usize]);
                let e = base
                    .edges
                    .iter()
                    .position(|&[x, y]| (x, y) == (a, b) || (x, y) == (b, a))
                    .expect("a base edge");
                rules.sharpness[e] = sharp(c);
            }
        }
        if !verts.is_empty() {
            rules.vertex_sharpness = vec![0; nb];
            for &(v, c) in &verts {
                rules.vertex_sharpness[to_canon[v as usize] as usize] = sharp(c);
            }
        }
        let mut x: [Vec<i64>; 3] = std::array::from_fn(|k| {
            (0..nb)
                .map(|c| control[canon.order[c] as usize][k])
                .collect()
        });
        let finest = canon.levels.last().expect("a level").next();
        rules.extra_levels = args
            .iter()
            .find_map(|a| a.strip_prefix("extra="))
            .map(|n| n.parse().expect("extra=N"));
        rules.end_caps = args
            .iter()
            .find_map(|a| a.strip_prefix("caps="))
            .map(|n| n.parse().expect("caps=Q"));
        refine(&canon.levels, &finest, &rules, &mut x).expect("extra levels within bounds");
        // Kinds: the level a vertex first appears at, and whether it is a vertex, edge
        // or face point there.
        let mut starts = vec![(0usize, "base")];
        for (i, l) in canon.levels.iter().enumerate() {
            starts.push((l.nv, if i == 0 { "edge1" } else { "edge" }));
            starts.push((l.nv + l.ne(), "face"));
        }
        let mut worst = vec![(0usize, 0usize, 0i64); starts.len()];
        for (c, &o) in canon.order.iter().enumerate() {
            let o = o as usize;
            let miss = (0..3)
                .map(|k| (x[k][c] - mesh.positions[o][k]).abs())
                .max()
                .unwrap_or(0);
            let kind = starts.iter().rposition(|&(s, _)| c >= s).unwrap();
            if kind == 0 && miss > 1 && args.iter().any(|a| a == "list") {
                let l = &canon.levels[0];
                let bd = l
                    .v_edges(c)
                    .iter()
                    .filter(|&&e| l.is_boundary(e as usize))
                    .count();
                let sizes: Vec<usize> = l
                    .v_faces(c)
                    .iter()
                    .map(|&f| l.coarse.face(f as usize).len())
                    .collect();
                println!("    base {c} (input {o}): miss {miss}, {} edges, faces {sizes:?}, {bd} boundary edges", l.v_edges(c).len());
            }
            let w = &mut worst[kind];
            w.0 += 1;
            if miss > 1 {
                w.1 += 1;
            }
            w.2 = w.2.max(miss);
        }
        println!(
            "hierarchy with base {nb}, {} levels, rules {:?}",
            canon.levels.len(),
            (
                rules.limit,
                rules.sharpness.iter().filter(|&&s| s > 0).count(),
                rules.vertex_sharpness.iter().filter(|&&s| s > 0).count()
            )
        );
        for (i, (n, off, max)) in worst.iter().enumerate() {
            if *n > 0 {
                println!(
                    "  from {:>6} ({:5}): {n:6} vertices, {off:6} off by > 1, largest {max}",
                    starts[i].0, starts[i].1
                );
            }
        }
    }
}

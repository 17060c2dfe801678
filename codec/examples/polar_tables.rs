//! Writes the frozen tables of the integer polar transforms (SPEC.md 9.9) from the
//! floating-point reference in `subwave_codec::transform::polar::reference` (gamma of eq. 1; the lifting
//! weights t, s and w solved from eq. 7/8 with the appendix's inner products), as Rust
//! source: `cargo run -p subwave-codec --example polar_tables > codec/src/discs/tables.rs`.
use subwave_codec::transform::polar::reference::{
    circular_weights_fixed, gamma_fixed, radial_weights_fixed,
};

fn list<T: ToString>(xs: impl IntoIterator<Item = T>) -> String {
    xs.into_iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

fn main() {
    let (lo, hi) = (4, 64);
    let count = hi - lo + 1;
    println!("//! The frozen weights of the integer polar transforms (SPEC.md 9.9), times 2^16:");
    println!("//! gamma (summing to exactly 2^15) and the lifting weights t, s and w, as");
    println!(
        "//! `crate::transform::polar::reference::gamma_fixed`, `radial_weights_fixed` and `circular_weights_fixed`"
    );
    println!("//! compute them (a test checks it). Written by");
    println!("//! `cargo run -p subwave-codec --example polar_tables`.");
    println!("//! Valences {lo}..={hi}; index = valence - {lo}.");
    println!();
    println!("/// The smallest valence in the per-valence tables.");
    println!("pub const GAMMA_MIN: usize = {lo};");
    println!();
    println!("/// Gamma_0..gamma_(n-1) per valence n.");
    println!("pub const GAMMA: [&[i32]; {count}] = [");
    for n in lo..=hi {
        println!("    &[{}],", list(gamma_fixed(n)));
    }
    println!("];");
    println!();
    println!("/// The circular lifting weights w_(-2)..w_3 (Zhao et al. Table 2).");
    println!(
        "pub const LIFT_W: [i32; 6] = [{}];",
        list(circular_weights_fixed())
    );
    println!();
    println!("/// The radial lifting weights t_0..t_(n+1) per valence n (Table 1's t): the");
    println!("/// pole, ring 1 at spokes j..j+n-1, ring 2 at spoke j.");
    println!("pub const LIFT_T: [&[i32]; {count}] = [");
    for n in lo..=hi {
        println!("    &[{}],", list(radial_weights_fixed(n).0));
    }
    println!("];");
    println!();
    println!("/// The radial lifting weights s_0..s_7 per valence and case (Table 1's s, columns");
    println!("/// a, b, c: segments 1, 2 and >= 3 beyond the pole's own).");
    println!("pub const LIFT_S: [[[i32; 8]; 3]; {count}] = [");
    for n in lo..=hi {
        let s = radial_weights_fixed(n).1;
        println!("    [");
        for row in s {
            println!("        [{}],", list(row));
        }
        println!("    ],");
    }
    println!("];");
}

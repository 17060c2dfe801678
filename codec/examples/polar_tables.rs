//! Writes the frozen gamma table of the integer polar transform (SPEC.md 9.9) from the
//! floating-point reference in `subwave_codec::polar`, as Rust source:
//! `cargo run -p subwave-codec --example polar_tables > codec/src/discs/tables.rs`.
use subwave_codec::polar::gamma_fixed;

fn main() {
    let (lo, hi) = (4, 64);
    println!("//! The frozen gamma weights of the integer polar transform (SPEC.md 9.9), times");
    println!("//! 2^16, summing to exactly 2^15: what `crate::polar::gamma_fixed` computes (a");
    println!(
        "//! test checks it). Written by `cargo run -p subwave-codec --example polar_tables`."
    );
    println!("//! Valences {lo}..={hi}; index = valence - {lo}; entry k = gamma_k.");
    println!();
    println!("/// The smallest valence in [`GAMMA`].");
    println!("pub const GAMMA_MIN: usize = {lo};");
    println!();
    println!("/// Gamma_0..gamma_(n-1) per valence n.");
    println!("pub const GAMMA: [&[i32]; {}] = [", hi - lo + 1);
    for n in lo..=hi {
        let row: Vec<String> = gamma_fixed(n).iter().map(|g| g.to_string()).collect();
        println!("    &[{}],", row.join(", "));
    }
    println!("];");
}

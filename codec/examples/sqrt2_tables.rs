//! Prints the frozen IR2W tables (SPEC.md 9.7) from the solver in
//! `subwave_codec::transform::sqrt2::solve`: `cargo run -p subwave-codec --example sqrt2_tables`.
use subwave_codec::transform::sqrt2::solve;

fn main() {
    let max = subwave_codec::transform::sqrt2::TABLE_MAX;
    println!("alpha (x 2^16), valence: j = 0..n-1");
    for (i, row) in solve::alpha_table(max).iter().enumerate() {
        println!("{:>2}: {:?}", i + 3, row);
    }
    println!("omega (x 2^16), valence: w0, w1=w3, w2, w4=w11, w5=w10, w6=w9, w7=w8");
    for (i, row) in solve::omega_table(max).iter().enumerate() {
        let f = solve::omega(i + 3);
        println!(
            "{:>2}: {:?}  ({:.6} {:.6} {:.6} {:.6})",
            i + 3,
            row,
            f[0],
            f[1],
            f[2],
            f[4]
        );
    }
}

//! Writes the small committed meshes into a folder, or a large benchmark mesh.
//!
//! `cargo run -p subwave-corpus --bin gen-corpus -- corpus/` rewrites the small meshes;
//! `cargo run --release -p subwave-corpus --bin gen-corpus -- --large 9 big.obj` writes a
//! displaced cube refined 9 times (1.57 M vertices); `--large-polar 6 polar.obj` a
//! displaced polar sphere refined 6 times (261,634 vertices).

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.as_slice() {
        [flag, levels, out] if flag == "--large" => match levels.parse::<u32>() {
            Ok(l) if l <= 11 => std::fs::write(out, subwave_corpus::large_cube(l).to_obj(6)),
            _ => {
                eprintln!("gen-corpus: levels must be a number up to 11");
                std::process::exit(2);
            }
        },
        [flag, levels, out] if flag == "--large-polar" => match levels.parse::<u32>() {
            Ok(l) if l <= 9 => std::fs::write(out, subwave_corpus::large_polar(l).to_obj(6)),
            _ => {
                eprintln!("gen-corpus: levels must be a number up to 9");
                std::process::exit(2);
            }
        },
        [dir] => subwave_corpus::small_corpus()
            .into_iter()
            .try_for_each(|(name, text)| {
                std::fs::write(std::path::Path::new(dir).join(name), text)
            }),
        _ => {
            eprintln!(
                "usage: gen-corpus DIR | gen-corpus --large LEVELS OUT.obj | gen-corpus --large-polar LEVELS OUT.obj"
            );
            std::process::exit(2);
        }
    };
    if let Err(e) = result {
        eprintln!("gen-corpus: {e}");
        std::process::exit(1);
    }
}

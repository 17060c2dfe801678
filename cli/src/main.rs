//! The `subwave` command: a thin layer over the `subwave` library.

use std::io::{IsTerminal, Read, Write};
use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand, ValueEnum};
use serde_json::json;
use subwave::{
    DecodeOptions, EncodeOptions, Format, Limits, Quantization, Source, TransformChoice, Wavelet,
};

const EXAMPLES: &str = "\
Examples:
  subwave compress corpus/cube_cc4.obj cube.swv          exact: the file's own values
  subwave compress scan.ply scan.swv --bits 16           Draco's 16-bit grid
  subwave decompress cube.swv cube.obj                   format follows the extension
  subwave decompress cube.swv - --format off > cube.off  '-' is stdout (stdin for input)
  subwave compress scan.obj scan.swv -f                  overwrite scan.swv if it exists
  subwave info cube.swv --json
  subwave verify corpus/cube_cc4.obj                     compress + decompress in memory
  subwave verify scan.ply --bits 16 --json               grid error bound, sizes, times
  subwave verify scan.ply --repeat 9                     median times of 9 runs
  subwave info cube.swv                                  sections, levels, transform
  subwave compress -r models/ -o packed/                 every mesh file in models/
  subwave decompress packed/*.swv -o meshes/             packed/NAME.swv -> meshes/NAME";

#[derive(Parser)]
#[command(
    name = "subwave",
    version,
    about = "Lossless integer geometry codec for meshes with subdivision connectivity",
    after_help = EXAMPLES
)]
struct Cli {
    /// Do not print warnings.
    #[arg(short, long, global = true)]
    quiet: bool,
    /// Overwrite an existing output file, and write binary data to a terminal.
    #[arg(short, long, global = true)]
    force: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Compress a mesh file (OBJ, PLY, OFF or STL) into a .swv container, or many
    /// files into a folder (`-o DIR`).
    #[command(after_help = EXAMPLES)]
    Compress {
        #[command(flatten)]
        io: Files,
        /// Store the input's order and its own bytes so decompression gives the file back
        /// byte for byte. Implied when the file holds more than positions and faces (UVs,
        /// normals, colours, materials, groups, other properties), unless --canonical.
        #[arg(long, conflicts_with = "canonical")]
        keep_order: bool,
        /// Canonical order: positions, faces and the attribute channels (texture
        /// coordinates, normals, vertex colours, an OBJ's objects, groups, smoothing
        /// groups and materials, its comments, `mtllib`, `l` and `p` lines; PLY vertex,
        /// face and other elements' properties, lists included, and header comments),
        /// every value exact, written back by subwave's writers; drops number styles,
        /// line order and what else the file holds (OBJ free-form statements, say; a
        /// warning names it).
        #[arg(long)]
        canonical: bool,
        #[command(flatten)]
        coding: Coding,
    },
    /// Decompress a .swv container into a mesh file, or many into a folder (`-o DIR`).
    #[command(after_help = EXAMPLES)]
    Decompress {
        #[command(flatten)]
        io: Files,
        /// Output format, written by subwave's writer. By default the output's extension
        /// says (.obj, .off; .ply and .stl are ASCII for decimal values and binary for
        /// float values, so values stay exact), else the input's format; without this
        /// option, a container that keeps the input file's bytes writes them back to
        /// an output of the input's kind (or `-`).
        #[arg(long, value_enum)]
        format: Option<OutFormat>,
        /// Write the mesh of refinement level K (0 = base mesh); works on a file cut off
        /// after level K's section.
        #[arg(long, value_name = "K")]
        max_level: Option<u8>,
        /// Threads (0: one per core): with -o, files decoded at once (each on one);
        /// for one file, the decoder's (the mesh is the same for every count).
        #[arg(long, value_name = "N", default_value_t = 0)]
        threads: usize,
    },
    /// Describe a container: counts, family, transform, quantisation, section sizes.
    Info {
        /// The container, or - for standard input.
        file: String,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Compress and decompress in memory and check the result is exact.
    Verify {
        /// Input mesh file, or - for standard input.
        input: String,
        #[command(flatten)]
        coding: Coding,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
        /// Encode and decode N times in this process and report the median times (the
        /// first runs warm the caches; every result is checked).
        #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
        repeat: u32,
    },
}

/// The files `compress` and `decompress` take: IN OUT, or a batch into a folder.
#[derive(clap::Args)]
struct Files {
    /// IN OUT (- for standard input or output), or with -o DIR any number of inputs
    /// (and folders, with -r).
    #[arg(required = true, num_args = 1..)]
    files: Vec<String>,
    /// Write the outputs into DIR (created if missing): compress writes NAME.swv for
    /// each input NAME, decompress NAME for each NAME.swv (a NAME without a mesh
    /// extension gets its source format's).
    #[arg(short = 'o', long = "output-dir", value_name = "DIR")]
    output_dir: Option<String>,
    /// With -o: take the files inside folders, at any depth (compress: .obj, .ply, .off,
    /// .stl; decompress: .swv), keeping their paths under DIR.
    #[arg(short, long)]
    recursive: bool,
}

/// How `compress` and `verify` code a mesh.
#[derive(clap::Args)]
struct Coding {
    /// Quantise to Draco's Q-bit grid (1..=30) instead of keeping the exact values.
    #[arg(long, value_name = "Q", value_parser = clap::value_parser!(u8).range(1..=30))]
    bits: Option<u8>,
    /// Code positions and faces only, in canonical order: leave out every attribute
    /// channel (texture coordinates, normals, colours, names, the file's own lines and
    /// other elements; a warning names them), as geometry codecs such as Draco's
    /// position-only mode do.
    #[arg(long)]
    geometry_only: bool,
    /// Wavelet for subdivision levels: auto (smallest file); Catmull-Clark: lazy,
    /// bilinear, bicubic, biquintic, dyadic-sym, interp4 (4-point interpolating), interp6
    /// (6-point interpolating), or fit (the subdivision fit, for subdivided models);
    /// sqrt(2): sqrt2-lazy, ir2w, sqrt2-sym.
    #[arg(long, default_value = "auto", value_parser = parse_transform)]
    transform: TransformChoice,
    /// Look for at most N refinement levels (0: code the mesh flat).
    #[arg(long, value_name = "N", default_value_t = 16, value_parser = clap::value_parser!(u8).range(0..=16))]
    levels: u8,
    /// Polar hierarchies: the poles' discs take auto (smallest file), none (the
    /// Catmull-Clark transform everywhere), lazy (the lazy polar wavelet, circular
    /// analysis first), lazy-radial (radial first), lifted (the lifted polar
    /// wavelet, circular first) or lifted-radial (radial first).
    #[arg(long, default_value = "auto", value_parser = parse_disc)]
    polar_disc: DiscArg,
    /// Per-axis value maps: auto (map the axes whose values are sparse in their
    /// range and lie apart, as on a lattice, when that makes the file smaller), on
    /// (map every axis) or off.
    #[arg(long, default_value = "auto", value_parser = parse_value_map)]
    value_map: ValueMapArg,
    /// Threads the encoder may use to try transforms at once (0: one per core, at most
    /// 4, and one for meshes over 500,000 vertices); with -o, files coded at once
    /// instead (0: one per core). The file is the same for any count; each thread
    /// holds a coding's memory.
    #[arg(long, value_name = "N", default_value_t = 0)]
    threads: usize,
    /// How hard auto searches, 1 (fastest) to 9 (every candidate, transform and mode:
    /// the smallest file); any effort decodes the same way.
    #[arg(long, value_name = "N", default_value_t = subwave::DEFAULT_EFFORT,
          value_parser = clap::value_parser!(u8).range(1..=subwave::MAX_EFFORT as i64))]
    effort: u8,
}

impl Coding {
    /// The encoder options these arguments ask for, for a mesh of `vertices` (the
    /// input's order not kept).
    fn options(&self, vertices: usize) -> EncodeOptions {
        EncodeOptions {
            transform: self.transform,
            max_levels: self.levels,
            disc: self.polar_disc.0,
            value_map: self.value_map.0,
            threads: match self.threads {
                // Each thread holds a coding's memory: one per core, at most 4, and on
                // large meshes (about 130 bytes per vertex each: 596 MB on two
                // threads against 394 MB on one for the 1.57 M-vertex mesh) one.
                0 if vertices > LARGE_MESH => 1,
                0 => std::thread::available_parallelism().map_or(1, |n| n.get().min(4)),
                n => n,
            },
            effort: self.effort,
            ..Default::default()
        }
    }
}

fn parse_transform(s: &str) -> Result<TransformChoice, String> {
    match s {
        "auto" => return Ok(TransformChoice::Auto),
        "fit" => return Ok(TransformChoice::Fit),
        _ => {}
    }
    Wavelet::from_name(s)
        .map(TransformChoice::Fixed)
        .ok_or_else(|| {
            format!("unknown transform '{s}'; use auto, lazy, bilinear, bicubic, biquintic, dyadic-sym, interp4, interp6 (Catmull-Clark), sqrt2-lazy, ir2w or sqrt2-sym (sqrt(2)), fit (subdivision fit)")
        })
}

/// `--polar-disc`: a disc transform, or none for auto.
#[derive(Clone, Copy)]
struct DiscArg(Option<subwave::DiscTransform>);

fn parse_disc(s: &str) -> Result<DiscArg, String> {
    use subwave::DiscTransform as D;
    match s {
        "auto" => Ok(DiscArg(None)),
        "none" => Ok(DiscArg(Some(D::None))),
        "lazy" => Ok(DiscArg(Some(D::LazyCircularFirst))),
        "lazy-radial" => Ok(DiscArg(Some(D::LazyRadialFirst))),
        "lifted" => Ok(DiscArg(Some(D::LiftedCircularFirst))),
        "lifted-radial" => Ok(DiscArg(Some(D::LiftedRadialFirst))),
        _ => Err(format!(
            "unknown polar disc transform '{s}'; use auto, none, lazy, lazy-radial, lifted or lifted-radial"
        )),
    }
}

/// `--value-map`: on, off, or none for auto.
#[derive(Clone, Copy)]
struct ValueMapArg(Option<bool>);

fn parse_value_map(s: &str) -> Result<ValueMapArg, String> {
    match s {
        "auto" => Ok(ValueMapArg(None)),
        "on" => Ok(ValueMapArg(Some(true))),
        "off" => Ok(ValueMapArg(Some(false))),
        _ => Err(format!(
            "unknown value map choice '{s}'; use auto, on or off"
        )),
    }
}

impl OutFormat {
    /// The format `--format` names.
    fn format(self) -> Format {
        match self {
            OutFormat::Obj => Format::Obj,
            OutFormat::Ply => Format::PlyBinary,
            OutFormat::PlyAscii => Format::PlyAscii,
            OutFormat::Off => Format::Off,
            OutFormat::Stl => Format::StlBinary,
            OutFormat::StlAscii => Format::StlAscii,
        }
    }
}

/// Vertices above which `--threads 0` codes on one thread, to bound memory.
const LARGE_MESH: usize = 500_000;

#[derive(Clone, Copy, ValueEnum)]
enum OutFormat {
    Obj,
    /// Binary little-endian PLY (decimal values become the nearest doubles).
    Ply,
    /// ASCII PLY.
    PlyAscii,
    Off,
    /// Binary STL (triangles; values become the nearest floats).
    Stl,
    /// ASCII STL (triangles and polygons as facets).
    StlAscii,
}

/// An error for the user: the file it concerns and what went wrong.
struct Failure {
    file: String,
    message: String,
    /// The reader of standard output went away (`| head`): end quietly.
    closed_pipe: bool,
}

fn fail(file: &str, e: impl std::fmt::Display) -> Failure {
    Failure {
        file: file.to_string(),
        message: e.to_string(),
        closed_pipe: false,
    }
}

/// Appends a formatted line to a `String` (text written to standard output in one go,
/// so that a closed pipe ends the command quietly, not in a panic).
macro_rules! put {
    ($out:ident, $($arg:tt)*) => {{
        $out.push_str(&format!($($arg)*));
        $out.push('\n');
    }};
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(code) => code,
        Err(f) if f.closed_pipe => ExitCode::SUCCESS,
        Err(f) => {
            let name = if f.file == "-" {
                "<stdin/stdout>"
            } else {
                &f.file
            };
            eprintln!("subwave: error: {name}: {}", f.message);
            ExitCode::from(1)
        }
    }
}

/// A progress display on stderr, only when stderr is a terminal, shown after a second
/// of work: for one file a spinner with the stage it is in (reading, the hierarchy's
/// recovery, each level of each transform tried, writing); for a batch one bar over the
/// files.
#[derive(Clone)]
struct Progress {
    bar: indicatif::ProgressBar,
}

impl Progress {
    fn new(batch: bool) -> Self {
        let bar = indicatif::ProgressBar::hidden();
        if batch {
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} files {msg}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
        } else {
            bar.set_style(
                indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
        }
        if std::io::stderr().is_terminal() {
            let b = bar.clone();
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_secs(1));
                if !b.is_finished() {
                    b.set_draw_target(indicatif::ProgressDrawTarget::stderr());
                    b.enable_steady_tick(Duration::from_millis(120));
                }
            });
        }
        Progress { bar }
    }

    fn stage(&self, what: impl Into<std::borrow::Cow<'static, str>>) {
        self.bar.set_message(what);
    }

    /// The encoder's stages, shown as they come.
    fn encoder(&self) -> subwave::Progress {
        let bar = self.bar.clone();
        subwave::Progress::new(move |s| {
            if let subwave::Stage::Level { .. } = s {
                trim_heap();
            }
            bar.set_message(match s {
                subwave::Stage::Recovering => "recovering the hierarchy".to_string(),
                subwave::Stage::Level {
                    transform,
                    level,
                    levels,
                } => format!("coding level {level}/{levels} ({transform})"),
                subwave::Stage::Flat => "coding the mesh flat".to_string(),
                subwave::Stage::Container => "writing the container".to_string(),
            })
        })
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}

fn read_input(path: &str) -> Result<Vec<u8>, Failure> {
    if path == "-" {
        let mut v = Vec::new();
        std::io::stdin()
            .read_to_end(&mut v)
            .map_err(|e| fail(path, e))?;
        return Ok(v);
    }
    std::fs::read(path).map_err(|e| fail(path, e))
}

/// The largest distance, over every coordinate, between a file's value and its value
/// on the grid `q`.
fn max_grid_error(raw: &subwave::RawCoords, mesh: &subwave::Mesh, q: &Quantization) -> f64 {
    let file = |v: usize, k: usize| -> f64 {
        match raw {
            subwave::RawCoords::Decimal(p) => p[v][k].to_f64(),
            subwave::RawCoords::F32(p) => p[v][k] as f64,
            subwave::RawCoords::F64(p) => p[v][k],
        }
    };
    let mut worst = 0f64;
    for (v, p) in mesh.positions.iter().enumerate() {
        for (k, &n) in p.iter().enumerate() {
            worst = worst.max((file(v, k) - q.value_f64(n, k)).abs());
        }
    }
    worst
}

/// Which order (and so how much of the file) `compress` keeps.
#[derive(Clone, Copy)]
enum Order {
    /// The file's order and bytes when it holds more than positions and faces.
    Auto,
    /// The file's order and bytes (`--keep-order`).
    Keep,
    /// Positions and faces in canonical order (`--canonical`).
    Canonical,
}

/// What a batch does to each file.
enum Job<'a> {
    Compress {
        order: Order,
        coding: &'a Coding,
    },
    Decompress {
        format: Option<OutFormat>,
        max_level: Option<u8>,
    },
}

/// The two-argument form's input and output.
fn pair(files: &[String], recursive: bool) -> Result<(&str, &str), Failure> {
    match files {
        [input, output] if !recursive => Ok((input, output)),
        [one] => Err(fail(
            one,
            "no output given: name one (IN OUT) or a folder (-o DIR)",
        )),
        _ => Err(fail(
            &files[0],
            "several inputs (or -r) need a folder for the outputs: -o DIR",
        )),
    }
}

/// The batch's inputs, each with its path relative to the output folder: files as
/// named, and with `recursive` the files of `wanted` extensions in folders.
fn batch_inputs(
    files: &[String],
    recursive: bool,
    wanted: &dyn Fn(&Path) -> bool,
) -> Result<Vec<(String, std::path::PathBuf)>, Failure> {
    let mut out = Vec::new();
    for f in files {
        let path = Path::new(f);
        if f == "-" {
            return Err(fail(f, "standard input cannot be part of a batch (-o DIR)"));
        }
        if !path.is_dir() {
            let name = path.file_name().ok_or_else(|| fail(f, "not a file name"))?;
            out.push((f.clone(), name.into()));
            continue;
        }
        if !recursive {
            return Err(fail(
                f,
                "is a directory (use -r to take the files inside it)",
            ));
        }
        let mut stack = vec![path.to_path_buf()];
        let mut found = Vec::new();
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).map_err(|e| fail(&dir.to_string_lossy(), e))? {
                let p = entry.map_err(|e| fail(&dir.to_string_lossy(), e))?.path();
                if p.is_dir() {
                    stack.push(p);
                } else if wanted(&p) {
                    found.push(p);
                }
            }
        }
        found.sort();
        let top = path
            .file_name()
            .map(std::path::PathBuf::from)
            .unwrap_or_default();
        for p in found {
            let rel = top.join(p.strip_prefix(path).unwrap_or(&p));
            out.push((p.to_string_lossy().into_owned(), rel));
        }
    }
    Ok(out)
}

/// Compresses or decompresses every input into `dir`, `threads` files at once (0: one
/// per core), with one progress bar; a summary line at the end, and exit 1 naming the
/// files that failed while the others are done.
fn batch(
    cli: &Cli,
    job: &Job<'_>,
    files: &[String],
    dir: &str,
    recursive: bool,
    threads: usize,
) -> Result<ExitCode, Failure> {
    let has_ext = |p: &Path, exts: &[&str]| {
        p.extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| exts.iter().any(|x| e.eq_ignore_ascii_case(x)))
    };
    let inputs = match job {
        Job::Compress { .. } => batch_inputs(files, recursive, &|p| {
            Format::from_path(&p.to_string_lossy()).is_some()
        })?,
        Job::Decompress { .. } => batch_inputs(files, recursive, &|p| has_ext(p, &["swv"]))?,
    };
    // Each output's path: NAME.swv, or NAME without its .swv.
    let target = |rel: &Path| -> std::path::PathBuf {
        let out = Path::new(dir).join(rel);
        match job {
            Job::Compress { .. } => {
                let mut name = out.clone().into_os_string();
                name.push(".swv");
                name.into()
            }
            Job::Decompress { .. } if has_ext(&out, &["swv"]) => out.with_extension(""),
            Job::Decompress { .. } => out,
        }
    };
    std::fs::create_dir_all(dir).map_err(|e| fail(dir, e))?;
    let threads = match threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    }
    .clamp(1, inputs.len().max(1));
    let progress = Progress::new(true);
    progress.bar.set_length(inputs.len() as u64);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: std::sync::Mutex<Vec<Outcome>> = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some((input, rel)) = inputs.get(i) else {
                    break;
                };
                let out = target(rel);
                let result = batch_one(cli, job, input, &out);
                if let Err(f) = &result {
                    progress
                        .bar
                        .suspend(|| eprintln!("subwave: error: {}: {}", f.file, f.message));
                }
                progress.bar.inc(1);
                if let Ok(mut r) = results.lock() {
                    r.push((i, result));
                }
            });
        }
    });
    drop(progress);
    let mut results = results.into_inner().unwrap_or_default();
    results.sort_by_key(|(i, _)| *i);
    Ok(batch_summary(job, &inputs, &results, dir))
}

/// Per input of a batch (by its index): the bytes read and written, or why not.
type Outcome = (usize, Result<(u64, u64), Failure>);

/// One file of a batch: `input` coded into `out`; the bytes read and written.
fn batch_one(cli: &Cli, job: &Job<'_>, input: &str, out: &Path) -> Result<(u64, u64), Failure> {
    if let Some(parent) = out.parent() {
        std::fs::create_dir_all(parent).map_err(|e| fail(&parent.to_string_lossy(), e))?;
    }
    let out_name = out.to_string_lossy();
    let quiet = Progress {
        bar: indicatif::ProgressBar::hidden(),
    };
    let written = match job {
        Job::Compress { order, coding } => {
            compress(cli, input, &out_name, *order, coding, true, &quiet)?
        }
        Job::Decompress { format, max_level } => {
            let out_name = match Format::from_path(&out_name) {
                None => with_extension(input, &out_name, *format)?,
                Some(_) => out_name.into_owned(),
            };
            decompress(cli, input, &out_name, *format, *max_level, 1, &quiet)?
        }
    };
    let read = std::fs::metadata(input).map_or(0, |m| m.len());
    Ok((read, written))
}

/// A batch's summary line (the bytes read and written, the files that failed) and its
/// exit code: 1 if any file failed.
fn batch_summary<P>(
    job: &Job<'_>,
    inputs: &[(String, P)],
    results: &[Outcome],
    dir: &str,
) -> ExitCode {
    let (mut read, mut written, mut done) = (0u64, 0u64, 0usize);
    let mut failed = Vec::new();
    for (i, r) in results {
        match r {
            Ok((a, b)) => {
                read += a;
                written += b;
                done += 1;
            }
            Err(_) => failed.push(inputs[*i].0.as_str()),
        }
    }
    let verb = match job {
        Job::Compress { .. } => "compressed",
        Job::Decompress { .. } => "decompressed",
    };
    let ratio = if read > 0 {
        written as f64 / read as f64
    } else {
        0.0
    };
    eprintln!(
        "subwave: {verb} {done} of {} files into {dir}: {read} -> {written} bytes ({ratio:.3}){}",
        inputs.len(),
        if failed.is_empty() {
            String::new()
        } else {
            format!("; {} failed: {}", failed.len(), failed.join(", "))
        }
    );
    if failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// `out`, with the extension of `format`, or where none is given of the format
/// `container` was compressed from.
fn with_extension(
    container: &str,
    out: &str,
    format: Option<OutFormat>,
) -> Result<String, Failure> {
    let format = match format {
        Some(f) => f.format(),
        None => {
            let bytes = read_input(container)?;
            let info =
                subwave::inspect(&bytes, &Limits::default()).map_err(|e| fail(container, e))?;
            subwave::default_output_format(info.header.source)
        }
    };
    Ok(format!("{out}.{}", format.extension()))
}

/// Compresses `input` into `output` (`in_batch`: on one thread, the batch's files being
/// what runs at once); the container's size.
#[allow(clippy::too_many_arguments)]
fn compress(
    cli: &Cli,
    input: &str,
    output: &str,
    order: Order,
    coding: &Coding,
    in_batch: bool,
    progress: &Progress,
) -> Result<u64, Failure> {
    check_output(input, output, true, cli.force)?;
    progress.stage("reading");
    let mut bytes = read_input(input)?;
    check_kind(input, &bytes)?;
    let mut loaded = subwave::load(&bytes, coding.bits).map_err(|e| fail(input, e))?;
    if coding.geometry_only {
        if matches!(order, Order::Keep) {
            return Err(fail(
                input,
                "--geometry-only leaves out what --keep-order keeps: give one of them",
            ));
        }
        geometry_only(cli.quiet, input, &mut loaded);
    }
    let keep_order = match order {
        Order::Keep => true,
        Order::Canonical => false,
        // Nothing the file holds is left out by default: a file with more than
        // positions, faces and lines of its own (comments, `mtllib`, which canonical
        // order keeps at its head) keeps its order and bytes.
        Order::Auto if coding.geometry_only => false,
        Order::Auto => {
            !loaded.dropped.is_empty()
                || loaded
                    .mesh
                    .attributes
                    .iter()
                    .any(|a| a.domain != subwave::Domain::File || a.labels.is_empty())
        }
    };
    if !keep_order {
        warn_dropped(
            cli.quiet,
            input,
            &loaded,
            "--canonical: positions, faces and attribute channels only",
        );
        // The file's bytes are needed no more: free them before coding.
        bytes = Vec::new();
    }
    let mut opts = EncodeOptions {
        keep_order,
        source: loaded.source(),
        progress: progress.encoder(),
        ..coding.options(loaded.mesh.vertex_count())
    };
    if in_batch {
        opts.threads = 1;
    }
    // With the file's order, its own bytes too: it comes back byte for byte.
    let (mesh, q) = (&loaded.mesh, &loaded.quantization);
    let enc = match keep_order {
        true => subwave::encode_file(mesh, q, &opts, &bytes, loaded.format),
        false => subwave::encode_to_vec(mesh, q, &opts),
    }
    .map_err(|e| fail(input, e))?;
    drop(bytes);
    progress.stage("writing");
    write_output(output, &enc.bytes)?;
    Ok(enc.bytes.len() as u64)
}

/// Decompresses `input` into `output`; the mesh file's size.
fn decompress(
    cli: &Cli,
    input: &str,
    output: &str,
    format: Option<OutFormat>,
    max_level: Option<u8>,
    threads: usize,
    progress: &Progress,
) -> Result<u64, Failure> {
    if format.is_none() && output != "-" && Format::from_path(output).is_none() {
        return Err(fail(
            output,
            "the extension names no mesh format (.obj, .ply, .off, .stl); use --format",
        ));
    }
    // Binary only where it may be written; text formats go to a terminal.
    let binary = match format {
        Some(f) => matches!(f.format(), Format::PlyBinary | Format::StlBinary),
        None => Format::from_path(output).is_some_and(|f| f.is_ply() || f.is_stl()),
    };
    check_output(input, output, binary, cli.force)?;
    progress.stage("reading");
    let bytes = read_input(input)?;
    progress.stage("decoding");
    let opts = DecodeOptions {
        limits: Limits::default(),
        max_level,
        threads,
    };
    let dec = subwave::decode(&bytes, &opts).map_err(|e| fail(input, e))?;
    let fmt = match format {
        Some(f) => f.format(),
        // PLY and STL named by the output keep the values exact: ASCII where binary
        // floats cannot hold them. Else the input's own format (an STL, too, as one
        // that holds them).
        None => match Format::from_path(output) {
            Some(f) => f.exact_for(&dec.quantization),
            None => match subwave::default_output_format(dec.header.source) {
                src if src.is_stl() => src.exact_for(&dec.quantization),
                src => src,
            },
        },
    };
    progress.stage("writing");
    // The input file itself where the container keeps it and the output is of its kind
    // (or says no kind).
    let same_kind = |f: Format| match dec.header.source {
        Source::Obj => f == Format::Obj,
        Source::Off => f == Format::Off,
        Source::PlyAscii | Source::PlyBinary => f.is_ply(),
        Source::StlAscii | Source::StlBinary => f.is_stl(),
        Source::Unknown => false,
    };
    let original = format.is_none() && Format::from_path(output).is_none_or(same_kind);
    let keeps_file = original && dec.template.is_some();
    if !keeps_file {
        let lost: Vec<&str> = dec
            .mesh
            .attributes
            .iter()
            .filter(|a| !subwave::writes_attribute(fmt, a))
            .map(|a| a.name.as_str())
            .collect();
        if !cli.quiet && !lost.is_empty() {
            eprintln!(
                "subwave: warning: {output}: {} holds no such attribute channel, not written: {}",
                fmt.name(),
                lost.join(", ")
            );
        }
    }
    // Written as it is made, not held whole (a large file's memory).
    stream_output(input, output, |w| {
        if keeps_file {
            if let Some(n) = dec.write_file(&mut *w) {
                return n;
            }
        }
        let mut counted = Counted { inner: w, bytes: 0 };
        subwave::write_mesh(&mut counted, &dec.mesh, &dec.quantization, fmt)?;
        Ok(counted.bytes)
    })
}

/// A writer that counts the bytes written through it.
struct Counted<W> {
    inner: W,
    bytes: u64,
}

impl<W: Write> Write for Counted<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.bytes += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// A mesh file whose extension names one format and whose content is another is refused
/// (a misnamed file, or one subwave would misread).
fn check_kind(path: &str, bytes: &[u8]) -> Result<(), Failure> {
    let Some(named) = Format::from_path(path) else {
        return Ok(());
    };
    let found = Format::sniff(bytes);
    if named.is_ply() != found.is_ply()
        || named.is_stl() != found.is_stl()
        || (named == Format::Off) != (found == Format::Off)
    {
        return Err(fail(
            path,
            format!(
                "the extension says {}, the content is not (it reads as {})",
                named.name().split(' ').next().unwrap_or("PLY"),
                found.name()
            ),
        ));
    }
    Ok(())
}

/// Refuses, before any work, an output that would clobber: the input itself, an existing
/// file (unless `force`), binary data to a terminal (unless `force`).
fn check_output(input: &str, output: &str, binary: bool, force: bool) -> Result<(), Failure> {
    if output == "-" {
        if binary && !force && std::io::stdout().is_terminal() {
            return Err(fail(
                output,
                "refusing to write binary data to a terminal (redirect it, or use -f)",
            ));
        }
        return Ok(());
    }
    let out = Path::new(output);
    if input != "-" {
        let same = match (std::fs::canonicalize(input), std::fs::canonicalize(out)) {
            (Ok(a), Ok(b)) => a == b,
            _ => Path::new(input) == out,
        };
        if same {
            return Err(fail(
                output,
                "the output is the input; refusing to overwrite it",
            ));
        }
    }
    if out.is_dir() {
        return Err(fail(output, "is a directory"));
    }
    if out.exists() && !force {
        return Err(fail(output, "already exists (use -f to overwrite it)"));
    }
    Ok(())
}

/// Writes `output` (a file, or standard output for `-`) with `write`, through a buffer
/// and, for a file, whole or not at all: into a temporary file beside it that is
/// renamed into place when complete (and removed on an error); the bytes written. An
/// error writing is the output's (a closed standard output ends quietly); any other (a
/// container whose file does not match its channels) is `input`'s.
fn stream_output(
    input: &str,
    output: &str,
    write: impl FnOnce(&mut dyn Write) -> subwave::Result<u64>,
) -> Result<u64, Failure> {
    let blame = |e: subwave::Error| match e {
        subwave::Error::Io(e) => Failure {
            closed_pipe: e.kind() == std::io::ErrorKind::BrokenPipe,
            ..fail(output, e)
        },
        e => fail(input, e),
    };
    if output == "-" {
        let mut out = std::io::BufWriter::with_capacity(1 << 16, std::io::stdout().lock());
        let n = write(&mut out).map_err(blame)?;
        out.flush().map_err(|e| blame(e.into()))?;
        return Ok(n);
    }
    let tmp = temporary_beside(output);
    let written = std::fs::File::create(&tmp)
        .map_err(subwave::Error::from)
        .and_then(|f| {
            let mut out = std::io::BufWriter::with_capacity(1 << 16, f);
            let n = write(&mut out)?;
            let f = out.into_inner().map_err(|e| e.into_error())?;
            f.sync_all()?;
            std::fs::rename(&tmp, output)?;
            Ok(n)
        });
    written.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        blame(e)
    })
}

/// The temporary file an output is written to before it is renamed into place.
fn temporary_beside(path: &str) -> std::path::PathBuf {
    let target = Path::new(path);
    let dir = target
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = target
        .file_name()
        .map_or("out".into(), |n| n.to_string_lossy());
    dir.join(format!(".{name}.{}.subwave-tmp", std::process::id()))
}

/// Writes `bytes` to `path` as [`stream_output`] does.
fn write_output(path: &str, bytes: &[u8]) -> Result<(), Failure> {
    stream_output(path, path, |w| {
        w.write_all(bytes)?;
        Ok(bytes.len() as u64)
    })
    .map(|_| ())
}

/// Warns that what `loaded` holds besides positions and faces is left out, and why.
/// `--geometry-only`: `loaded` without its attribute channels, which a warning names;
/// what else was not carried stays noted.
fn geometry_only(quiet: bool, file: &str, loaded: &mut subwave::Loaded) {
    let names: Vec<String> = loaded.mesh.attributes.drain(..).map(|a| a.name).collect();
    if !quiet && !names.is_empty() {
        eprintln!(
            "subwave: warning: {file}: not carried (--geometry-only): {}",
            names.join(", ")
        );
    }
}

fn warn_dropped(quiet: bool, file: &str, loaded: &subwave::Loaded, why: &str) {
    if !quiet && !loaded.dropped.is_empty() {
        let list: Vec<&str> = loaded.dropped.iter().map(String::as_str).collect();
        eprintln!(
            "subwave: warning: {file}: not carried ({why}): {}",
            list.join(", ")
        );
    }
}

/// The encoder makes and frees many large working arrays (per level, per mode tried).
/// glibc's allocator keeps freed memory inside its heap, where it fragments: the process
/// then holds far more memory than it uses (on a 1.57 M-vertex mesh about 400 MB for
/// 332 MB in use). Handing the heap's free pages back to the system as each level's
/// coding starts (the encoder's progress reports are the hook) keeps the peak near what
/// is in use, for little time (benches/RESULTS.md: 394 MB there at the default effort,
/// 402 MB at effort 9, for a heap peak of 393 and 383 MB). (A fixed 4 MiB mmap
/// threshold gave 331 MB but doubled the page faults and made allocations fail under
/// valgrind, whose profiles this project uses.)
fn trim_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free memory of the allocator's own heap to the
    // system; it is safe to call from any thread at any time.
    unsafe {
        libc::malloc_trim(0);
    }
}

fn run(cli: &Cli) -> Result<ExitCode, Failure> {
    match &cli.command {
        Command::Compress {
            io:
                Files {
                    files,
                    output_dir,
                    recursive,
                },
            keep_order,
            canonical,
            coding,
        } => {
            let order = match (keep_order, canonical) {
                (true, _) => Order::Keep,
                (_, true) => Order::Canonical,
                _ => Order::Auto,
            };
            let job = Job::Compress { order, coding };
            match output_dir {
                Some(dir) => batch(cli, &job, files, dir, *recursive, coding.threads),
                None => {
                    let (input, output) = pair(files, *recursive)?;
                    let progress = Progress::new(false);
                    compress(cli, input, output, order, coding, false, &progress)?;
                    Ok(ExitCode::SUCCESS)
                }
            }
        }
        Command::Decompress {
            io:
                Files {
                    files,
                    output_dir,
                    recursive,
                },
            format,
            max_level,
            threads,
        } => {
            let job = Job::Decompress {
                format: *format,
                max_level: *max_level,
            };
            match output_dir {
                Some(dir) => batch(cli, &job, files, dir, *recursive, *threads),
                None => {
                    let (input, output) = pair(files, *recursive)?;
                    let progress = Progress::new(false);
                    let threads = match *threads {
                        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
                        n => n,
                    };
                    decompress(cli, input, output, *format, *max_level, threads, &progress)?;
                    Ok(ExitCode::SUCCESS)
                }
            }
        }
        Command::Info { file, json } => {
            let bytes = read_input(file)?;
            let info = subwave::inspect(&bytes, &Limits::default()).map_err(|e| fail(file, e))?;
            write_output("-", info_text(&info, *json).as_bytes())?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Verify {
            input,
            coding,
            json,
            repeat,
        } => verify(cli, input, coding, *json, *repeat),
    }
}

fn info_text(info: &subwave::Info, as_json: bool) -> String {
    let mut out = String::new();
    let h = &info.header;
    let bits_per_vertex = subwave::json::bits_per_vertex(info.bytes, h.vertices);
    if as_json {
        put!(out, "{}", subwave::json::info(info));
        return out;
    }
    put!(out, "format version  {}", info.version);
    put!(out, "vertices        {}", h.vertices);
    put!(out, "faces           {} ({} corners)", h.faces, h.corners);
    put!(
        out,
        "base mesh       {} vertices, {} faces",
        h.base_vertices,
        h.base_faces
    );
    put!(out, "levels          {}", h.levels);
    put!(out, "family          {}", h.family.name());
    if !h.poles.is_empty() {
        let list: Vec<String> = h.poles.iter().map(|p| (p + 1).to_string()).collect();
        put!(
            out,
            "poles           {} (base vertices {})",
            h.poles.len(),
            list.join(", ")
        );
        put!(out, "disc transform  {}", h.disc.name());
    }
    match h.transform {
        subwave::Transform::Fit { bits, .. } => {
            let rules = match subwave::fit_rules(h) {
                r if r.is_empty() => r,
                r => format!(", {r}"),
            };
            put!(
                out,
                "transform       fit (control values with {bits} extra bits{rules})"
            )
        }
        t => put!(out, "transform       {}", t.name()),
    }
    put!(out, "quantisation    {}", h.quantization.describe());
    if h.has_value_map {
        put!(
            out,
            "value map       yes: coordinates coded as ranks of their axis's values"
        );
    }
    put!(
        out,
        "vertex order    {}",
        if h.has_order {
            "input order (stored)"
        } else {
            "canonical"
        }
    );
    let secs: Vec<String> = info
        .sections
        .iter()
        .map(|s| match s.mode {
            Some(m) => {
                let joint = if s.joint { " joint" } else { "" };
                let unbinned = if s.unbinned { ", unbinned" } else { "" };
                let zero = match s.zero_slots.as_slice() {
                    [] => String::new(),
                    z => {
                        let list: Vec<String> = z.iter().map(u8::to_string).collect();
                        format!(", zero slots {}", list.join(" "))
                    }
                };
                format!("{} {} B (mode {m}{joint}{unbinned}{zero})", s.kind, s.bytes)
            }
            None => match &s.attribute {
                Some(a) => {
                    let rules = match a.rules.as_str() {
                        "" => String::new(),
                        r => format!(": {r}"),
                    };
                    let name = match (a.name.as_str(), a.domain.as_str()) {
                        ("", _) => String::new(),
                        (n, "") => format!("'{n}': "),
                        (n, d) => format!("'{n}' per {d}: "),
                    };
                    format!(
                        "{} {} B ({name}{} x {} values, {}{rules})",
                        s.kind, s.bytes, a.entries, a.width, a.transform
                    )
                }
                None if !s.order_method.is_empty() => {
                    format!("{} {} B ({})", s.kind, s.bytes, s.order_method)
                }
                None => format!("{} {} B", s.kind, s.bytes),
            },
        })
        .collect();
    put!(out, "sections        {}", secs.join(", "));
    put!(
        out,
        "size            {} bytes, {:.3} bits per vertex",
        info.bytes,
        bits_per_vertex
    );
    out
}

/// The median of some timings (the upper one of an even count's middle two).
fn median_ms(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t.get(t.len() / 2).copied().unwrap_or(0.0)
}

fn verify(
    cli: &Cli,
    input: &str,
    coding: &Coding,
    as_json: bool,
    repeat: u32,
) -> Result<ExitCode, Failure> {
    let progress = Progress::new(false);
    progress.stage("reading");
    let bytes = read_input(input)?;
    check_kind(input, &bytes)?;
    let mut loaded = subwave::load(&bytes, coding.bits).map_err(|e| fail(input, e))?;
    if coding.geometry_only {
        geometry_only(cli.quiet, input, &mut loaded);
    }
    warn_dropped(
        cli.quiet,
        input,
        &loaded,
        "verify checks positions, faces and attribute channels",
    );
    let opts = &EncodeOptions {
        progress: progress.encoder(),
        ..coding.options(loaded.mesh.vertex_count())
    };
    let (mut encode_times, mut decode_times) = (Vec::new(), Vec::new());
    let mut last = None;
    for _ in 0..repeat {
        let t0 = Instant::now();
        let enc = subwave::encode_to_vec(&loaded.mesh, &loaded.quantization, opts)
            .map_err(|e| fail(input, e))?;
        encode_times.push(t0.elapsed().as_secs_f64() * 1e3);
        progress.stage("decoding");
        let t1 = Instant::now();
        let dec = subwave::decode(
            &enc.bytes,
            &DecodeOptions {
                threads: opts.threads.max(1),
                ..DecodeOptions::default()
            },
        )
        .map_err(|e| fail(input, e))?;
        decode_times.push(t1.elapsed().as_secs_f64() * 1e3);
        // The coding is deterministic: every run writes the same container.
        if last
            .as_ref()
            .is_some_and(|(e, _): &(subwave::Encoded, _)| e.bytes != enc.bytes)
        {
            return Err(fail(input, "two encodings of the same mesh differ"));
        }
        last = Some((enc, dec));
    }
    let (enc, dec) = last.expect("repeat is at least 1");
    let (encode_ms, decode_ms) = (median_ms(encode_times), median_ms(decode_times));
    drop(progress);
    let check = subwave::compare_up_to_order(&loaded.mesh, &dec.mesh, &enc.order);
    let exact = check.is_ok() && dec.quantization == loaded.quantization;
    let n = loaded.mesh.vertex_count() as u64;
    // On a grid (--bits), the round trip is exact on the grid's integers; how far the
    // values moved from the file's is the error bound a user asks for.
    let grid_error = match loaded.quantization {
        Quantization::Grid { step, .. } => subwave::read_mesh(&bytes).ok().map(|raw| {
            let err = max_grid_error(&raw.coords, &loaded.mesh, &loaded.quantization);
            (err, step as f64)
        }),
        _ => None,
    };
    if as_json {
        let v = json!({
            "file": input,
            "vertices": n,
            "faces": loaded.mesh.face_count(),
            "bytes": enc.bytes.len(),
            "bits_per_vertex": subwave::json::bits_per_vertex(enc.bytes.len(), n),
            "encode_ms": encode_ms,
            "encode_threads": opts.threads.max(1),
            "effort": opts.effort,
            "decode_ms": decode_ms,
            "decode_threads": opts.threads.max(1),
            "repeat": repeat,
            "exact": exact,
            "levels": enc.header.levels,
            "family": enc.header.family.name(),
            "transform": enc.header.transform.name(),
            "quantization": subwave::json::quantization(&loaded.quantization),
            "lossless": exact && grid_error.is_none(),
            "max_error": grid_error.map(|e| e.0),
        });
        let mut out = String::new();
        put!(out, "{v}");
        write_output("-", out.as_bytes())?;
    } else {
        let mut out = String::new();
        put!(
            out,
            "{}: {} vertices, {} faces -> {} bytes, {:.3} bits per vertex; encode {:.1} ms, decode {:.1} ms ({} threads each){}; {}",
            Path::new(input).file_name().map_or(input.into(), |f| f.to_string_lossy()),
            n,
            loaded.mesh.face_count(),
            enc.bytes.len(),
            subwave::json::bits_per_vertex(enc.bytes.len(), n),
            encode_ms,
            decode_ms,
            opts.threads.max(1),
            if repeat > 1 {
                format!(" (medians of {repeat})")
            } else {
                String::new()
            },
            match (exact, grid_error) {
                (false, _) => "MISMATCH".to_string(),
                (true, None) => "exact".to_string(),
                (true, Some((e, step))) => format!(
                    "exact on the grid; values within {e:.3e} of the file's (grid step {step:.3e})"
                ),
            }
        );
        write_output("-", out.as_bytes())?;
    }
    if let Err(why) = check {
        return Err(fail(input, format!("round trip is not exact: {why}")));
    }
    Ok(if exact {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

//! A container of at most 1 KiB cannot make the decoder allocate more than 64 MiB or run
//! longer than a second, with the default limits: measured with a counting allocator on
//! crafted containers (huge counts, deep levels, long sections, streams that run out) and
//! on a legitimate, extremely compressible one.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use subwave::{EncodeOptions, Mesh, Quantization, TransformChoice, Wavelet};
use subwave_container::{ByteWriter, Container, ContainerWriter, Limits, SectionKind};

struct Counting;

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn add(n: usize) {
    let now = CURRENT.fetch_add(n, Ordering::Relaxed) + n;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

// SAFETY: every call is forwarded to the system allocator unchanged; the counters only
// observe sizes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        add(layout.size());
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        add(layout.size());
        System.alloc_zeroed(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        CURRENT.fetch_sub(layout.size(), Ordering::Relaxed);
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() {
            add(new_size - layout.size());
        } else {
            CURRENT.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
        }
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

const BUDGET: usize = 64 << 20;

/// The counters are global: the tests take turns.
static TURN: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Decodes `bytes` (all levels and level 0), returning the peak allocation above the
/// starting point and the time taken.
fn measure(bytes: &[u8]) -> (usize, Duration, bool) {
    let base = CURRENT.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let t = Instant::now();
    let ok = subwave::decode_slice(bytes).is_ok();
    let _ = subwave::decode(
        bytes,
        &subwave::DecodeOptions {
            max_level: Some(0),
            ..Default::default()
        },
    );
    (PEAK.load(Ordering::Relaxed) - base, t.elapsed(), ok)
}

fn header(counts: [u64; 6], levels: u8, family: u8, transform: u8) -> Vec<u8> {
    let mut h = ByteWriter::new();
    for c in counts {
        h.varint(c);
    }
    h.out
        .extend_from_slice(&[levels, family, transform, 0, 6, 1, 0]);
    h.out
}

fn container(head: &[u8], sections: &[(SectionKind, Vec<u8>)]) -> Vec<u8> {
    let mut w = ContainerWriter::new();
    w.section(SectionKind::HEADER, head);
    for (k, p) in sections {
        w.section(*k, p);
    }
    w.finish()
}

fn noise(n: usize, seed: u64) -> Vec<u8> {
    let mut s = seed | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s as u8
        })
        .collect()
}

/// A legitimate hierarchy container of a tiny mesh, for editing.
fn legit() -> Vec<u8> {
    let p = subwave_corpus::cube().refined(2);
    let mut m = Mesh::new();
    m.positions = p
        .positions
        .iter()
        .map(|v| v.map(|c| (c * 1000.0).round() as i64))
        .collect();
    for f in &p.faces {
        m.push_face(f);
    }
    let opts = EncodeOptions {
        transform: TransformChoice::Fixed(Wavelet::Lazy),
        ..Default::default()
    };
    subwave::encode_to_vec(&m, &Quantization::Decimal { decimals: 3 }, &opts)
        .unwrap()
        .bytes
}

#[test]
fn small_containers_stay_within_64_mib_and_one_second() {
    let _turn = TURN.lock().unwrap_or_else(|e| e.into_inner());
    let mut cases: Vec<(String, Vec<u8>)> = Vec::new();
    // Huge counts at the default limits, with noise as the coded data.
    for (i, counts) in [
        [1u64 << 27, 1 << 27, 1 << 29, 1 << 27, 1 << 27, 1 << 29],
        [1 << 20, 1 << 20, 1 << 22, 1 << 20, 1 << 20, 1 << 22],
        [400_000, 400_000, 1_600_000, 400_000, 400_000, 1_600_000],
        [100_000, 100_000, 400_000, 100_000, 100_000, 400_000],
    ]
    .into_iter()
    .enumerate()
    {
        let c = container(
            &header(counts, 0, 0, 0),
            &[(SectionKind::BASE, noise(900, i as u64 + 1))],
        );
        cases.push((format!("flat counts {counts:?}"), c));
    }
    // Deep levels: a real base mesh, a header claiming 12 levels of it, and noise levels.
    let real = legit();
    let parsed = Container::parse(&real, &Limits::default()).unwrap();
    let base = parsed.sections[1].payload.to_vec();
    let info = subwave::inspect(&real, &Limits::default()).unwrap();
    let (bv, bf, bc) = (
        info.header.base_vertices,
        info.header.base_faces,
        info.header.base_corners,
    );
    for levels in [3u8, 6, 9, 12] {
        // Counts of `levels` refinements of the base: faces x4 per level after the first.
        let (mut v, mut f, mut c) = (bv, bf, bc);
        for _ in 0..levels {
            let e = c / 2;
            v += e + f;
            f = c;
            c = 4 * f;
        }
        let mut sections = vec![(SectionKind::BASE, base.clone())];
        for l in 0..levels {
            sections.push((SectionKind::LEVEL, noise(60, 100 + l as u64)));
        }
        let c = container(&header([v, f, c, bv, bf, bc], levels, 1, 1), &sections);
        cases.push((format!("{levels} levels over a real base"), c));
    }
    // A section claiming more bytes than there are.
    let head = header([8, 6, 24, 8, 6, 24], 0, 0, 0);
    let mut long = container(&head, &[(SectionKind::BASE, noise(200, 7))]);
    // The BASE section's length, a two-byte varint (200), becomes 2^32 - 1.
    let at = subwave_container::PREAMBLE_LEN
        + head.len()
        + subwave_container::section_overhead(head.len())
        + 1;
    assert_eq!(long[at..at + 2], [0xc8, 0x01]);
    long.splice(at..at + 2, [0xff, 0xff, 0xff, 0xff, 0x0f]);
    cases.push(("section length 4 GiB".into(), long));
    let mut checked = 0;
    for (name, bytes) in &cases {
        assert!(bytes.len() <= 1024, "{name}: {} bytes", bytes.len());
        let (peak, time, _) = measure(bytes);
        eprintln!(
            "{name}: {} bytes -> peak {} KiB, {:?}",
            bytes.len(),
            peak / 1024,
            time
        );
        assert!(peak <= BUDGET, "{name}: peak allocation {peak} bytes");
        assert!(time < Duration::from_secs(1), "{name}: {time:?}");
        checked += 1;
    }
    assert_eq!(checked, cases.len());
}

#[test]
fn a_legit_but_extremely_compressible_container_is_bounded_too() {
    let _turn = TURN.lock().unwrap_or_else(|e| e.into_inner());
    // A flat 257 x 257 grid of zeros compresses to a few hundred bytes; it decodes within
    // the budget, or asks for more than 65,536 times its size and is refused.
    let mut m = Mesh::new();
    let n = 257u32;
    m.positions = (0..n * n)
        .map(|i| [(i % n) as i64, (i / n) as i64, 0])
        .collect();
    for y in 0..n - 1 {
        for x in 0..n - 1 {
            let i = y * n + x;
            m.push_face(&[i, i + 1, i + n + 1, i + n]);
        }
    }
    let enc = subwave::encode_to_vec(
        &m,
        &Quantization::Decimal { decimals: 0 },
        &EncodeOptions::default(),
    )
    .unwrap();
    let (peak, time, ok) = measure(&enc.bytes);
    eprintln!(
        "flat grid: {} bytes, decoded {ok}, peak {} KiB, {time:?}",
        enc.bytes.len(),
        peak / 1024
    );
    assert!(peak as u64 <= (enc.bytes.len() as u64).max(64) * 65_536 + (1 << 20));
    if enc.bytes.len() <= 1024 {
        assert!(peak <= BUDGET);
    }
}

//! Entropy coding: constriction's ANS coder driven by adaptive frequency models of our
//! own, updated with integer arithmetic only, so encoder and decoder stay in lockstep on
//! every platform (SPEC.md 4). The decoder reads symbols in coding order; the encoder
//! notes each symbol's range as its models give it and codes them backwards at the end.

use std::num::NonZeroU32;

use constriction::stream::model::{DecoderModel, EncoderModel, EntropyModel};
use constriction::stream::stack::DefaultAnsCoder;
use constriction::stream::{Decode, Encode};

use crate::error::{Error, Result};

/// Probabilities are multiples of 2^-16.
pub const PRECISION: usize = 16;
const ONE: u32 = 1 << PRECISION;
/// Count added per coded symbol.
const INCREMENT: u32 = 24;
/// Counts are halved when their sum passes this.
const MAX_TOTAL: u32 = 1 << 16;
/// The quantised table is rebuilt after 1, 2, 4, ... symbols, then every 512 (SPEC.md
/// 4.2).
const FIRST_PERIOD: u32 = 1;
const MAX_PERIOD: u32 = 512;

/// An adaptive distribution over `0..n` (SPEC.md 4.2).
#[derive(Debug, Clone)]
pub struct AdaptiveModel {
    /// The counts of the `n` symbols, then the table `cum` of `n + 1` entries:
    /// `cum[s]..cum[s + 1]` is symbol `s`'s quantised range, `cum[n] = 2^16` (one
    /// buffer: a model is cloned for every mode the encoder tries).
    table: Vec<u32>,
    total: u32,
    /// `lut[b]`: the symbol whose range holds quantile `b << LUT_SHIFT`, so that a
    /// quantile in bucket b belongs to a symbol from `lut[b]` to `lut[b + 1]` (the
    /// decoder's search, not part of the format).
    lut: [u16; LUT_LEN + 1],
    /// Whether `lut` predates the table: the decoder refills it before its next search
    /// (the encoder never reads it).
    stale: bool,
    until_rebuild: u32,
    period: u32,
}

/// Buckets of the decoder's symbol search: the top 6 bits of a quantile.
const LUT_LEN: usize = 64;
const LUT_SHIFT: u32 = PRECISION as u32 - 6;

impl AdaptiveModel {
    /// A model over `n` symbols (2 <= n <= 4096), all counts 1; its first rebuild comes
    /// after one symbol.
    pub fn new(n: usize) -> Self {
        assert!((2..=4096).contains(&n), "alphabet size {n} out of range");
        let mut table = vec![1; 2 * n + 1];
        table[n..].fill(0);
        let mut m = AdaptiveModel {
            table,
            total: n as u32,
            lut: [0; LUT_LEN + 1],
            stale: true,
            until_rebuild: FIRST_PERIOD,
            period: FIRST_PERIOD,
        };
        m.rebuild();
        m
    }

    /// Keeps what the model has learnt as the prior of a new stretch of data (SPEC.md
    /// 4.2): counts are halved (rounding up) until their sum is at most
    /// `max_total`, the table is rebuilt and the rebuild period starts again at 1.
    pub fn reseed(&mut self, max_total: u32) {
        while self.total > max_total {
            self.halve();
        }
        self.rebuild();
        self.period = FIRST_PERIOD;
        self.until_rebuild = FIRST_PERIOD;
    }

    /// How often `s` has been seen (the encoder's choice among equal codings).
    pub(crate) fn count_of(&self, s: usize) -> u32 {
        self.counts()[s]
    }

    /// The alphabet's size.
    #[inline]
    fn n(&self) -> usize {
        self.table.len() / 2
    }

    /// The symbols' counts.
    #[inline]
    fn counts(&self) -> &[u32] {
        &self.table[..self.n()]
    }

    /// The quantised table: `cum[s]..cum[s + 1]` is symbol `s`'s range.
    #[inline]
    fn cum(&self) -> &[u32] {
        &self.table[self.n()..]
    }

    /// Alphabet size.
    #[cfg(feature = "internals")]
    pub fn len(&self) -> usize {
        self.n()
    }

    /// Always false: models have at least two symbols.
    #[cfg(feature = "internals")]
    pub fn is_empty(&self) -> bool {
        false
    }

    fn rebuild(&mut self) {
        let n = self.n();
        let spare = ONE as u64 - n as u64;
        let total = self.total as u64;
        let (counts, cum) = self.table.split_at_mut(n);
        let mut acc = 0u32;
        let mut best = 0usize;
        for (s, &c) in counts.iter().enumerate() {
            cum[s] = acc;
            acc += 1 + ((c as u64 * spare) / total) as u32;
            if c > counts[best] {
                best = s;
            }
        }
        // Give the rounding remainder to the most frequent symbol (the first on ties).
        let rest = ONE - acc;
        for c in &mut cum[best + 1..] {
            *c += rest;
        }
        cum[n] = ONE;
        self.stale = true;
    }

    /// Makes `lut` follow the table, if it does not yet.
    #[inline(always)]
    fn refresh(&mut self) {
        if self.stale {
            self.refill();
        }
    }

    /// [`AdaptiveModel::refresh`]'s work, after each rebuild (out of the symbol's path).
    #[cold]
    #[inline(never)]
    fn refill(&mut self) {
        let n = self.n();
        let cum = &self.table[n..];
        let mut s = 0;
        for (b, l) in self.lut[..LUT_LEN].iter_mut().enumerate() {
            let q = (b as u32) << LUT_SHIFT;
            while cum[s + 1] <= q {
                s += 1;
            }
            *l = s as u16;
        }
        self.lut[LUT_LEN] = (n - 1) as u16;
        self.stale = false;
    }

    /// Adds one occurrence of `s` to the counts (halving them past the bound) without
    /// the table: for a model that is only ever read through [`AdaptiveModel::reseed`],
    /// which rebuilds it, this is the same as [`AdaptiveModel::update`].
    #[inline]
    fn count(&mut self, s: usize) {
        self.table[s] += INCREMENT;
        self.total += INCREMENT;
        if self.total > MAX_TOTAL {
            self.halve();
        }
    }

    /// Every count becomes `(c + 1) >> 1`, the total their sum.
    fn halve(&mut self) {
        let n = self.n();
        self.total = 0;
        for c in &mut self.table[..n] {
            *c = (*c + 1) >> 1;
            self.total += *c;
        }
    }

    /// Records one occurrence of `s`.
    #[inline(always)]
    pub fn update(&mut self, s: usize) {
        self.count(s);
        self.until_rebuild -= 1;
        if self.until_rebuild == 0 {
            self.next_period();
        }
    }

    /// The table rebuilt and the next rebuild period begun (every 1, 2, 4, ... then
    /// 512 symbols: out of the symbol's path).
    #[cold]
    #[inline(never)]
    fn next_period(&mut self) {
        self.rebuild();
        self.period = (self.period * 2).min(MAX_PERIOD);
        self.until_rebuild = self.period;
    }
}

impl EntropyModel<PRECISION> for AdaptiveModel {
    type Symbol = usize;
    type Probability = u32;
}

impl EncoderModel<PRECISION> for AdaptiveModel {
    #[inline]
    fn left_cumulative_and_probability(
        &self,
        symbol: impl std::borrow::Borrow<usize>,
    ) -> Option<(u32, NonZeroU32)> {
        let s = *symbol.borrow();
        let cum = self.cum();
        let lo = *cum.get(s)?;
        let hi = *cum.get(s + 1)?;
        Some((lo, NonZeroU32::new(hi - lo)?))
    }
}

impl DecoderModel<PRECISION> for AdaptiveModel {
    #[inline]
    fn quantile_function(&self, quantile: u32) -> (usize, u32, NonZeroU32) {
        // cum[0] = 0 <= quantile < 2^16 = cum[n]; find the last s with cum[s] <= quantile,
        // between the symbols of its bucket's start and of the next bucket's.
        let b = ((quantile >> LUT_SHIFT) as usize).min(LUT_LEN - 1);
        // (A stale search table, which [`Decoder::symbol`] never leaves, means the whole
        // table.)
        let n = self.n();
        let cum = self.cum();
        let (lo, hi) = if self.stale {
            (0, n - 1)
        } else {
            (self.lut[b] as usize, self.lut[b + 1] as usize)
        };
        let s = lo + cum[lo + 1..=hi].partition_point(|&c| c <= quantile);
        let s = s.min(n - 1);
        let lo = cum[s];
        let p = cum[s + 1] - lo;
        (s, lo, NonZeroU32::new(p).unwrap_or(NonZeroU32::MIN))
    }
}

/// The uniform distribution over `0..n`, 2 <= n <= 2^16 (SPEC.md 4.3).
#[derive(Debug, Clone, Copy)]
pub struct Uniform {
    n: u32,
    base: u32,
    extra: u32,
}

impl Uniform {
    /// Uniform over `0..n`.
    pub fn new(n: u32) -> Self {
        assert!((2..=ONE).contains(&n));
        Uniform {
            n,
            base: ONE / n,
            extra: ONE % n,
        }
    }

    fn left(&self, s: u32) -> u32 {
        s * self.base + s.min(self.extra)
    }
}

impl EntropyModel<PRECISION> for Uniform {
    type Symbol = u32;
    type Probability = u32;
}

impl EncoderModel<PRECISION> for Uniform {
    fn left_cumulative_and_probability(
        &self,
        symbol: impl std::borrow::Borrow<u32>,
    ) -> Option<(u32, NonZeroU32)> {
        let s = *symbol.borrow();
        if s >= self.n {
            return None;
        }
        let p = self.base + (s < self.extra) as u32;
        Some((self.left(s), NonZeroU32::new(p)?))
    }
}

impl DecoderModel<PRECISION> for Uniform {
    fn quantile_function(&self, q: u32) -> (u32, u32, NonZeroU32) {
        // Symbols below `extra` have width base + 1.
        let big = self.extra * (self.base + 1);
        let s = if q < big {
            q / (self.base + 1)
        } else {
            self.extra + (q - big) / self.base.max(1)
        };
        let s = s.min(self.n - 1);
        let p = self.base + (s < self.extra) as u32;
        (
            s,
            self.left(s),
            NonZeroU32::new(p).unwrap_or(NonZeroU32::MIN),
        )
    }
}

/// Number of magnitude classes for [`IntModel`]: class `k` holds `2^(k-1) <= |v| < 2^k`,
/// up to 2^62, plus class 0 for zero.
pub const INT_CLASSES: usize = 64;

/// Codes signed integers (SPEC.md 4.4): one adaptive symbol for the magnitude class,
/// sign and the bit below the leading one together, then the remaining bits raw; classes
/// above [`JOINT_MAX_CLASS`] escape to a model of the class.
#[derive(Debug, Clone)]
pub struct IntModel {
    sym: AdaptiveModel,
    big: AdaptiveModel,
}

/// Largest class the joint symbol holds; larger ones escape.
pub const JOINT_MAX_CLASS: usize = 15;
/// Symbols of the joint integer model: 0; +1, -1; four per class 2..=15 (sign, then the
/// bit below the leading one); escape.
pub const JOINT_SYMBOLS: usize = 3 + (JOINT_MAX_CLASS - 1) * 4 + 1;
const ESCAPE_SYMBOL: usize = JOINT_SYMBOLS - 1;

impl Default for IntModel {
    fn default() -> Self {
        Self::new()
    }
}

impl IntModel {
    /// A fresh model.
    pub fn new() -> Self {
        IntModel {
            sym: AdaptiveModel::new(JOINT_SYMBOLS),
            big: AdaptiveModel::new(INT_CLASSES),
        }
    }

    /// Counts `v` as if it had been coded with the model (the escaped class model counts
    /// the class), without rebuilding the tables: for a model read only through
    /// [`IntModel::reseed`] (the shared models, SPEC.md 10.1).
    pub fn observe(&mut self, v: i64) {
        let (s, c) = joint_symbol(v);
        self.count_symbol(s, c);
    }

    /// [`IntModel::observe`] of a value whose joint symbol is `s` and class `c`.
    #[inline]
    fn count_symbol(&mut self, s: usize, c: usize) {
        self.sym.count(s);
        if s == ESCAPE_SYMBOL {
            self.big.count(c);
        }
    }

    /// [`AdaptiveModel::reseed`] on every model inside.
    pub fn reseed(&mut self, max_total: u32) {
        self.sym.reseed(max_total);
        self.big.reseed(max_total);
    }
}

/// The joint symbol of `v` (SPEC.md 4.4) and its magnitude class.
fn joint_symbol(v: i64) -> (usize, usize) {
    let c = class_of(v);
    let neg = (v < 0) as usize;
    let s = match c {
        0 => 0,
        1 => 1 + neg,
        c if c <= JOINT_MAX_CLASS => {
            3 + (c - 2) * 4 + neg * 2 + ((v.unsigned_abs() >> (c - 2)) & 1) as usize
        }
        _ => ESCAPE_SYMBOL,
    };
    (s, c)
}

/// `2^k` equally likely values, `1 <= k <= 16`, by shifts.
#[derive(Debug, Clone, Copy)]
struct RawBits(u32);

impl EntropyModel<PRECISION> for RawBits {
    type Symbol = u32;
    type Probability = u32;
}

impl EncoderModel<PRECISION> for RawBits {
    #[inline]
    fn left_cumulative_and_probability(
        &self,
        symbol: impl std::borrow::Borrow<u32>,
    ) -> Option<(u32, NonZeroU32)> {
        let s = *symbol.borrow();
        let w = PRECISION as u32 - self.0;
        if s >> self.0 != 0 {
            return None;
        }
        Some((s << w, NonZeroU32::new(1 << w)?))
    }
}

impl DecoderModel<PRECISION> for RawBits {
    #[inline]
    fn quantile_function(&self, q: u32) -> (u32, u32, NonZeroU32) {
        let w = PRECISION as u32 - self.0;
        let s = (q >> w) & ((1 << self.0) - 1);
        (
            s,
            s << w,
            NonZeroU32::new(1 << w).unwrap_or(NonZeroU32::MIN),
        )
    }
}

/// Magnitude class of `v`: 0 for 0, else the bit length of `|v|`.
#[inline]
pub fn class_of(v: i64) -> usize {
    (64 - v.unsigned_abs().leading_zeros()) as usize
}

/// A symbol's range as the encoder noted it: the left cumulative and the probability,
/// for the backward pass (any symbol: the range is the model).
#[derive(Clone, Copy)]
struct Noted(u32, NonZeroU32);

impl EntropyModel<PRECISION> for Noted {
    type Symbol = ();
    type Probability = u32;
}

impl EncoderModel<PRECISION> for Noted {
    #[inline]
    fn left_cumulative_and_probability(
        &self,
        _: impl std::borrow::Borrow<()>,
    ) -> Option<(u32, NonZeroU32)> {
        Some((self.0, self.1))
    }
}

/// `ceil(256 log2(1 + (m + 1) / 256))` for `m` in `0..256`: an upper bound of the
/// fractional part of `log2 p` (in 1/256 bits) for a `p` whose 8 bits after its leading
/// one are `m` (the encoder's size bound only).
fn log2_ceil_table() -> &'static [u16; 256] {
    static T: std::sync::OnceLock<[u16; 256]> = std::sync::OnceLock::new();
    T.get_or_init(|| std::array::from_fn(|m| (256.0 * (1.0 + (m as f64 + 1.0) / 256.0).log2()).ceil() as u16))
}

/// Writes symbols.
pub struct Encoder {
    /// Every symbol's range in coding order: the left cumulative in the low 16 bits,
    /// the probability minus 1 in the high 16.
    noted: Vec<u32>,
    /// A lower bound of the information coded so far, in 1/256 bits.
    info: u64,
    /// `log2_ceil_table()`, looked up once.
    log2: &'static [u16; 256],
}

impl Default for Encoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Encoder {
    /// An empty stream.
    pub fn new() -> Self {
        Encoder {
            noted: Vec::new(),
            info: 0,
            log2: log2_ceil_table(),
        }
    }

    /// Notes one symbol of range `left..left + p` (of 2^16).
    #[inline]
    fn note(&mut self, left: u32, p: u32) {
        debug_assert!(p >= 1 && left + p <= ONE);
        self.noted.push(left | (p - 1) << 16);
        // -log2(p / 2^16) >= 16 - e - log2(1 + (m + 1) / 256), p = 2^e (1 + m / 256 + ...).
        let e = 31 - p.leading_zeros();
        let m = if e >= 8 { (p >> (e - 8)) & 255 } else { (p << (8 - e)) & 255 };
        self.info += ((16 - e) * 256) as u64 - self.log2[m as usize] as u64;
    }

    /// Notes symbol `s` of model `m` (any model: adaptive, uniform, raw bits).
    #[inline]
    fn note_symbol<M: EncoderModel<PRECISION, Probability = u32>>(&mut self, m: M, s: M::Symbol) {
        let (lo, p) = m
            .left_cumulative_and_probability(s)
            .expect("symbol within the model's alphabet");
        self.note(lo, p.get());
    }

    /// Codes `s` with `m` and adapts `m`.
    #[inline]
    pub fn symbol(&mut self, m: &mut AdaptiveModel, s: usize) {
        self.note_symbol(&*m, s);
        m.update(s);
    }

    /// Codes `s` uniformly in `0..n`, any `n >= 1` up to 2^32.
    pub fn uniform(&mut self, s: u64, n: u64) {
        debug_assert!(s < n && n <= 1 << 32);
        if n <= 1 {
            return;
        }
        let bits = 64 - (n - 1).leading_zeros();
        let (top, top_n, shift) = if bits <= 16 {
            (s, n, 0)
        } else {
            // Top 16 bits uniformly over the values they can take, then the rest as raw
            // bits.
            let shift = bits - 16;
            (s >> shift, ((n - 1) >> shift) + 1, shift)
        };
        self.note_symbol(Uniform::new(top_n as u32), top as u32);
        self.bits(s & ((1 << shift) - 1), shift);
    }

    /// Codes the low `k` bits of `v` (k <= 64) as raw bits, most significant first, in
    /// chunks of at most 16.
    pub fn bits(&mut self, v: u64, k: u32) {
        let mut k = k;
        while k > 0 {
            let c = k.min(16);
            k -= c;
            let chunk = ((v >> k) & ((1u64 << c) - 1)) as u32;
            self.note_symbol(RawBits(c), chunk);
        }
    }

    /// Codes a signed integer (|v| < 2^62) with `m`.
    pub fn int(&mut self, m: &mut IntModel, v: i64) {
        let c = class_of(v);
        let neg = (v < 0) as usize;
        let a = v.unsigned_abs();
        let (s, _) = joint_symbol(v);
        self.symbol(&mut m.sym, s);
        if s == ESCAPE_SYMBOL {
            // Class, sign, then every bit below the leading one raw.
            self.symbol(&mut m.big, c);
            self.bits(neg as u64, 1);
            self.bits(a, c as u32 - 1);
            return;
        }
        if c >= 3 {
            self.bits(a, c as u32 - 2);
        }
    }

    /// A lower bound of the bytes [`Encoder::finish`] will return, from the
    /// information coded so far (the coder's last state holds up to 64 bits of it).
    pub fn written(&self) -> usize {
        ((self.info / 256).saturating_sub(64) / 8) as usize
    }

    /// Finishes the stream (SPEC.md 4.1): the symbols coded backwards by constriction
    /// 0.5's `DefaultAnsCoder`, its words written from the last (the state's top, without
    /// its leading zero bytes) to the first, big-endian.
    pub fn finish(self) -> Vec<u8> {
        if self.noted.is_empty() {
            return Vec::new();
        }
        let mut ans = DefaultAnsCoder::from_raw_parts(Vec::new(), START);
        for &n in self.noted.iter().rev() {
            let p = NonZeroU32::new((n >> 16) + 1).expect("at least 1");
            ans.encode_symbol((), Noted(n & 0xffff, p))
                .expect("a noted range is a valid symbol");
        }
        let words = ans.into_compressed().unwrap_or_default();
        let mut out = Vec::with_capacity(4 * words.len());
        for (i, w) in words.iter().rev().enumerate() {
            let b = w.to_be_bytes();
            // The top word is never zero: its leading zero bytes are left out.
            let skip = if i == 0 { w.leading_zeros() as usize / 8 } else { 0 };
            out.extend_from_slice(&b[skip..]);
        }
        out
    }
}

/// The encoder's first state (SPEC.md 4.1): every state after a symbol is above it, so
/// a decoder whose state is below it, with no word left, has read past the symbols.
const START: u64 = 1 << 16;

/// Reads what [`Encoder`] wrote.
pub struct Decoder {
    inner: DefaultAnsCoder,
    section: &'static str,
}

impl Decoder {
    /// Reads a stream from a section payload (SPEC.md 4.1): big-endian words, the first
    /// of `len mod 4` bytes when that is not 0 (its leading zero bytes left out), the
    /// first not zero.
    pub fn new(bytes: &[u8], section: &'static str) -> Result<Self> {
        let head = match bytes.len() % 4 {
            0 => 4.min(bytes.len()),
            r => r,
        };
        let (first, rest) = bytes.split_at(head);
        // The decoder pops words from the end: the last word read goes first.
        let mut words: Vec<u32> = rest
            .chunks_exact(4)
            .rev()
            .map(|c| u32::from_be_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if !first.is_empty() {
            let top = first.iter().fold(0u32, |w, &b| w << 8 | b as u32);
            if first[0] == 0 {
                return Err(Error::corrupt(section, "bad stream start"));
            }
            words.push(top);
        }
        let inner = DefaultAnsCoder::from_compressed(words)
            .map_err(|_| Error::corrupt(section, "bad stream start"))?;
        Ok(Decoder { inner, section })
    }

    /// One symbol with model `m`, unless the stream has run out (SPEC.md 4.1: a state
    /// below 2^16 with no word left).
    #[inline(always)]
    fn next<M>(&mut self, m: M) -> Result<M::Symbol>
    where
        M: DecoderModel<PRECISION, Probability = u32>,
    {
        if self.inner.bulk().is_empty() && self.inner.num_valid_bits() < 16 {
            return Err(self.ended());
        }
        match self.inner.decode_symbol(m) {
            Ok(s) => Ok(s),
            Err(e) => match e {},
        }
    }

    /// The error of a stream that ends before its symbols do.
    #[cold]
    #[inline(never)]
    fn ended(&self) -> Error {
        Error::corrupt(self.section, "the stream ends before its symbols do")
    }

    /// Decodes a symbol with `m` and adapts `m`.
    #[inline(always)]
    pub fn symbol(&mut self, m: &mut AdaptiveModel) -> Result<usize> {
        m.refresh();
        let s = self.next(&*m)?;
        m.update(s);
        Ok(s)
    }

    /// Decodes what [`Encoder::uniform`] wrote.
    pub fn uniform(&mut self, n: u64) -> Result<u64> {
        if n <= 1 {
            return Ok(0);
        }
        if n > 1 << 32 {
            return Err(Error::corrupt(self.section, "uniform range too large"));
        }
        let bits = 64 - (n - 1).leading_zeros();
        if bits <= 16 {
            let s = self.next(Uniform::new(n as u32))?;
            return Ok(s as u64);
        }
        let shift = bits - 16;
        let top_n = ((n - 1) >> shift) + 1;
        let top = self.next(Uniform::new(top_n as u32))? as u64;
        let v = (top << shift) | self.bits(shift)?;
        if v >= n {
            return Err(Error::corrupt(self.section, "uniform value out of range"));
        }
        Ok(v)
    }

    /// Decodes `k` raw bits.
    #[inline(always)]
    pub fn bits(&mut self, k: u32) -> Result<u64> {
        if (1..=16).contains(&k) {
            return self.next(RawBits(k)).map(u64::from);
        }
        self.long_bits(k)
    }

    /// [`Decoder::bits`] of none or more than 16, in chunks of 16.
    #[inline(never)]
    fn long_bits(&mut self, k: u32) -> Result<u64> {
        let mut v = 0u64;
        let mut k = k;
        while k > 0 {
            let c = k.min(16);
            k -= c;
            let chunk = self.next(RawBits(c))?;
            v = (v << c) | chunk as u64;
        }
        Ok(v)
    }

    /// Decodes what [`Encoder::int`] wrote.
    #[inline]
    pub fn int(&mut self, m: &mut IntModel) -> Result<i64> {
        self.int_symbol(m).map(|(v, ..)| v)
    }

    /// [`Decoder::int`], and `learner` counts the value as [`IntModel::observe`] would
    /// (from the symbols read rather than the value).
    #[inline(always)]
    pub fn int_observed(&mut self, m: &mut IntModel, learner: &mut IntModel) -> Result<i64> {
        let (v, s, c) = self.int_symbol(m)?;
        learner.count_symbol(s, c);
        Ok(v)
    }

    /// [`Decoder::int`]'s value, its joint symbol and its magnitude class.
    #[inline(always)]
    fn int_symbol(&mut self, m: &mut IntModel) -> Result<(i64, usize, usize)> {
        let s = self.symbol(&mut m.sym)?;
        let (c, neg, top) = match s {
            0 => return Ok((0, 0, 0)),
            1 | 2 => return Ok((if s == 2 { -1 } else { 1 }, s, 1)),
            ESCAPE_SYMBOL => {
                let c = self.symbol(&mut m.big)?;
                if c <= JOINT_MAX_CLASS || c > 62 {
                    return Err(Error::corrupt(self.section, "bad escaped integer class"));
                }
                let neg = self.bits(1)? == 1;
                let v = ((1u64 << (c - 1)) | self.bits(c as u32 - 1)?) as i64;
                return Ok((if neg { -v } else { v }, s, c));
            }
            _ => {
                let t = s - 3;
                (t / 4 + 2, t & 2 != 0, (t & 1) as u64)
            }
        };
        let a = ((2 | top) << (c - 2)) | self.bits(c as u32 - 2)?;
        let v = a as i64;
        Ok((if neg { -v } else { v }, s, c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn model_tables_sum_to_one() {
        let mut m = AdaptiveModel::new(40);
        for i in 0..100_000usize {
            m.update((i * i) % 7);
            assert_eq!(m.cum()[40], ONE);
            assert!(m.cum().windows(2).all(|w| w[1] > w[0]));
        }
    }

    #[test]
    fn bucketed_search_finds_every_quantile_symbol() {
        // Every quantile of models small and large, flat and skewed, as they adapt:
        // the symbol found is the one whose range holds the quantile.
        for (n, seed) in [(2usize, 1u64), (3, 2), (60, 3), (64, 4), (65, 5), (4096, 6)] {
            let mut m = AdaptiveModel::new(n);
            let mut r = seed;
            for round in 0..12 {
                // Before the decoder's refresh (a table just rebuilt), the whole table
                // is searched; after it, the bucket's symbols.
                for q in (0..ONE).step_by(7) {
                    let (s, ..) = m.quantile_function(q);
                    assert!(m.cum()[s] <= q && q < m.cum()[s + 1], "stale: n {n}, q {q}");
                }
                m.refresh();
                assert!(!m.stale);
                for q in 0..ONE {
                    let (s, lo, p) = m.quantile_function(q);
                    assert!(
                        m.cum()[s] <= q && q < m.cum()[s + 1],
                        "n {n}, round {round}, q {q}"
                    );
                    assert_eq!((lo, p.get()), (m.cum()[s], m.cum()[s + 1] - m.cum()[s]));
                }
                // Skew the model towards a few symbols, then a few more.
                for _ in 0..(700 << round.min(4)) {
                    r = r
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let pick = ((r >> 33) as usize % (round + 2)).min(n - 1);
                    m.update(if round % 2 == 0 { pick } else { n - 1 - pick });
                }
            }
        }
    }

    fn width(m: &AdaptiveModel, s: usize) -> u32 {
        m.cum()[s + 1] - m.cum()[s]
    }

    #[test]
    fn models_learn_from_the_first_symbol() {
        let mut m = AdaptiveModel::new(10);
        let uniform = width(&m, 3);
        m.update(3);
        // One symbol: the table has been rebuilt and has learnt it.
        assert!(width(&m, 3) > 4 * uniform, "{}", width(&m, 3));
    }

    #[test]
    fn reseeding_scales_counts_down_and_keeps_the_shape() {
        let mut m = AdaptiveModel::new(6);
        for i in 0..5_000usize {
            m.update(if i % 10 == 0 { 5 } else { 1 });
        }
        let before = (width(&m, 1), width(&m, 5));
        m.reseed(1024);
        assert!(m.total <= 1024 && m.total > 512, "{}", m.total);
        assert_eq!(m.total, m.counts().iter().sum::<u32>());
        assert_eq!(m.cum()[6], ONE);
        assert!(m.cum().windows(2).all(|w| w[1] > w[0]));
        // Still mostly 1, then 5; the halving rounds small counts up, so close, not equal.
        let after = (width(&m, 1), width(&m, 5));
        assert!(
            after.0.abs_diff(before.0) < ONE / 50,
            "{before:?} {after:?}"
        );
        assert!(
            after.1.abs_diff(before.1) < ONE / 50,
            "{before:?} {after:?}"
        );
        // Adapts at once again: one symbol of 3 rebuilds the table.
        let w3 = width(&m, 3);
        m.update(3);
        assert!(width(&m, 3) > w3);
        // A fresh model is left as it is.
        let mut fresh = AdaptiveModel::new(6);
        let cum = fresh.cum().to_vec();
        fresh.reseed(1024);
        assert_eq!(fresh.cum(), cum);
    }

    #[test]
    fn skewed_data_costs_little() {
        let mut e = Encoder::new();
        let mut m = AdaptiveModel::new(8);
        for i in 0..10_000 {
            e.symbol(&mut m, if i % 100 == 0 { 3 } else { 0 });
        }
        let bytes = e.finish();
        // Entropy of this source is about 0.08 bits per symbol: 100 bytes.
        assert!(bytes.len() < 250, "{} bytes", bytes.len());
    }

    #[test]
    fn size_bound_holds_and_streams_start_with_a_nonzero_byte() {
        // 400 streams of 0 to 3,999 symbols from a pseudo-random source: `written` never
        // passes the finished size and follows it to within 64 bits and 2 %.
        let source = |n: usize| {
            let mut x = n as u64;
            (0..n).map(move |_| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((x >> 33) % 20) as usize % (1 + (x >> 60) as usize)
            })
        };
        for n in (0..4000).step_by(10) {
            let (mut e, mut m) = (Encoder::new(), AdaptiveModel::new(20));
            source(n).for_each(|s| e.symbol(&mut m, s));
            let bound = e.written();
            let bytes = e.finish();
            assert!(bound <= bytes.len(), "{n} symbols: {bound} > {}", bytes.len());
            assert!(bytes.len() <= bound + 16 + bytes.len() / 50, "{n}: {bound} {}", bytes.len());
            assert!(bytes.first().is_none_or(|&b| b != 0), "{n} symbols");
            let mut d = Decoder::new(&bytes, "test").unwrap();
            let mut m = AdaptiveModel::new(20);
            for s in source(n) {
                assert_eq!(d.symbol(&mut m).unwrap(), s);
            }
        }
        // Past its symbols a stream is corrupt at once or at the next symbol, however
        // much is asked of it.
        for n in [0, 1, 5, 300] {
            let (mut e, mut m) = (Encoder::new(), AdaptiveModel::new(20));
            source(n).for_each(|s| e.symbol(&mut m, s));
            let bytes = e.finish();
            let mut d = Decoder::new(&bytes, "test").unwrap();
            let mut m = AdaptiveModel::new(20);
            for s in source(n) {
                assert_eq!(d.symbol(&mut m).unwrap(), s);
            }
            let past = (0..2).map(|_| d.symbol(&mut m)).collect::<Vec<_>>();
            assert!(past.iter().any(|r| r.is_err()), "{n} symbols: {past:?}");
            let mut im = IntModel::new();
            assert!((0..2).any(|_| d.int(&mut im).is_err()), "{n} symbols");
        }
        // A leading zero byte, or a zero first word, is not a stream.
        assert!(Decoder::new(&[0, 1, 2, 3, 4], "test").is_err());
        assert!(Decoder::new(&[0, 0, 0, 0], "test").is_err());
    }

    proptest! {
        #[test]
        fn mixed_stream_round_trips(
            syms in proptest::collection::vec(0usize..37, 0..300),
            ints in proptest::collection::vec(-(1i64 << 61)..(1i64 << 61), 0..300),
            small in proptest::collection::vec(-40i64..40, 0..300),
            unis in proptest::collection::vec((1u64..=1 << 32, proptest::num::u64::ANY), 0..50),
        ) {
            let mut e = Encoder::new();
            let mut m = AdaptiveModel::new(37);
            let mut im = IntModel::new();
            for &s in &syms { e.symbol(&mut m, s); }
            for &v in ints.iter().chain(&small) { e.int(&mut im, v); }
            for &(n, r) in &unis { e.uniform(r % n, n); }
            let bytes = e.finish();
            let mut d = Decoder::new(&bytes, "test").unwrap();
            let mut m = AdaptiveModel::new(37);
            let mut im = IntModel::new();
            for &s in &syms { prop_assert_eq!(d.symbol(&mut m).unwrap(), s); }
            for &v in ints.iter().chain(&small) { prop_assert_eq!(d.int(&mut im).unwrap(), v); }
            for &(n, r) in &unis { prop_assert_eq!(d.uniform(n).unwrap(), r % n); }
        }

        #[test]
        fn garbage_never_panics(
            bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..160),
        ) {
            if let Ok(mut d) = Decoder::new(&bytes, "test") {
                let mut m = AdaptiveModel::new(5);
                let mut im = IntModel::new();
                for _ in 0..200 {
                    let _ = d.symbol(&mut m);
                    let _ = d.int(&mut im);
                    let _ = d.uniform(1_000_003);
                }
            }
        }
    }
}

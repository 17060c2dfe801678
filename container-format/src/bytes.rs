//! Little-endian fields and LEB128 varints (SPEC.md 2.3), read with bounds checks.

use crate::Error;

/// Reads fields from a section payload. Every read is bounds-checked and names the
/// field and byte offset in its error.
#[derive(Debug, Clone)]
pub struct ByteReader<'a> {
    data: &'a [u8],
    pos: usize,
    /// Offset of `data[0]` in the container, for error messages.
    base: u64,
}

impl<'a> ByteReader<'a> {
    /// Reads `data`, which starts at byte `base` of the container.
    pub fn new(data: &'a [u8], base: u64) -> Self {
        ByteReader { data, pos: 0, base }
    }

    /// The container offset of the next byte.
    pub fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }

    /// Bytes not yet read.
    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    fn short(&self, what: &str) -> Error {
        Error::malformed(
            self.offset(),
            format!("{what} runs past the end of its section"),
        )
    }

    /// One byte.
    pub fn u8(&mut self, what: &str) -> Result<u8, Error> {
        let b = *self.data.get(self.pos).ok_or_else(|| self.short(what))?;
        self.pos += 1;
        Ok(b)
    }

    /// `n` raw bytes.
    pub fn bytes(&mut self, n: usize, what: &str) -> Result<&'a [u8], Error> {
        if n > self.remaining() {
            return Err(self.short(what));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// A little-endian `u32`.
    pub fn u32_le(&mut self, what: &str) -> Result<u32, Error> {
        let b = self.bytes(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// An unsigned LEB128 varint of at most 10 bytes, canonical (no redundant
    /// trailing zero groups), fitting in `u64`.
    pub fn varint(&mut self, what: &str) -> Result<u64, Error> {
        let start = self.offset();
        let mut value: u64 = 0;
        for i in 0..10 {
            let b = self.u8(what)?;
            let group = (b & 0x7f) as u64;
            if i == 9 && group > 1 {
                return Err(Error::malformed(
                    start,
                    format!("{what}: varint overflows 64 bits"),
                ));
            }
            value |= group << (7 * i);
            if b & 0x80 == 0 {
                if i > 0 && group == 0 {
                    return Err(Error::malformed(start, format!("{what}: overlong varint")));
                }
                return Ok(value);
            }
        }
        Err(Error::malformed(
            start,
            format!("{what}: varint longer than 10 bytes"),
        ))
    }

    /// A varint that must not exceed `max`.
    pub fn varint_max(&mut self, what: &str, max: u64) -> Result<u64, Error> {
        let start = self.offset();
        let v = self.varint(what)?;
        if v > max {
            return Err(Error::malformed(
                start,
                format!("{what} = {v}, more than {max}"),
            ));
        }
        Ok(v)
    }

    /// A zigzag-coded signed varint.
    pub fn varint_signed(&mut self, what: &str) -> Result<i64, Error> {
        let v = self.varint(what)?;
        Ok(((v >> 1) as i64) ^ -((v & 1) as i64))
    }

    /// Fails unless every byte was read.
    pub fn finish(&self, what: &str) -> Result<(), Error> {
        if self.remaining() != 0 {
            return Err(Error::malformed(
                self.offset(),
                format!("{} unexpected bytes at the end of {what}", self.remaining()),
            ));
        }
        Ok(())
    }
}

/// Writes the fields [`ByteReader`] reads.
#[derive(Debug, Clone, Default)]
pub struct ByteWriter {
    /// The bytes written so far.
    pub out: Vec<u8>,
}

impl ByteWriter {
    /// An empty writer.
    pub fn new() -> Self {
        Self::default()
    }

    /// One byte.
    pub fn u8(&mut self, v: u8) {
        self.out.push(v);
    }

    /// A little-endian `u32`.
    pub fn u32_le(&mut self, v: u32) {
        self.out.extend_from_slice(&v.to_le_bytes());
    }

    /// An unsigned LEB128 varint.
    pub fn varint(&mut self, mut v: u64) {
        loop {
            let b = (v & 0x7f) as u8;
            v >>= 7;
            if v == 0 {
                self.out.push(b);
                return;
            }
            self.out.push(b | 0x80);
        }
    }

    /// A zigzag-coded signed varint.
    pub fn varint_signed(&mut self, v: i64) {
        self.varint(((v << 1) ^ (v >> 63)) as u64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        #[test]
        fn varints_round_trip(v in proptest::num::u64::ANY, s in proptest::num::i64::ANY) {
            let mut w = ByteWriter::new();
            w.varint(v);
            w.varint_signed(s);
            let mut r = ByteReader::new(&w.out, 0);
            proptest::prop_assert_eq!(r.varint("v").unwrap(), v);
            proptest::prop_assert_eq!(r.varint_signed("s").unwrap(), s);
            r.finish("test").unwrap();
        }
    }

    #[test]
    fn rejects_overlong_and_overflow() {
        assert!(ByteReader::new(&[0x80, 0x00], 0).varint("x").is_err());
        assert!(ByteReader::new(&[0xff; 10], 0).varint("x").is_err());
        let mut over = vec![0xff; 9];
        over.push(0x02);
        assert!(ByteReader::new(&over, 0).varint("x").is_err());
        assert!(ByteReader::new(&[0x80], 0).varint("x").is_err());
    }
}

//! Plain CDR, little-endian, as ROS 2 sends a message after its 4-byte encapsulation header: each primitive
//! aligned to its size (8 for 64-bit values) from the start of the body; a string as its byte length with the
//! terminating NUL, the bytes and the NUL; a wstring as its length in UTF-16 code units and each unit in 4 bytes
//! (rosidl_typesupport_fastrtps widens a `u16string` to a `wstring`); a sequence as its length, then the
//! elements.

/// Writes a CDR body (the encoding above), one primitive at a time: what [`Interfaces::encode`] writes a
/// payload with, public for encoders of other value shapes (the Python package's rosidl objects).
///
/// [`Interfaces::encode`]: super::Interfaces::encode
#[derive(Default)]
pub struct Writer {
    buf: Vec<u8>,
}

impl Writer {
    fn align(&mut self, n: usize) {
        while !self.buf.len().is_multiple_of(n) {
            self.buf.push(0);
        }
    }

    /// A `byte`, `char`, `uint8`, `int8` (as its bits) or `bool` (0 or 1).
    pub fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }

    /// A 16-bit value, aligned to 2.
    pub fn u16(&mut self, v: u16) {
        self.align(2);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A 32-bit value (a `float32` as its bits, a sequence's length), aligned to 4.
    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A 64-bit value (a `float64` as its bits), aligned to 8.
    pub fn u64(&mut self, v: u64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `string`: its length with the NUL, its bytes, the NUL.
    pub fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// A `wstring`: its length in UTF-16 code units, each unit in 4 bytes.
    pub fn wstring(&mut self, s: &str) {
        let units: Vec<u16> = s.encode_utf16().collect();
        self.u32(units.len() as u32);
        for u in units {
            self.u32(u32::from(u));
        }
    }

    /// Elements already in their little-endian bytes (`b`), the first aligned to `align`: a numeric array
    /// copied whole. Nothing at all, no padding either, when `b` is empty.
    pub fn elements(&mut self, align: usize, b: &[u8]) {
        if !b.is_empty() {
            self.align(align);
            self.buf.extend_from_slice(b);
        }
    }

    /// The body written.
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
}

/// Reads a CDR body (the encoding above); every read checks that the bytes are there, and an error says where
/// the message ended short. Public for decoders of other value shapes (the Python package's rosidl objects).
pub struct Reader<'a> {
    buf: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// A reader at the start of the body `buf`.
    pub fn new(buf: &'a [u8]) -> Reader<'a> {
        Reader { buf, at: 0 }
    }

    /// Bytes left after the current position.
    pub fn remaining(&self) -> usize {
        self.buf.len().saturating_sub(self.at)
    }

    /// `n` elements of `size` bytes each, as their bytes, the first aligned to `size`; nothing at all, no padding
    /// either, when `n` is 0: a numeric array read whole.
    pub fn elements(&mut self, size: usize, n: usize) -> Result<&'a [u8], String> {
        if n == 0 {
            return Ok(&[]);
        }
        let bytes = n
            .checked_mul(size)
            .filter(|b| *b <= self.remaining())
            .ok_or_else(|| format!("{n} elements of {size} bytes in {} bytes", self.remaining()))?;
        self.take(size, bytes)
    }

    fn take(&mut self, align: usize, n: usize) -> Result<&'a [u8], String> {
        let start = self.at.div_ceil(align) * align;
        let end = start + n;
        if end > self.buf.len() {
            return Err(format!(
                "the message ends at byte {} where {n} more were expected at {start}",
                self.buf.len()
            ));
        }
        self.at = end;
        Ok(&self.buf[start..end])
    }

    /// A `byte`, `char`, `uint8`, `int8` (its bits) or `bool`.
    pub fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1, 1)?[0])
    }

    /// A 16-bit value, aligned to 2.
    pub fn u16(&mut self) -> Result<u16, String> {
        Ok(u16::from_le_bytes(self.take(2, 2)?.try_into().unwrap()))
    }

    /// A 32-bit value, aligned to 4.
    pub fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4, 4)?.try_into().unwrap()))
    }

    /// A 64-bit value, aligned to 8.
    pub fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8, 8)?.try_into().unwrap()))
    }

    /// A `string` (UTF-8; an error otherwise).
    pub fn string(&mut self) -> Result<String, String> {
        let n = self.u32()? as usize;
        if n == 0 {
            return Ok(String::new()); // some writers send an empty string without its NUL
        }
        let bytes = self.take(1, n)?;
        let text = &bytes[..n - 1];
        String::from_utf8(text.to_vec()).map_err(|e| format!("a string that is not UTF-8: {e}"))
    }

    /// A `wstring`.
    pub fn wstring(&mut self) -> Result<String, String> {
        let n = self.u32()? as usize;
        if n.saturating_mul(4) > self.remaining() {
            return Err(format!(
                "a wstring of {n} characters in {} bytes",
                self.remaining()
            ));
        }
        let mut units = Vec::with_capacity(n);
        for _ in 0..n {
            units.push(self.u32()? as u16);
        }
        String::from_utf16(&units).map_err(|e| format!("a wstring that is not UTF-16: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_are_aligned_to_their_size_from_the_body_start() {
        let mut w = Writer::default();
        w.u8(1);
        w.u32(2);
        w.u8(3);
        w.u64(4);
        w.string("ab");
        let b = w.finish();
        assert_eq!(
            b,
            [
                1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 0, 0, 0, 0, 4, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0, 0,
                b'a', b'b', 0
            ]
        );
        let mut r = Reader::new(&b);
        assert_eq!(
            (r.u8(), r.u32(), r.u8(), r.u64()),
            (Ok(1), Ok(2), Ok(3), Ok(4))
        );
        assert_eq!(r.string().as_deref(), Ok("ab"));
        assert!(r.u8().is_err(), "nothing left");
    }

    #[test]
    fn a_wstring_is_its_utf16_units_four_bytes_each() {
        let mut w = Writer::default();
        w.wstring("hé");
        let b = w.finish();
        assert_eq!(b, [2, 0, 0, 0, b'h', 0, 0, 0, 0xe9, 0, 0, 0]);
        assert_eq!(Reader::new(&b).wstring().as_deref(), Ok("hé"));
    }

    #[test]
    fn a_short_message_is_an_error_not_a_panic() {
        assert!(Reader::new(&[5, 0, 0, 0, b'a']).string().is_err());
        assert!(Reader::new(&[0xff, 0xff, 0xff, 0x7f]).wstring().is_err());
        assert!(Reader::new(&[1, 2]).u32().is_err());
    }
}

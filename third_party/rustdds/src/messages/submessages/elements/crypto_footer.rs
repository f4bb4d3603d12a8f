use speedy::{Context, Readable, Writable};

/// CryptoFooter: section 7.3.6.2.4 of the Security specification (v.
/// 1.1)
/// Should be interpreted by the plugin based on `transformation_id`
#[derive(Debug, PartialEq, Eq, Clone)]
pub struct CryptoFooter {
  pub data: Vec<u8>,
}
impl From<Vec<u8>> for CryptoFooter {
  fn from(data: Vec<u8>) -> Self {
    Self { data }
  }
}
impl From<CryptoFooter> for Vec<u8> {
  fn from(CryptoFooter { data }: CryptoFooter) -> Self {
    data
  }
}

// According to 9.5.2.5 and Wireshark, CryptoFooter is just a blob of data
// specific to plugin implementation, and the serialization does not include its
// length
impl<C: Context> Writable<C> for CryptoFooter {
  fn write_to<T: ?Sized + speedy::Writer<C>>(
    &self,
    writer: &mut T,
  ) -> Result<(), <C as Context>::Error> {
    writer.write_bytes(&self.data)
  }
}

impl<'a, C: Context> Readable<'a, C> for CryptoFooter {
  fn read_from<R: speedy::Reader<'a, C>>(reader: &mut R) -> Result<Self, <C as Context>::Error> {
    // RADAR patch 66: a reader over a buffer (every received submessage) hands the rest over at once;
    // speedy's generic loop reads a byte at a time and stops at an end-of-input error (about 1,700
    // instructions for a 20-byte footer, five footers a secured sample). Other readers: the loop.
    if let Some(rest) = reader.read_bytes_borrowed_until_eof() {
      return Ok(Self::from(rest.to_vec()));
    }
    reader.read_vec_until_eof().map(Self::from)
  }
}

#[cfg(test)]
mod tests {
  use speedy::{Endianness, Readable};

  use super::CryptoFooter;

  /// The rest of a buffer, read at once (patch 66), is what the byte loop of a stream reader reads, for an
  /// empty footer, a common MAC alone and one with receiver-specific MACs.
  #[test]
  fn a_footer_read_from_a_buffer_is_the_footer_read_from_a_stream() {
    for len in [0usize, 1, 20, 24, 44, 64, 200] {
      let bytes: Vec<u8> = (0..len).map(|i| (i * 7 + 3) as u8).collect();
      for e in [Endianness::LittleEndian, Endianness::BigEndian] {
        let from_buffer = CryptoFooter::read_from_buffer_with_ctx(e, &bytes).unwrap();
        let from_stream =
          CryptoFooter::read_from_stream_unbuffered_with_ctx(e, bytes.as_slice()).unwrap();
        assert_eq!(from_buffer.data, bytes, "{len} bytes from a buffer");
        assert_eq!(from_stream, from_buffer, "{len} bytes from a stream");
      }
    }
  }
}

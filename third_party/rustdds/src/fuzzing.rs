//! What arrives from the network, as fuzz targets (RADAR patch 32). Feature `fuzzing`: used by `fuzz/`
//! (cargo-fuzz, nightly, run for minutes), and by this module's unit tests, which run every target over the
//! committed corpus (`fuzz/corpus/<target>/`) and seeded mutations of it for a bounded time (stable, CI).
//!
//! Each target takes the bytes a peer could send and hands them to the code that reads them: a malformed
//! message must cost its sender (it is dropped), never the receiver (no panic, no hang).

use std::{cell::RefCell, rc::Rc};

use bytes::Bytes;

use crate::{
  discovery::{
    DiscoveredReaderData, DiscoveredTopicData, DiscoveredWriterData, SpdpDiscoveredParticipantData,
  },
  network::udp_listener::PacketOrigin,
  polling::{wake_channel, LoopWaker},
  rtps::{message::Message, message_receiver::MessageReceiver, transmit::InterfaceObservations},
  serialization::pl_cdr_adapters::PlCdrDeserialize,
  structure::guid::GuidPrefix,
  RepresentationIdentifier,
};

/// The targets, by the name of their corpus directory.
pub const TARGETS: &[(&str, fn(&[u8]))] = &[
  ("rtps_message", rtps_message),
  ("receiver", receiver),
  ("spdp", spdp),
  ("sedp", sedp),
  #[cfg(feature = "security")]
  ("handshake", handshake),
];

/// An RTPS datagram, parsed as the message receiver parses it (header and every submessage).
pub fn rtps_message(data: &[u8]) {
  let _ = Message::read_from_buffer(&Bytes::copy_from_slice(data));
}

/// An RTPS datagram handed to a participant's message receiver (no readers or writers of its own: what a
/// datagram does before it reaches one, interpreter submessages, ACKNACKs, HEARTBEATs, GAPs, fragments).
pub fn receiver(data: &[u8]) {
  let waker = LoopWaker::new();
  let (acknacks, _acknacks) = wake_channel(8, &waker);
  let (liveness, _liveness) = wake_channel(8, &waker);
  let mut r = MessageReceiver::new(
    GuidPrefix::new(&[1; 12]),
    acknacks,
    liveness,
    None,
    Rc::new(RefCell::new(InterfaceObservations::new())),
  );
  r.handle_received_packet(&Bytes::copy_from_slice(data), PacketOrigin::UNKNOWN);
}

const ENCODINGS: [RepresentationIdentifier; 2] = [
  RepresentationIdentifier::PL_CDR_LE,
  RepresentationIdentifier::PL_CDR_BE,
];

/// A participant announcement (SPDP), in both encodings.
pub fn spdp(data: &[u8]) {
  for e in ENCODINGS {
    let _ = SpdpDiscoveredParticipantData::from_pl_cdr_bytes(data, e);
  }
}

/// An endpoint or topic announcement (SEDP), as each of the three, in both encodings.
pub fn sedp(data: &[u8]) {
  for e in ENCODINGS {
    let _ = DiscoveredReaderData::from_pl_cdr_bytes(data, e);
    let _ = DiscoveredWriterData::from_pl_cdr_bytes(data, e);
    let _ = DiscoveredTopicData::from_pl_cdr_bytes(data, e);
  }
}

/// A DDS Security authentication message (`ParticipantStatelessMessage`, CDR, both byte orders) and every
/// handshake token in it, parsed as the authentication plugin parses them (feature `security`).
#[cfg(feature = "security")]
pub fn handshake(data: &[u8]) {
  use byteorder::{BigEndian, LittleEndian};

  use crate::security::types::ParticipantStatelessMessage;
  let messages = [
    cdr_encoding::from_bytes::<ParticipantStatelessMessage, LittleEndian>(data).map(|(m, _)| m),
    cdr_encoding::from_bytes::<ParticipantStatelessMessage, BigEndian>(data).map(|(m, _)| m),
  ];
  for m in messages.into_iter().flatten() {
    for dh in m.generic.message_data {
      crate::security::authentication::authentication_builtin::parse_handshake_token(dh.into());
    }
  }
}

#[cfg(test)]
mod tests {
  use std::{
    panic::{catch_unwind, AssertUnwindSafe},
    path::PathBuf,
    time::{Duration, Instant},
  };

  use speedy::Writable;

  use super::*;
  use crate::{
    serialization::pl_cdr_adapters::PlCdrSerialize,
    test::test_data::{
      spdp_participant_data, spdp_participant_data_raw, spdp_publication_data_raw,
      spdp_subscription_data_raw,
    },
  };

  /// xorshift64*: a mutation sequence that a seed repeats.
  struct Rng(u64);
  impl Rng {
    fn next(&mut self) -> u64 {
      self.0 ^= self.0 >> 12;
      self.0 ^= self.0 << 25;
      self.0 ^= self.0 >> 27;
      self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
      (self.next() % (n.max(1) as u64)) as usize
    }
  }

  /// One mutation of `input`, some of them taken from `others` (splices).
  fn mutate(rng: &mut Rng, input: &[u8], others: &[Vec<u8>]) -> Vec<u8> {
    let mut v = input.to_vec();
    for _ in 0..1 + rng.below(4) {
      let len = v.len();
      match rng.below(8) {
        0 if len > 0 => {
          let i = rng.below(len);
          v[i] ^= 1 << rng.below(8);
        }
        1 if len > 0 => {
          let i = rng.below(len);
          v[i] = [0, 0xff, 0x7f, 0x80, 1][rng.below(5)];
        }
        2 => {
          let i = rng.below(len + 1);
          let n = 1 + rng.below(16);
          let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
          v.splice(i..i, bytes);
        }
        3 if len > 0 => {
          let i = rng.below(len);
          let n = 1 + rng.below(len - i);
          v.drain(i..i + n);
        }
        4 => v.truncate(rng.below(len + 1)),
        // a length or count field set to something large (16-bit and 32-bit, both byte orders)
        5 if len >= 4 => {
          let i = rng.below(len - 3);
          let big = [0xffff_ffffu32, 0x7fff_ffff, 0x0001_0000, 0xffff][rng.below(4)];
          let b = if rng.below(2) == 0 { big.to_le_bytes() } else { big.to_be_bytes() };
          let n = if rng.below(2) == 0 { 2 } else { 4 };
          v[i..i + n].copy_from_slice(&b[..n]);
        }
        6 if !others.is_empty() => {
          let o = &others[rng.below(others.len())];
          let i = rng.below(len + 1);
          let j = rng.below(o.len() + 1);
          v.truncate(i);
          v.extend_from_slice(&o[j..]);
        }
        _ if len > 1 => {
          // a chunk repeated
          let i = rng.below(len);
          let n = 1 + rng.below((len - i).min(32));
          let chunk = v[i..i + n].to_vec();
          v.splice(i..i, chunk);
        }
        _ => v.push(rng.next() as u8),
      }
    }
    v
  }

  fn corpus_dir(target: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
      .join("fuzz/corpus")
      .join(target)
  }

  /// The committed corpus of `target`, and what this crate can make of its own for it.
  fn seeds(target: &str) -> Vec<Vec<u8>> {
    let mut seeds: Vec<Vec<u8>> = std::fs::read_dir(corpus_dir(target))
      .map(|d| {
        d.filter_map(|e| std::fs::read(e.ok()?.path()).ok())
          .collect()
      })
      .unwrap_or_default();
    seeds.extend(builtin_seeds(target));
    seeds
  }

  fn builtin_seeds(target: &str) -> Vec<Vec<u8>> {
    let pl = |b: Bytes| b[4..].to_vec(); // without the encapsulation header
    match target {
      "spdp" => vec![
        pl(spdp_participant_data_raw()),
        spdp_participant_data()
          .unwrap()
          .to_pl_cdr_bytes(RepresentationIdentifier::PL_CDR_LE)
          .unwrap()
          .to_vec(),
      ],
      "sedp" => vec![
        pl(spdp_subscription_data_raw()),
        pl(spdp_publication_data_raw()),
      ],
      #[cfg(feature = "security")]
      "handshake" => handshake_seeds(),
      _ => vec![
        crate::test::test_data::spdp_participant_msg()
          .write_to_vec_with_ctx(speedy::Endianness::LittleEndian)
          .unwrap(),
        crate::test::test_data::spdp_publication_msg()
          .write_to_vec_with_ctx(speedy::Endianness::LittleEndian)
          .unwrap(),
      ],
    }
  }

  /// An authentication request, reply and final message, with every property the handshake reads.
  #[cfg(feature = "security")]
  fn handshake_seeds() -> Vec<Vec<u8>> {
    use crate::security::types::{
      DataHolderBuilder, ParticipantGenericMessage, ParticipantStatelessMessage,
    };
    ["DDS:Auth:PKI-DH:1.0+Req", "DDS:Auth:PKI-DH:1.0+Reply", "DDS:Auth:PKI-DH:1.0+Final"]
      .iter()
      .map(|class| {
        let mut b = DataHolderBuilder::with_class_id(class.to_string());
        for (name, len) in [
          ("c.id", 600),
          ("c.perm", 400),
          ("c.pdata", 64),
          ("c.dsign_algo", 15),
          ("c.kagree_algo", 15),
          ("hash_c1", 32),
          ("hash_c2", 32),
          ("dh1", 65),
          ("dh2", 65),
          ("challenge1", 32),
          ("challenge2", 32),
          ("signature", 64),
        ] {
          b = b.add_binary_property(name, Bytes::from(vec![7u8; len]), true);
        }
        let m = ParticipantStatelessMessage {
          generic: ParticipantGenericMessage {
            message_identity: Default::default(),
            related_message_identity: Default::default(),
            destination_participant_guid: Default::default(),
            destination_endpoint_guid: Default::default(),
            source_endpoint_guid: Default::default(),
            message_class_id: "dds.sec.auth".to_string(),
            message_data: vec![b.build()],
          },
        };
        cdr_encoding::to_vec::<_, byteorder::LittleEndian>(&m).unwrap()
      })
      .collect()
  }

  /// How long each target is fuzzed in a test run: `RADAR_FUZZ_SECONDS` (default 3).
  fn budget() -> Duration {
    let s = std::env::var("RADAR_FUZZ_SECONDS")
      .ok()
      .and_then(|s| s.parse::<f64>().ok())
      .unwrap_or(3.0);
    Duration::from_secs_f64(s)
  }

  /// Runs `f` on every seed, then on seeded mutations of them until the budget is spent; panics naming the
  /// input (hex) that made `f` panic.
  fn fuzz(target: &str, f: fn(&[u8])) -> usize {
    let seeds = seeds(target);
    assert!(!seeds.is_empty(), "no seeds for {target}");
    let seed = std::env::var("RADAR_FUZZ_SEED")
      .ok()
      .and_then(|s| s.parse().ok())
      .unwrap_or(0x5eed_u64);
    let mut rng = Rng(seed | 1);
    let run = |input: &[u8]| {
      if catch_unwind(AssertUnwindSafe(|| f(input))).is_err() {
        let hex: String = input.iter().map(|b| format!("{b:02x}")).collect();
        panic!("{target}: panicked on input {hex} (RADAR_FUZZ_SEED={seed})");
      }
    };
    for s in &seeds {
      run(s);
    }
    // `RADAR_FUZZ_WRITE_CORPUS=1`: the built-in seeds become corpus files (how fuzz/corpus/ began)
    if std::env::var_os("RADAR_FUZZ_WRITE_CORPUS").is_some() {
      let dir = corpus_dir(target);
      std::fs::create_dir_all(&dir).unwrap();
      for (i, s) in builtin_seeds(target).iter().enumerate() {
        std::fs::write(dir.join(format!("builtin-{i}")), s).unwrap();
      }
    }
    let (start, budget) = (Instant::now(), budget());
    let mut n = seeds.len();
    while start.elapsed() < budget {
      let base = &seeds[rng.below(seeds.len())];
      let input = mutate(&mut rng, base, &seeds);
      run(&input);
      n += 1;
    }
    n
  }

  #[test]
  fn every_target_survives_its_corpus_and_mutations_of_it() {
    // the panics are caught and reported with their input: keep the default hook quiet meanwhile
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let result = catch_unwind(|| {
      TARGETS
        .iter()
        .map(|(name, f)| (*name, fuzz(name, *f)))
        .collect::<Vec<_>>()
    });
    std::panic::set_hook(hook);
    match result {
      Ok(counts) => println!("inputs run: {counts:?}"),
      Err(e) => std::panic::resume_unwind(e),
    }
  }
}

//! cargo-fuzz target: `rustdds::fuzzing::handshake` (feature `security`; see ../../src/fuzzing.rs).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| rustdds::fuzzing::handshake(data));

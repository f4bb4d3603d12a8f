//! cargo-fuzz target: `rustdds::fuzzing::receiver` (see ../../src/fuzzing.rs).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| rustdds::fuzzing::receiver(data));

//! Fuzzes the LUSTBUS streaming decoders (bus sniffer, master, slave) and the
//! whole-telegram decoder with one arbitrary byte stream. The body lives in
//! `driveset_proto::lustbus::fuzzing` so `tests/integration/lustbus_fuzz_corpus.rs`
//! replays the seed corpus in CI without cargo-fuzz.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    driveset_proto::lustbus::fuzzing::lustbus_stream(data);
});

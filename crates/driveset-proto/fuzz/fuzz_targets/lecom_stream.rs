//! Fuzzes the LECOM-A/B streaming decoders (master, slave, bus sniffer) and
//! the whole-frame decoders with one arbitrary byte stream. The body lives in
//! `driveset_proto::lecom::fuzzing` so `tests/integration/lecom_stream.rs` replays the
//! seed corpus in CI without cargo-fuzz.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    driveset_proto::lecom::fuzzing::lecom_stream(data);
});

//! Fuzzes the slcan decoders of both directions and the SDO client/server
//! behind them with one arbitrary byte stream. The body lives in
//! `driveset_proto::can::fuzzing` so `tests/integration/can_fuzz_corpus.rs` replays the
//! seed corpus in CI without cargo-fuzz.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    driveset_proto::can::fuzzing::slcan_sdo_stream(data);
});

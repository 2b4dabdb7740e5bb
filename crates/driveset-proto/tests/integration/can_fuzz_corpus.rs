//! Replays every seed of `fuzz/corpus/slcan_sdo_stream/` through the fuzz
//! target's body, so CI exercises it without cargo-fuzz.

use std::path::Path;

use driveset_test_support::files_in;

#[test]
fn replay_slcan_sdo_stream_corpus() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/slcan_sdo_stream");
    let entries = files_in(&dir);
    for (_, data) in &entries {
        driveset_proto::can::fuzzing::slcan_sdo_stream(data);
    }
    assert!(
        entries.len() >= 8,
        "expected the seed corpus in {}",
        dir.display()
    );
}

//! Replays every seed of `fuzz/corpus/slcan_sdo_stream/` through the fuzz
//! target's body, so CI exercises it without cargo-fuzz.

use std::fs;
use std::path::Path;

#[test]
fn replay_slcan_sdo_stream_corpus() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/slcan_sdo_stream");
    let mut entries: Vec<_> = fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.is_file())
        .collect();
    entries.sort();
    for path in &entries {
        let data = fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        driveset_proto::can::fuzzing::slcan_sdo_stream(&data);
    }
    assert!(
        entries.len() >= 8,
        "expected the seed corpus in {}",
        dir.display()
    );
}

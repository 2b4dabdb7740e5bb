//! The workspace's example parameter sets (`parameter-sets/`), loaded
//! against the built-in schemas, as the transaction tests upload them.

use std::path::Path;

use driveset_schema::{Registry, ResolvedSet, load_set};

/// The example set at `rel` (from the workspace root, e.g.
/// `parameter-sets/mc6000/axis-1.toml`), resolved; it loads without
/// findings.
pub fn example_set(rel: &str) -> ResolvedSet {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel);
    let mut reg = Registry::builtin().expect("builtin");
    let loaded = load_set(&path, &mut reg).expect("set loads");
    assert!(loaded.findings.is_empty(), "{:?}", loaded.findings);
    loaded.resolved.expect("resolved")
}

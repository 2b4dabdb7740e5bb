//! The schema crate's one integration-test binary (one binary per crate,
//! fast to link). Fixtures are in `tests/fixtures/`; unit tests live beside
//! the code in `src/`.

mod check;
mod prop;
mod sets;

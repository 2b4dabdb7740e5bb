//! The proto crate's one integration-test binary (one binary per crate,
//! fast to link): property tests, the specs' examples and the fuzz
//! corpora replayed without cargo-fuzz. Unit tests live beside the codecs
//! in `src/`.

mod can_fuzz_corpus;
mod can_props;
mod lecom_stream;
mod lustbus_fuzz_corpus;
mod lustbus_props;
mod lustbus_spec_examples;

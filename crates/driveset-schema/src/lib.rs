//! driveset-schema: schema and parameter-set model, exact values and scaling,
//! validation, canonical form, fingerprint, diff and export (no bus IO).
//!
//! The file formats this crate reads and writes are specified in
//! `docs/file-formats.md`; that document is the contract.
//!
//! Typical use:
//!
//! ```no_run
//! use driveset_schema::{Registry, load_set};
//! let registry = Registry::builtin().expect("built-in schemas parse");
//! let loaded = load_set(std::path::Path::new("set.toml"), &mut registry.clone()).unwrap();
//! for f in &loaded.findings {
//!     eprintln!("{}", f.render_human());
//! }
//! if let Some(set) = &loaded.resolved {
//!     println!("{}", set.fingerprint());
//! }
//! ```

pub mod canonical;
pub mod check;
pub mod decimal;
pub mod diff;
pub mod doc;
pub mod eds;
pub mod error;
pub mod export;
pub mod family;
mod fnv;
pub mod input;
pub mod output;
pub mod role;
pub mod schema;
pub mod set;
mod toml_reader;
pub mod validate;
pub mod value;
pub mod walk;

pub use canonical::{CodeKey, RawValue, ResolvedSet};
pub use check::check_schema;
pub use decimal::Decimal;
pub use diff::{Diff, DiffEntry, DiffError, DiffKind, diff, diff_defaults, unified_diff};
pub use error::{Finding, FindingKind, InputError, InputErrorKind, Location};
pub use export::{Format, export};
pub use family::{AddressRefusal, BusProtocol, Descriptor, Family, Learning};
pub use role::{BitRole, ControlState, Role, RunningIndicator};
pub use schema::{Code, CodeStyle, Keeping, Registry, Schema, Store, StoreCommand};
pub use set::{LoadedSet, load_set, load_set_str};
pub use value::ValueType;

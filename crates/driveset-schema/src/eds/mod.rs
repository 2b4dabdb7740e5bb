//! Owns CiA 306 electronic data sheets (EDS) and device configuration files
//! (DCF): reading them ([`reader`]), importing one as a Lenze ECS schema
//! ([`import()`]) and writing a set's values as a DCF ([`write_dcf`]).

mod dcf;
mod import;
pub mod reader;

pub use dcf::{DcfError, write_dcf};
pub use import::{
    ImportError, ImportLint, ImportOptions, Imported, LENZE_INDEX_BASE, default_id, import,
};

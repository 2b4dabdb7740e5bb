//! A CANopen device simulated from its data sheet (`sim://eds?file=DEVICE.eds`,
//! `driveset sim --eds FILE`): the EDS / DCF is imported as `schema
//! import` imports it (`driveset_schema::eds`, docs/file-formats.md,
//! "Imported schemas") and each node is an SDO server ([`EcsDrive`]) with
//! the imported schema's table: its objects (Lenze codes of a Lenze sheet
//! at 24575 - code, other objects by index with their own CiA types),
//! access, limits and defaults (`DefaultValue` is the factory value).
//! What the sheet forbids is refused with the DS301 abort a data sheet
//! implies: 0x06010002 a read-only object, 0x06090030 a value outside
//! `LowLimit..HighLimit` (the sheet does not say which more precise code
//! a device uses), 0x06020000 an object it does not list. A declared
//! 0x1010 with a writable sub 1 is the store step (CiA 301: "save" stores,
//! any other value aborts 0x08000020, a read gives 1, "saves on command"),
//! and writes are then kept over a power cycle only once stored; a sheet
//! without it (its schema says `unknown`) keeps nothing written: a power
//! cycle brings the sheet's defaults back, the worst case the upload
//! report names ("not stored: lost at power off").

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_proto::can::NodeId;
use driveset_schema::eds::{ImportOptions, import};
use driveset_schema::error::SourceFile;
use driveset_schema::input::{InputKind, read_input};
use driveset_schema::{Registry, Schema};

use crate::ecs::EcsDrive;
use crate::table::ParamTable;

/// The bus name of a data-sheet bus (`sim://eds?file=...`); its drives
/// are of the family the data sheet's schema is for (CAN SDO).
pub const EDS_BUS: &str = "eds";

/// A data sheet loaded for simulation: where it is and the schema its
/// import gives.
#[derive(Debug, Clone)]
pub struct EdsDevice {
    /// The EDS / DCF as named.
    pub file: PathBuf,
    /// The imported schema.
    pub schema: Arc<Schema>,
}

impl PartialEq for EdsDevice {
    fn eq(&self, other: &Self) -> bool {
        self.file == other.file && self.schema.fingerprint == other.schema.fingerprint
    }
}

impl EdsDevice {
    /// Read and import `path` (the `schema import` reader: a regular file,
    /// the data-sheet size cap). `Err`: what is wrong, with the file and
    /// line.
    pub fn load(path: &Path) -> Result<EdsDevice, String> {
        let shown = path.display().to_string();
        let bytes = read_input(path, InputKind::EDS).map_err(|e| e.to_string())?;
        let imported = import(
            &bytes,
            &ImportOptions {
                id: None,
                file: shown.clone(),
            },
        )
        .map_err(|e| {
            let at = if e.line > 0 {
                format!("{shown}:{}", e.line)
            } else {
                shown.clone()
            };
            format!("{at}: {} ({})", e.message, e.help)
        })?;
        let schema = Registry::new()
            .add_source(SourceFile::new(
                format!("{}.toml", imported.id),
                imported.toml,
            ))
            .map_err(|e| format!("{shown}: the imported schema does not load: {}", e.message))?;
        Ok(EdsDevice {
            file: path.to_path_buf(),
            schema,
        })
    }

    /// The node at `node` as the sheet describes it, random choices from
    /// `seed`.
    pub fn drive(&self, node: NodeId, seed: u64) -> Result<EcsDrive, String> {
        let table = ParamTable::from_schema(Arc::clone(&self.schema))?;
        let drive = EcsDrive::with_table(node, table, seed).with_general_range_abort();
        Ok(match self.schema.store.keeping {
            driveset_schema::Keeping::Unknown => drive.with_volatile_writes(),
            _ => drive,
        })
    }
}

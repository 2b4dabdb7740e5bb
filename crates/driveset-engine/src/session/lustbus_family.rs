//! Owns telling the two LUSTBUS families apart when no schema names one
//! (`driveset identify --protocol lustbus`): an MC6000/7000 answers an
//! ENQUIRY of its own CODE form of 91-TYPE (20091, `lustbus-protocol.txt`
//! §11.2: the MC addresses its parameters as 20000 + number), a VF1000
//! NAKs it. Read-only: nothing is written.

use std::sync::Arc;

use driveset_proto::lustbus::{Dialect, ParameterCode};
use driveset_schema::family::TYPE;
use driveset_schema::{Family, Registry, Schema};

use super::{OpenedPort, Session, SessionError};
use crate::client::DriveClient;
use crate::connect;

/// What the probe found.
pub struct LustbusFamily {
    /// The drive, reached with the schema of the family that answered.
    pub session: Session,
    /// What answered, for the report.
    pub evidence: String,
}

/// The drive at `address` of `port`, an MC6000/7000 (speaking `mc`, the
/// MC family's schema) or a VF1000 (speaking the VF1000 family's built-in
/// schema from `registry`), by the probe in the module docs.
pub fn open_lustbus_family(
    port: OpenedPort,
    mc: Arc<Schema>,
    registry: &Registry,
    address: u8,
) -> Result<LustbusFamily, SessionError> {
    let name = port.name.clone();
    let connect_opts = port.connect;
    let mut probe = Session::lustbus(port, mc.clone(), address)?;
    let code = u16::try_from(TYPE)
        .ok()
        .and_then(ParameterCode::mc_value)
        .unwrap_or(ParameterCode::POSMOD);
    let is_mc = probe.enquire_code(code, 8)?.is_some();
    let (schema, client, evidence): (Arc<Schema>, Box<dyn DriveClient>, &str) = if is_mc {
        (
            mc,
            Box::new(probe),
            "the drive answers the MC6000/7000 CODE 20091: a MASTERCONTROL servo",
        )
    } else {
        let id = Family::from_dialect(Dialect::Vf1000).descriptor().schema_id;
        let vf = registry
            .get(id)
            .ok_or(SessionError::MissingBuiltin { id })?;
        let client = connect::lustbus(probe.into_link(), vf.clone(), address, &connect_opts)?;
        (
            vf,
            Box::new(client),
            "the drive NAKs the MC6000/7000 CODE 20091: a VF1000 inverter",
        )
    };
    Ok(LustbusFamily {
        session: Session {
            port: name,
            address,
            schema,
            client,
            learned: None,
        },
        evidence: evidence.to_string(),
    })
}

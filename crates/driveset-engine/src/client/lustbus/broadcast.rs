//! LUSTBUS broadcasts (`lustbus-protocol.txt` sections 2.1, 4.2, 9.1,
//! 11.4): which codes are never sent to address 31, and the
//! [`super::LustbusClient`]'s unanswered SELECT to every device of the bus
//! inside open dataset downloads.

use std::sync::Arc;

use driveset_link::ByteLink;
use driveset_proto::lustbus::{Address, CompatibleParameter, Dialect};
use driveset_schema::{CodeKey, RawValue, Schema};

use super::LustbusClient;
use super::LustbusRefusal;
use super::encoding::{value_of, wire_type};
use crate::client::{code_name, link_error, schema_code, shown_value};
use crate::error::EngineError;
use crate::guard::{self, Permit};

/// Why the value of `code` is never broadcast to address 31 (`None`: it
/// may be, inside open dataset downloads): a numerically compatible code
/// (81..85, 91, section 5.2; a VF1000 executes CODE `000xx` as its own), a
/// code with a role, one that is not CardWriteable (section 11.4), the
/// dataset handshake itself. [`LustbusClient::broadcast`] refuses by it and
/// the line runner chooses its values by it.
pub fn not_broadcast(schema: &Schema, code: &driveset_schema::Code) -> Option<String> {
    if CompatibleParameter::contains(code.number) || code.compatible == Some(true) {
        return Some(
            "a numerically compatible code (81..85, 91; section 5.2) is never broadcast".into(),
        );
    }
    if let Some(role) = schema.role_of(code.number) {
        return Some(format!(
            "a code with role `{}` is never broadcast",
            role.as_str()
        ));
    }
    if code.card_writeable != Some(true) {
        return Some(
            "not CardWriteable: only values a dataset download stages are broadcast (section 11.4)"
                .into(),
        );
    }
    if schema.family.descriptor().dataset.map(|h| h.code) == Some(code.number) {
        return Some("the dataset handshake (80-SLOAD) is never broadcast".into());
    }
    None
}

impl<L: ByteLink> LustbusClient<L> {
    /// MC6000/7000: SELECT `key` = `raw` to address 31, the broadcast
    /// address (sections 2.1, 4.2): every device on the bus executes it and
    /// none replies (9.1), so nothing is awaited. The value is encoded as
    /// [`crate::client::DriveClient::write`] encodes it for this client's schema. Then the
    /// client waits the family's longest reaction time (section 10: 30 ms
    /// with KEYPAD), so every device has taken the telegram before the next
    /// one starts (the spec gives no figure for a broadcast; this is the
    /// longest any device takes to process a telegram).
    ///
    /// Only for values staged in open dataset downloads (section 11.4):
    /// refused before sending for a code that is not CardWriteable, for the
    /// numerically compatible codes 81..85 and 91 (CODE `000xx`, which a
    /// VF1000 on the same bus executes as its own SIOC, SIOA, ...), and for
    /// a code with a role (address, baud rate, control, command, mode ...).
    /// Address 31 reaches every device on the bus, listed anywhere or not.
    pub fn broadcast(&mut self, key: CodeKey, raw: &RawValue) -> Result<(), EngineError> {
        let schema = Arc::clone(&self.drive.schema);
        let code = schema_code(&schema, &self.drive.target, key)?;
        let refuse = |why: String| {
            EngineError::refused(
                self.drive.target.clone(),
                LustbusRefusal::Broadcast {
                    code: code_name(&schema, key),
                    why,
                },
            )
        };
        if self.family != Dialect::Mc {
            return Err(refuse(
                "broadcasts go into MC6000/7000 dataset downloads only".into(),
            ));
        }
        if let Some(why) = not_broadcast(&schema, code) {
            return Err(refuse(why));
        }
        let pcode = self.code_for(key, Some(code))?;
        let Some(ty) = wire_type(&schema, code, self.family) else {
            return Err(refuse(format!(
                "schema `{}` gives no type or width, so the value cannot be encoded",
                schema.id
            )));
        };
        let RawValue::Int(n) = raw else {
            return Err(refuse("LUSTBUS parameters hold integers".into()));
        };
        let value = value_of(ty, *n)
            .and_then(|v| v.encode(self.family).ok())
            .ok_or_else(|| {
                refuse(format!(
                    "{} does not fit {}",
                    shown_value(&schema, key, raw),
                    ty.name()
                ))
            })?;
        let cleared = guard::check(&schema, &self.drive.target, key, raw, Permit::SETTING)?;
        let bytes = guard::lustbus_select(&cleared, Address::BROADCAST, pcode, value);
        self.drive
            .line
            .send_telegram(&bytes)
            .map_err(|e| link_error(&self.drive.target, e))?;
        let wait = self.max_reaction();
        self.drive.line.link.clock().sleep(wait);
        Ok(())
    }
}

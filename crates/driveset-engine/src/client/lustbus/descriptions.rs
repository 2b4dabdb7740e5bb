//! A [`super::LustbusClient`]'s access outside the schema's codes for
//! `driveset schema pull` (`lustbus-protocol.txt` section 11): a raw
//! ENQUIRY of any CODE (descriptions, substitution texts) and the MC's
//! substitution text selector 108-STEXT.

use std::time::Duration;

use driveset_link::ByteLink;
use driveset_proto::lustbus::{Dialect, ParameterCode, ParameterValue, ValueText};
use driveset_schema::{CodeKey, RawValue};

use super::LustbusClient;
use super::LustbusRefusal;
use crate::error::{EngineError, SiofVerdict};
use crate::guard::{self, Permit};

impl<L: ByteLink> LustbusClient<L> {
    /// A raw ENQUIRY of any CODE (parameter descriptions `10dpp` / `30ppp`,
    /// substitution texts `61ppp`, section 11), for `driveset schema
    /// pull`: the VALUE text, or `None` when the drive answers NAK (no such
    /// parameter or text). `value_len` is the longest VALUE expected (for
    /// the answer timeout). Retries like a read; nothing is interpreted and
    /// nothing is written.
    pub fn enquire_code(
        &mut self,
        code: ParameterCode,
        value_len: usize,
    ) -> Result<Option<ValueText>, EngineError> {
        let what = format!("ENQUIRY {code}");
        self.enquire(code, value_len, &what)
    }

    /// MC6000/7000 only: SELECT 108-STEXT = `index` (section 11.3), which
    /// picks the substitution text a following ENQUIRY `61ppp` returns.
    /// STEXT is a RAM selector with no effect on the drive's operation; a
    /// NAK is returned as the decoded [`DeviceFailure::Refused`](crate::error::DeviceFailure::Refused) cause (SERR is
    /// read and so cleared, as after any refused SELECT).
    pub fn select_stext(&mut self, index: u8) -> Result<(), EngineError> {
        if self.family != Dialect::Mc {
            return Err(EngineError::refused(
                self.drive.target.clone(),
                LustbusRefusal::StextMcOnly,
            ));
        }
        let code = ParameterCode::mc_value(driveset_proto::lustbus::description::STEXT)
            .unwrap_or(ParameterCode::POSMOD);
        let value = ParameterValue::Usign8(index)
            .encode(Dialect::Mc)
            .map_err(|e| {
                EngineError::protocol(self.drive.target.clone(), "write 108-STEXT", e.to_string())
            })?;
        let what = format!("write 108-STEXT = {index}");
        let cleared = guard::check(
            &self.drive.schema,
            &self.drive.target,
            CodeKey::new(u32::from(driveset_proto::lustbus::description::STEXT)),
            &RawValue::Int(i64::from(index)),
            Permit::TEXT_SELECTOR,
        )?;
        self.ensure_session(&what)?;
        let bytes = guard::lustbus_select(&cleared, self.address, code, value);
        if self.select_once(&bytes, Duration::ZERO, &what)? {
            return Ok(());
        }
        let siof = self.read_siof(&what)?;
        Err(self.siof_cause(&what, siof, SiofVerdict::NoSubstitutionTexts))
    }
}

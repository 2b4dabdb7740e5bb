//! [`check`]: everything about a transfer rate that needs no telegram
//! (`lustbus-protocol.txt` §4, §11.5): the family can switch online, the
//! schema knows how the rate code codes a rate, the rate is one of the
//! family's, the bus is not shared with drives that cannot follow, and the
//! port can change its rate.

use driveset_schema::value::Repr;
use driveset_schema::{CodeKey, RawValue, Schema};

use super::{TransferRequest, refuse};
use crate::client::{DriveClient, set_line_rate};
use crate::error::{EngineError, ErrorKind, LinkFailure};
use crate::overrides::Override;
use crate::plan::code_label;

/// Check everything that needs no telegram: the family can switch online,
/// the schema knows how 81-SBAUD codes a rate, RATE is one of the family's
/// rates, the bus is not shared with drives that cannot follow (unless
/// overridden), and the port can change its rate.
pub fn check(client: &mut dyn DriveClient, req: &TransferRequest) -> Result<(), EngineError> {
    let schema = client.schema().clone();
    let target = client.target().clone();
    let d = schema.family.descriptor();
    let Some(online) = d.line_rates.online else {
        let why = if d.rate_at_restart_only() {
            format!(
                "a {} runs at {} baud at most (lustbus-protocol.txt §4) and activates a new rate only at a restart (§11.5)",
                d.title,
                d.line_rates.rates.iter().max().copied().unwrap_or_default()
            )
        } else {
            format!(
                "a {} cannot activate a new line rate online (only MC6000/7000 servocontrollers can, lustbus-protocol.txt §11.5)",
                d.title
            )
        };
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud {}: {why}; leave out --transfer-baud",
                req.rate
            ),
        ));
    };
    let Some(rate_number) = d.line_rates.code else {
        return Err(refuse(
            &target,
            format!("--transfer-baud: the {} has no rate code", d.title),
        ));
    };
    let rate_key = CodeKey::new(rate_number);
    let label = code_label(&schema, rate_key);
    if !d.line_rates.rates.contains(&req.rate) {
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud {}: a {} runs at {} baud (lustbus-protocol.txt §4); pick one of these",
                req.rate,
                d.title,
                list(d.line_rates.rates)
            ),
        ));
    }
    let Some(code) = schema.code(rate_number) else {
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud: schema `{}` has no code {rate_number}; use the drive family's schema",
                schema.id
            ),
        ));
    };
    let figure = schema
        .type_of(code)
        .is_some_and(|t| t.repr() == Repr::Scaled(1))
        && code
            .unit
            .as_deref()
            .is_some_and(|u| u.eq_ignore_ascii_case("baud"))
        && code.values.is_none();
    if !figure {
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud: schema `{}` does not say how {label} codes a rate (it needs an integer type with unit Baud: the value is the baud figure); use the schema learned from the drive (the default unless --no-learn) or leave out --transfer-baud",
                schema.id
            ),
        ));
    }
    if schema.code(online.command).is_none() {
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud: schema `{}` has no code {} (the command that activates a rate, §11.5)",
                schema.id, online.command
            ),
        ));
    }
    let old = client.line_rate().unwrap_or(0);
    for r in [req.rate, old] {
        if !within(&schema, code, r) {
            return Err(refuse(
                &target,
                format!(
                    "--transfer-baud {}: {r} baud is outside the range of {label} in schema `{}`",
                    req.rate, schema.id
                ),
            ));
        }
    }
    let cannot: Vec<&str> = req
        .others
        .iter()
        .filter(|f| {
            let r = f.descriptor().line_rates;
            r.online.is_none() || !r.rates.contains(&req.rate)
        })
        .map(|f| f.descriptor().title)
        .collect();
    if !cannot.is_empty() && !req.allow_shared {
        let mut names = cannot.clone();
        names.dedup();
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud {}: the bus is shared with {} drive(s) ({}) that cannot follow: while this drive talks at {} baud they hear garbage, and their watchdog (84-SIOT / SWDGT, lustbus-protocol.txt §5.2) may fire; give {} to switch anyway, or leave out --transfer-baud",
                req.rate,
                cannot.len(),
                names.join(", "),
                req.rate,
                Override::AllowSharedTransferBaud.flag()
            ),
        ));
    }
    // The port must be able to follow (raw tcp:// cannot): ask it for
    // the rate it runs at, which changes nothing.
    if old != 0
        && let Err(e) = set_line_rate(client, old)
    {
        let why = match e.kind() {
            ErrorKind::Link(LinkFailure::Transport(source)) => source.to_string(),
            _ => e.to_string(),
        };
        return Err(refuse(
            &target,
            format!("--transfer-baud {}: {why}", req.rate),
        ));
    }
    let _ = (rate_key, online);
    Ok(())
}

fn list(rates: &[u32]) -> String {
    let mut r = rates.to_vec();
    r.sort_unstable();
    r.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
}

/// Whether `baud` is within the schema's min/max of the rate code.
fn within(schema: &Schema, code: &driveset_schema::Code, baud: u32) -> bool {
    let v = i64::from(baud);
    let lo = code.min.as_ref().map(|f| schema.fact_raw(code, f));
    let hi = code.max.as_ref().map(|f| schema.fact_raw(code, f));
    let ok_lo = !matches!(lo, Some(Ok(RawValue::Int(m))) if v < m);
    let ok_hi = !matches!(hi, Some(Ok(RawValue::Int(m))) if v > m);
    ok_lo && ok_hi
}

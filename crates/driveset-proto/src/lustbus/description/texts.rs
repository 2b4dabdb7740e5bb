//! Value substitution texts (`lustbus-protocol.txt` §11.3): 108-STEXT, 107-UNIT
//! and the `61xxx` request and reply.

use super::*;

/// 108-STEXT: selects which value substitution text `61xxx` returns
/// (section 11.3).
pub const STEXT: u16 = 108;
/// 107-UNIT: its substitution texts are the unit strings a description's
/// unit index points to (section 11.2.1).
pub const UNIT: u16 = 107;

/// The two telegrams that fetch the substitution text number `index` of
/// MC parameter `parameter` (section 11.3 steps 2 and 3): SELECT 108-STEXT =
/// `index`, then ENQUIRY `61ppp`. `None` if `parameter > 999`.
pub fn substitution_text_request(
    address: Address,
    parameter: u16,
    index: u8,
) -> Option<(Select, Enquiry)> {
    let code = ParameterCode::substitution_text(parameter)?;
    let stext = ParameterCode::mc_value(STEXT)?;
    let value = ParameterValue::Usign8(index).encode(Dialect::Mc).ok()?;
    Some((
        Select::new(address, stext, value),
        Enquiry::new(address, code),
    ))
}

/// The text of a `61xxx` reply: printable ASCII, trailing NULs and blanks
/// removed (a C device may send its terminator or padding).
pub fn decode_substitution_text(value: &[u8]) -> Result<&str, DescriptionError> {
    let end = value
        .iter()
        .rposition(|&b| b != 0 && b != b' ')
        .map_or(0, |i| i + 1);
    let text = &value[..end];
    if let Some(i) = text.iter().position(|b| !(0x20..=0x7E).contains(b)) {
        return Err(DescriptionError::Text {
            field: "substitution text",
            offset: i,
            found: text[i],
        });
    }
    Ok(core::str::from_utf8(text).unwrap_or(""))
}

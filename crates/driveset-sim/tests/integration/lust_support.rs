//! LUSTBUS telegrams as the simulator's tests send and expect them, built
//! with the codec of `driveset-proto` (LUSTBUS section 6): an ENQUIRY, a
//! SELECT and a value reply. Shared by `lust_bus`, `lust_models`,
//! `factory` and `spec_examples_transports`.

use driveset_proto::lustbus::{Address, Enquiry, ParameterCode, Select, ValueReply, ValueText};

fn adr(a: u8) -> Address {
    Address::new(a).unwrap()
}

fn code(c: u32) -> ParameterCode {
    ParameterCode::new(c).unwrap()
}

/// The ENQUIRY of code `c` at address `a`.
pub fn enq(a: u8, c: u32) -> Vec<u8> {
    Enquiry::new(adr(a), code(c)).encode().to_vec()
}

/// The SELECT writing `v` to code `c` at address `a`.
pub fn sel(a: u8, c: u32, v: &str) -> Vec<u8> {
    Select::new(adr(a), code(c), ValueText::new(v.as_bytes()).unwrap())
        .encode()
        .to_vec()
}

/// The value reply `v` of code `c` from address `a`.
pub fn val(a: u8, c: u32, v: &str) -> Vec<u8> {
    ValueReply {
        address: adr(a),
        code: code(c),
        value: ValueText::new(v.as_bytes()).unwrap(),
    }
    .encode()
    .to_vec()
}

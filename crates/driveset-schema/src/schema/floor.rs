//! The role floor: the roles the family's specs give its codes
//! ([`crate::family::FloorRole`]), applied to every schema when it is
//! loaded, so a schema file can add roles but never drop them.

use crate::role::{BitRole, Role};

use super::{BitField, Schema};

impl Schema {
    /// Give the codes the roles the family's specs give them
    /// ([`crate::family::FloorRole`], the descriptor's `floor`): the one
    /// place every schema passes when it is loaded (built-in, by path,
    /// `extends`, learned, imported from an EDS, `--schemas DIR`), so a
    /// schema file can add roles but never drop them. A code the schema
    /// does not list stays unlisted (a client never writes it).
    pub(super) fn apply_floor(&mut self) {
        let floor = self.family.descriptor().floor;
        for code in &mut self.codes {
            let Some(f) = floor.iter().find(|f| f.code == code.number) else {
                continue;
            };
            code.role = Some(f.role);
            if f.role != Role::ControlWord {
                continue;
            }
            // Only the floor's inhibit bits make a value safe.
            for b in &mut code.bits {
                if b.role == Some(crate::role::BitRole::Inhibit)
                    && !f
                        .bits
                        .iter()
                        .any(|fb| fb.bit == b.lsb && fb.role == crate::role::BitRole::Inhibit)
                {
                    b.role = None;
                    b.role_loc = None;
                }
            }
            for fb in f.bits {
                match code
                    .bits
                    .iter_mut()
                    .find(|b| b.lsb == fb.bit && b.msb == fb.bit)
                {
                    Some(b) => b.role = Some(fb.role),
                    None => {
                        // A wider member over the bit: a start, enable,
                        // release or reset bit makes the member count as
                        // one when any of its bits is set (more values are
                        // refused, none is let through); an inhibit bit
                        // stays unnamed (no value is made safe by it).
                        if let Some(b) = code
                            .bits
                            .iter_mut()
                            .find(|b| b.lsb <= fb.bit && fb.bit <= b.msb)
                        {
                            if fb.role != BitRole::Inhibit {
                                b.role = Some(fb.role);
                            }
                            continue;
                        }
                        code.bits.push(BitField {
                            name: fb.name.to_string(),
                            title: None,
                            lsb: fb.bit,
                            msb: fb.bit,
                            values: None,
                            loc: code.loc.clone(),
                            bits_loc: code.loc.clone(),
                            role: Some(fb.role),
                            role_loc: None,
                        });
                    }
                }
            }
            if f.stopped.is_empty() {
                code.stopped.clear();
            } else {
                code.stopped.retain(|v| f.stopped.contains(v));
                if code.stopped.is_empty() {
                    code.stopped = f.stopped.to_vec();
                }
            }
        }
    }
}

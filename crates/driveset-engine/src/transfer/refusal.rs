//! The refusal `--transfer-baud` raises ([`TransferRefusal`]), beside the
//! switch: the transfer rate cannot be used here (LUSTBUS §11.5, the
//! family's `line_rates`), said with what to do. Gathered into
//! [`Refusal`](crate::error::Refusal) as `Refusal::Transfer`, with the JSON
//! kind journals hold (`transfer_rate`).

use serde::{Deserialize, Serialize};

/// Why `--transfer-baud` cannot be used here.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "kind")]
pub enum TransferRefusal {
    /// Another family, a rate the drive does not run at, a port or client
    /// that cannot change its rate, a running drive, a shared bus without
    /// its override: what and what to do, as [`crate::transfer`] words it.
    #[error("{detail}")]
    #[serde(rename = "transfer_rate")]
    Rate {
        /// The reason and the remedy.
        detail: String,
    },
}

#[cfg(test)]
mod tests {
    use super::TransferRefusal;
    use crate::error::assert_refusal_json;

    /// The refusal is a `Refusal` whose JSON is the flat kind journals
    /// have always held, and reads back to the same refusal.
    #[test]
    fn the_transfer_refusal_keeps_its_json_kind_and_reads_back() {
        let refusal = TransferRefusal::Rate {
            detail: "the drive does not run at 57600 baud".to_string(),
        };
        let json = r#"{"kind":"transfer_rate","detail":"the drive does not run at 57600 baud"}"#;
        assert_eq!(refusal.to_string(), "the drive does not run at 57600 baud");
        assert_refusal_json(&refusal, json);
    }
}

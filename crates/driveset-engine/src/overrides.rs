//! Owns the named overrides of the upload refusals: each lifts exactly one
//! refusal, and each refusal message names its override (`--allow-...`).
//! Commands and control words in a start / enable state have no override:
//! a set never holds them (`driveset_schema::role`).

use std::fmt;

/// One refusal that an explicit override can lift.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Override {
    /// A set for another schema, a drive that identifies as another family
    /// or 91-TYPE, a simulated drive of another family.
    AllowFamily,
    /// A drive that reports a running motor.
    AllowRunning,
    /// A drive whose running state cannot be known (its schema names no
    /// running bit: Lenze ECS per its excerpt).
    AllowRunningUnknown,
    /// A change of the bus address of the drive being talked to.
    AllowAddressChange,
    /// A transfer rate (`--transfer-baud`) on a bus shared with drives
    /// that cannot follow it (VF1000: 9600 Bd at most): they hear garbage
    /// while it lasts and their watchdog may fire ([`crate::transfer`]).
    AllowSharedTransferBaud,
}

impl Override {
    /// Every override.
    pub const ALL: [Override; 5] = [
        Override::AllowFamily,
        Override::AllowRunning,
        Override::AllowRunningUnknown,
        Override::AllowAddressChange,
        Override::AllowSharedTransferBaud,
    ];

    /// The command-line flag.
    pub fn flag(self) -> &'static str {
        match self {
            Override::AllowFamily => "--allow-family",
            Override::AllowRunning => "--allow-running",
            Override::AllowRunningUnknown => "--allow-running-unknown",
            Override::AllowAddressChange => "--allow-address-change",
            Override::AllowSharedTransferBaud => "--allow-shared-transfer-baud",
        }
    }
}

impl fmt::Display for Override {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.flag())
    }
}

/// The overrides given for one upload (none by default): a set of
/// [`Override`], one bit each.
#[derive(Clone, Copy, PartialEq, Eq, Default)]
pub struct Overrides(u8);

impl Overrides {
    /// No override.
    pub fn none() -> Self {
        Overrides::default()
    }

    /// Only `o`.
    pub fn only(o: Override) -> Self {
        Overrides::none().with(o)
    }

    /// These overrides and `o`.
    #[must_use]
    pub fn with(self, o: Override) -> Self {
        Overrides(self.0 | Self::bit(o))
    }

    /// Whether `o` is given.
    pub fn allows(&self, o: Override) -> bool {
        self.0 & Self::bit(o) != 0
    }

    /// The overrides given, in [`Override::ALL`] order.
    pub fn iter(&self) -> impl Iterator<Item = Override> + '_ {
        Override::ALL.into_iter().filter(|o| self.allows(*o))
    }

    fn bit(o: Override) -> u8 {
        1 << (o as u8)
    }
}

impl FromIterator<Override> for Overrides {
    fn from_iter<I: IntoIterator<Item = Override>>(iter: I) -> Self {
        iter.into_iter().fold(Overrides::none(), Overrides::with)
    }
}

impl fmt::Debug for Overrides {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_set().entries(self.iter()).finish()
    }
}

//! `driveset schema pull` (being written).

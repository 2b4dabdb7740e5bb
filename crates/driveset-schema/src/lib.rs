//! driveset-schema (under construction).

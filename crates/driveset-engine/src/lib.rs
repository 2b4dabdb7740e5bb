//! driveset-engine (under construction).

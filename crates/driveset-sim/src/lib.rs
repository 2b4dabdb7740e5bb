//! driveset-sim (under construction).

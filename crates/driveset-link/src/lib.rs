//! driveset-link (under construction).

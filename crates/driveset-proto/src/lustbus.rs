//! lustbus codec (under construction).

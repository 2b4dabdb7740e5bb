//! lecom codec (under construction).

//! can codec (under construction).

//! Radiance font files (`.fnt`) and text patterns.

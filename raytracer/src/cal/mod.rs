//! Radiance's function language (`.cal` files and inline expressions).

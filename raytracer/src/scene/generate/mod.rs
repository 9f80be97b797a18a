//! Built-in procedural scenes, written as Radiance scene text.

//! Radiance data files (`.dat`) and pictures as N-dimensional data.

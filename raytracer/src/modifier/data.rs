//! Radiance data files (`.dat`) and pictures as N-dimensional data.
//! (Placeholder until the reader lands.)
#![allow(dead_code, unused_variables)]
use crate::{Error, Result, SourceLoc};
use std::path::Path;
#[derive(Debug)]
pub struct DataArray {}
impl DataArray {
    pub fn load(path: &Path, from: &SourceLoc) -> Result<DataArray> {
        Err(Error::parse(from.clone(), "no data"))
    }
    pub fn dims(&self) -> usize {
        1
    }
    pub fn value(&self, x: &[f64]) -> f64 {
        0.0
    }
}
#[derive(Debug)]
pub struct PictureData {}
impl PictureData {
    pub fn load(path: &Path, from: &SourceLoc) -> Result<PictureData> {
        Err(Error::parse(from.clone(), "no data"))
    }
    pub fn value(&self, u: f64, v: f64) -> [f64; 3] {
        [0.0; 3]
    }
}

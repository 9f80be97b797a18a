//! Radiance font files (`.fnt`) and text patterns.
//! (Placeholder until the reader lands.)
#![allow(dead_code, unused_variables)]
use crate::{Error, Result, SourceLoc};
use std::path::Path;
use std::sync::Arc;
#[derive(Debug)]
pub struct Font {}
impl Font {
    pub fn load(path: &Path, from: &SourceLoc) -> Result<Font> {
        Err(Error::parse(from.clone(), "no font"))
    }
}
#[derive(Debug)]
pub struct TextLayout {}
impl TextLayout {
    pub fn new(font: Arc<Font>, lines: Vec<String>, reals: &[f64], loc: &SourceLoc) -> Result<TextLayout> {
        Err(Error::parse(loc.clone(), "no font"))
    }
    pub fn inside(&self, p: glam::DVec3) -> bool {
        false
    }
}

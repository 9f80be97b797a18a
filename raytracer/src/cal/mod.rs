//! Radiance's function language (`.cal` files and inline expressions).
//! (Placeholder API until the evaluator lands.)
#![allow(dead_code, unused_variables)]

use std::path::{Path, PathBuf};

use crate::{Error, Result, SourceLoc};

pub const N_INPUTS: usize = 37;
pub mod chan {
    pub const DX: usize = 0;
    pub const DY: usize = 1;
    pub const DZ: usize = 2;
    pub const NX: usize = 3;
    pub const NY: usize = 4;
    pub const NZ: usize = 5;
    pub const PX: usize = 6;
    pub const PY: usize = 7;
    pub const PZ: usize = 8;
    pub const T: usize = 9;
    pub const RDOT: usize = 10;
    pub const S: usize = 11;
    pub const TX: usize = 12;
    pub const TY: usize = 13;
    pub const TZ: usize = 14;
    pub const IX: usize = 15;
    pub const IY: usize = 16;
    pub const IZ: usize = 17;
    pub const JX: usize = 18;
    pub const JY: usize = 19;
    pub const JZ: usize = 20;
    pub const KX: usize = 21;
    pub const KY: usize = 22;
    pub const KZ: usize = 23;
    pub const TS: usize = 24;
    pub const LU: usize = 25;
    pub const LV: usize = 26;
    pub const NXP: usize = 27;
    pub const NYP: usize = 28;
    pub const NZP: usize = 29;
    pub const RDOTP: usize = 30;
    pub const CRP: usize = 31;
    pub const CGP: usize = 32;
    pub const CBP: usize = 33;
    pub const DXA: usize = 34;
    pub const DYA: usize = 35;
    pub const DZA: usize = 36;
}
pub struct Inputs<'a> {
    pub values: [f64; N_INPUTS],
    pub args: &'a [f64],
}
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Context(u32);
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ExprId(u32);
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FuncId(u32);
pub struct Library {}
impl Library {
    pub fn new(search_path: Vec<PathBuf>) -> Result<Library> {
        Ok(Library {})
    }
    pub fn global(&self) -> Context {
        Context(0)
    }
    pub fn load_file(&mut self, name: &str, base_dir: &Path, from: &SourceLoc) -> Result<Context> {
        Err(Error::parse(from.clone(), "no cal"))
    }
    pub fn expr(&mut self, ctx: Context, text: &str, loc: &SourceLoc) -> Result<ExprId> {
        Err(Error::parse(loc.clone(), "no cal"))
    }
    pub fn function(&mut self, ctx: Context, name: &str, arity: usize, loc: &SourceLoc) -> Result<FuncId> {
        Err(Error::parse(loc.clone(), "no cal"))
    }
    pub fn is_defined(&self, ctx: Context, name: &str) -> bool {
        false
    }
    pub fn arity(&self, ctx: Context, name: &str) -> Option<usize> {
        None
    }
    pub fn finish(self) -> Result<Program> {
        Ok(Program {})
    }
}
#[derive(Debug)]
pub struct Program {}
impl Program {
    pub fn eval(&self, e: ExprId, inputs: &Inputs) -> Result<f64, EvalError> {
        Ok(0.0)
    }
    pub fn call(&self, f: FuncId, args: &[f64], inputs: &Inputs) -> Result<f64, EvalError> {
        Ok(0.0)
    }
    pub fn empty() -> Program {
        Program {}
    }
}
#[derive(Debug, Clone)]
pub struct EvalError {}
impl std::fmt::Display for EvalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "eval error")
    }
}
impl std::error::Error for EvalError {}

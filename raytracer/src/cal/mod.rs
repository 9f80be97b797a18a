//! Radiance's function language (`.cal` files and inline expressions).
//!
//! A [`Library`] collects definitions while a scene loads: the built-in
//! functions, the prelude (Radiance's `rayinit.cal`), one context per `.cal`
//! file, and the expressions and functions that modifiers name. [`Library::finish`]
//! resolves every name they reach and compiles them into an immutable
//! [`Program`] that evaluates without parsing, name look-ups or heap
//! allocation.
//!
//! Semantics follow calcomp (`calexpr.c`, `caldefn.c`, `calfunc.c`) and the
//! renderer's `func.c`:
//!
//! - `name = expr` defines a variable, `name : expr` a constant, and
//!   `f(a,b) = expr` a function; a later definition replaces an earlier one.
//! - Arguments of user functions are evaluated lazily, at most once per call;
//!   a parameter may be called as a function (`dot(v1,v2) : v1(1)*v2(1)+...`
//!   called as `dot(D,N)`). `if` and `select` evaluate only what they choose.
//! - Like calcomp, a library function whose result is NaN or infinite, or that
//!   raised a math error (a domain error such as `sqrt(-1)`, `log(0)`, an
//!   underflowing `exp`), returns 0; so does a division by zero and an
//!   illegal power. The error also zeroes every library call it happens
//!   inside, as calcomp's sticky `errno` does. [`Program::warnings`] counts
//!   them (Radiance prints a warning for each).
//! - A name is looked up in the context it was written in (a `.cal` file's
//!   own), then in the global one; names containing a back-quote are global.
//!
//! Ray state reaches expressions through the input slots of [`chan`].

mod builtins;
mod eval;
mod library;
mod noise;
mod parser;
mod prelude;
#[cfg(test)]
mod tests;

pub use eval::{EvalError, Program};
pub use library::{Context, ExprId, FuncId, Library};

/// Ray channels `$1..$27` of Radiance's `chanvalue`.
pub const N_CHANNELS: usize = 27;

/// Input slots: the 27 channels, then the values Radiance sets with
/// `varset` for some materials.
pub const N_INPUTS: usize = N_CHANNELS + 10;

/// Input slot indices (0-based: channel `$1` is slot 0).
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
    /// Distance from the eye (`T`, `$10`).
    pub const T: usize = 9;
    /// Ray direction dot normal (`Rdot`, `$11`).
    pub const RDOT: usize = 10;
    /// World scale (`S`).
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
    /// Single-ray (shadow) distance (`Ts`, `$25`).
    pub const TS: usize = 24;
    pub const LU: usize = 25;
    pub const LV: usize = 26;
    /// Perturbed normal and ray dot product (`*func`, `*data` materials).
    pub const NXP: usize = 27;
    pub const NYP: usize = 28;
    pub const NZP: usize = 29;
    pub const RDOTP: usize = 30;
    /// Perturbed material colour.
    pub const CRP: usize = 31;
    pub const CGP: usize = 32;
    pub const CBP: usize = 33;
    /// Direction to the target light source (`prism1`, `prism2`).
    pub const DXA: usize = 34;
    pub const DYA: usize = 35;
    pub const DZA: usize = 36;
}

/// Names of the inputs after the channels, in slot order.
pub(crate) const NAMED_INPUTS: [&str; N_INPUTS - N_CHANNELS] = [
    "NxP", "NyP", "NzP", "RdotP", "CrP", "CgP", "CbP", "DxA", "DyA", "DzA",
];

/// What an evaluation reads: the input slots and the modifier's real
/// arguments (`arg(n)`).
#[derive(Debug, Clone, Copy)]
pub struct Inputs<'a> {
    pub values: [f64; N_INPUTS],
    pub args: &'a [f64],
}

impl<'a> Inputs<'a> {
    /// All slots zero.
    pub fn new(args: &'a [f64]) -> Self {
        Inputs {
            values: [0.0; N_INPUTS],
            args,
        }
    }
}

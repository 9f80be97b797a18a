//! The library functions: calcomp's (`calfunc.c`) and the renderer's
//! (`func.c`, `noise3.c`).

/// A built-in function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Builtin {
    If,
    Select,
    Min,
    Max,
    Sqrt,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Atan2,
    Exp,
    Log,
    Log10,
    Floor,
    Ceil,
    Rand,
    Erf,
    Erfc,
    Noise3,
    Noise3x,
    Noise3y,
    Noise3z,
    Fnoise3,
    Hermite,
    Arg,
}

impl Builtin {
    pub fn lookup(name: &str) -> Option<Builtin> {
        use Builtin::*;
        Some(match name {
            "if" => If,
            "select" => Select,
            "min" => Min,
            "max" => Max,
            "sqrt" => Sqrt,
            "sin" => Sin,
            "cos" => Cos,
            "tan" => Tan,
            "asin" => Asin,
            "acos" => Acos,
            "atan" => Atan,
            "atan2" => Atan2,
            "exp" => Exp,
            "log" => Log,
            "log10" => Log10,
            "floor" => Floor,
            "ceil" => Ceil,
            "rand" => Rand,
            "erf" => Erf,
            "erfc" => Erfc,
            "noise3" => Noise3,
            "noise3x" => Noise3x,
            "noise3y" => Noise3y,
            "noise3z" => Noise3z,
            "fnoise3" => Fnoise3,
            "hermite" => Hermite,
            "arg" => Arg,
            _ => return None,
        })
    }

    /// Depends on nothing but its arguments (`arg` reads the modifier).
    pub fn is_pure(self) -> bool {
        self != Builtin::Arg
    }

    /// A one-argument function of C's math library.
    pub fn unary(self) -> Option<fn(f64) -> f64> {
        use Builtin::*;
        Some(match self {
            Sqrt => f64::sqrt,
            Sin => f64::sin,
            Cos => f64::cos,
            Tan => f64::tan,
            Asin => f64::asin,
            Acos => f64::acos,
            Atan => f64::atan,
            Exp => f64::exp,
            Log => f64::ln,
            Log10 => f64::log10,
            Floor => f64::floor,
            Ceil => f64::ceil,
            Rand => super::noise::rand,
            Erf => erf,
            Erfc => erfc,
            _ => return None,
        })
    }
}

mod libm {
    extern "C" {
        pub fn erf(x: f64) -> f64;
        pub fn erfc(x: f64) -> f64;
    }
}

/// C's `erf` (the platform's math library, which Rust's std links).
pub fn erf(x: f64) -> f64 {
    // SAFETY: a pure function of C's math library taking and returning a double.
    unsafe { libm::erf(x) }
}

/// C's `erfc`.
pub fn erfc(x: f64) -> f64 {
    // SAFETY: as for `erf`.
    unsafe { libm::erfc(x) }
}

/// Whether C's math library would report a range error (`ERANGE`) for an
/// underflow that still gives a finite result: glibc flags `exp`, `erfc`
/// and `pow` results below the smallest normal number. calcomp turns such a
/// flagged library result into 0 (with a warning), as it does NaN and
/// infinities.
pub fn underflows(b: Builtin, x: f64, r: f64) -> bool {
    match b {
        Builtin::Exp | Builtin::Erfc => r.abs() < f64::MIN_POSITIVE && x.is_finite(),
        _ => false,
    }
}

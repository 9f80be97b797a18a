//! Compilation of the reachable definitions into a flat node array with
//! resolved indices, constant folding, and the evaluator.

use std::cell::Cell;
use std::collections::HashMap;
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};

use super::builtins::{self, Builtin};
use super::library::{loc_of, Context, ExprId, FuncId, Library};
use super::parser::{BinOp, Callee, Expr, Pos};
use super::Inputs;
use crate::{Error, SourceLoc};

/// Deepest nesting of user function calls and variable evaluations.
pub(crate) const MAX_DEPTH: u32 = 512;
/// Stack an evaluation may use before it counts as too deep a recursion
/// (guards threads with small stacks and deep expression trees).
const STACK_BUDGET: usize = 512 * 1024;
/// User calls one evaluation may make (bounds exponential recursion).
const MAX_CALLS: u64 = 1 << 24;
/// User calls constant folding may spend on one node.
const FOLD_CALLS: u64 = 1 << 14;
/// Arguments remembered per call (calcomp remembers 6).
const ARG_CACHE: usize = 8;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Callable {
    User(u32),
    Builtin(Builtin),
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Node {
    Num(f64),
    Input(u32),
    Param(u32),
    Var(u32),
    /// A function passed as an argument; not a value.
    FuncRef(Callable),
    Neg(u32),
    Bin(BinOp, u32, u32),
    Call {
        def: u32,
        args: u32,
        n: u32,
    },
    CallParam {
        param: u32,
        args: u32,
        n: u32,
    },
    Builtin {
        b: Builtin,
        args: u32,
        n: u32,
    },
}

#[derive(Debug)]
pub(crate) struct CDef {
    name: String,
    loc: SourceLoc,
    body: u32,
    /// Node range of the body (children come before parents).
    range: (u32, u32),
}

#[derive(Debug, Clone, Copy)]
enum Target {
    Call(Callable),
    Var(u32),
}

/// Compiled, immutable, `Send + Sync`.
#[derive(Debug)]
pub struct Program {
    nodes: Vec<Node>,
    lists: Vec<u32>,
    defs: Vec<CDef>,
    exprs: Vec<u32>,
    funcs: Vec<Target>,
    warnings: AtomicU64,
}

/// A run-time error: recursion too deep, too few arguments to a function, a
/// function used as a value (or a value called), or a missing real argument.
#[derive(Debug, Clone)]
pub struct EvalError {
    // Boxed: keeps `Result<f64, EvalError>` two words, returned in registers.
    #[allow(clippy::box_collection)] // one word, where String is three
    message: Box<String>,
}

impl fmt::Display for EvalError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for EvalError {}

impl EvalError {
    fn new(message: impl Into<String>) -> Self {
        EvalError {
            message: Box::new(message.into()),
        }
    }

    fn in_def(d: &CDef, what: &str) -> Self {
        EvalError::new(format!("{}: `{}` (defined here): {what}", d.loc, d.name))
    }
}

// ---------------------------------------------------------------- compile

struct Compiler<'l> {
    lib: &'l Library,
    nodes: Vec<Node>,
    lists: Vec<u32>,
    defs: Vec<CDef>,
    def_map: HashMap<usize, u32>,
    queue: Vec<(usize, u32)>,
}

struct Place<'a> {
    ctx: Context,
    file: &'a std::path::Path,
    line_base: usize,
}

impl Place<'_> {
    fn err(&self, pos: Pos, reason: String) -> Error {
        Error::parse(loc_of(self.file, self.line_base, pos), reason)
    }
}

impl Compiler<'_> {
    fn cdef(&mut self, d: usize) -> u32 {
        if let Some(&c) = self.def_map.get(&d) {
            return c;
        }
        let def = &self.lib.defs[d];
        let c = self.defs.len() as u32;
        self.defs.push(CDef {
            name: def.name.clone(),
            loc: def.loc(),
            body: u32::MAX,
            range: (0, 0),
        });
        self.def_map.insert(d, c);
        self.queue.push((d, c));
        c
    }

    fn push(&mut self, n: Node) -> u32 {
        self.nodes.push(n);
        (self.nodes.len() - 1) as u32
    }

    fn name(&mut self, name: &str, pos: Pos, at: &Place, as_arg: bool) -> crate::Result<u32> {
        if let Some(d) = self.lib.lookup(at.ctx, name) {
            let is_fn = self.lib.defs[d].nparams > 0;
            let c = self.cdef(d);
            return if !is_fn {
                Ok(self.push(Node::Var(c)))
            } else if as_arg {
                Ok(self.push(Node::FuncRef(Callable::User(c))))
            } else {
                Err(at.err(
                    pos,
                    format!("`{name}` is a function, used without arguments"),
                ))
            };
        }
        match Builtin::lookup(name) {
            Some(b) if as_arg => Ok(self.push(Node::FuncRef(Callable::Builtin(b)))),
            Some(_) => Err(at.err(
                pos,
                format!("`{name}` is a built-in function, used without arguments"),
            )),
            None => Err(at.err(pos, format!("undefined variable `{name}`"))),
        }
    }

    fn args(&mut self, args: &[Expr], at: &Place, as_arg: bool) -> crate::Result<(u32, u32)> {
        let ids = args
            .iter()
            .map(|a| self.expr(a, at, as_arg))
            .collect::<crate::Result<Vec<u32>>>()?;
        let start = self.lists.len() as u32;
        self.lists.extend(ids);
        Ok((start, args.len() as u32))
    }

    fn expr(&mut self, e: &Expr, at: &Place, as_arg: bool) -> crate::Result<u32> {
        Ok(match e {
            Expr::Num(v) => self.push(Node::Num(*v)),
            Expr::Input(i) => self.push(Node::Input(*i)),
            Expr::Param(i) => self.push(Node::Param(*i)),
            Expr::Name(name, pos) => return self.name(name, *pos, at, as_arg),
            Expr::Neg(a) => {
                let a = self.expr(a, at, false)?;
                self.push(Node::Neg(a))
            }
            Expr::Bin(op, a, b) => {
                let a = self.expr(a, at, false)?;
                let b = self.expr(b, at, false)?;
                self.push(Node::Bin(*op, a, b))
            }
            Expr::Call { callee, args, pos } => match callee {
                Callee::Param(p) => {
                    let (args, n) = self.args(args, at, true)?;
                    self.push(Node::CallParam { param: *p, args, n })
                }
                Callee::Name(name) => {
                    if let Some(d) = self.lib.lookup(at.ctx, name) {
                        if self.lib.defs[d].nparams == 0 {
                            return Err(at.err(
                                *pos,
                                format!("`{name}` is a variable, called as a function"),
                            ));
                        }
                        let def = self.cdef(d);
                        let (args, n) = self.args(args, at, true)?;
                        self.push(Node::Call { def, args, n })
                    } else if let Some(b) = Builtin::lookup(name) {
                        let (args, n) = self.args(args, at, false)?;
                        self.push(Node::Builtin { b, args, n })
                    } else {
                        return Err(at.err(*pos, format!("undefined function `{name}`")));
                    }
                }
            },
        })
    }

    fn drain(&mut self) -> crate::Result<()> {
        while let Some((d, c)) = self.queue.pop() {
            let def = &self.lib.defs[d];
            let at = Place {
                ctx: def.ctx,
                file: &def.file,
                line_base: def.line_base,
            };
            let start = self.nodes.len() as u32;
            let body = self.expr(&def.body, &at, false)?;
            let cd = &mut self.defs[c as usize];
            cd.body = body;
            cd.range = (start, self.nodes.len() as u32);
        }
        Ok(())
    }
}
impl Library {
    /// Resolves every name reachable from the expressions and functions
    /// handed out, and compiles them. An undefined name reachable from them
    /// is an error naming where it is used.
    pub fn finish(self) -> crate::Result<Program> {
        compile(self)
    }
}

pub(crate) fn compile(lib: Library) -> crate::Result<Program> {
    let mut c = Compiler {
        lib: &lib,
        nodes: Vec::new(),
        lists: Vec::new(),
        defs: Vec::new(),
        def_map: HashMap::new(),
        queue: Vec::new(),
    };
    let mut exprs = Vec::with_capacity(lib.exprs.len());
    for r in &lib.exprs {
        let at = Place {
            ctx: r.ctx,
            file: &r.file,
            line_base: r.line_base,
        };
        exprs.push(c.expr(&r.body, &at, false)?);
        c.drain()?;
    }
    let mut funcs = Vec::with_capacity(lib.funcs.len());
    for f in &lib.funcs {
        let t = if let Some(d) = lib.lookup(f.ctx, &f.name) {
            let is_fn = lib.defs[d].nparams > 0;
            let cd = c.cdef(d);
            if is_fn {
                Target::Call(Callable::User(cd))
            } else {
                Target::Var(cd)
            }
        } else if let Some(b) = Builtin::lookup(&f.name) {
            Target::Call(Callable::Builtin(b))
        } else {
            return Err(Error::parse(
                f.loc.clone(),
                format!("undefined function `{}`", f.name),
            ));
        };
        funcs.push(t);
        c.drain()?;
    }
    let Compiler {
        mut nodes,
        lists,
        defs,
        ..
    } = c;
    optimise(&mut nodes, &lists, &defs);
    Ok(Program {
        nodes,
        lists,
        defs,
        exprs,
        funcs,
        warnings: AtomicU64::new(0),
    })
}

/// Inlines variables bound to an input, and folds every subexpression that
/// depends on no input, parameter or real argument into a number.
fn optimise(nodes: &mut [Node], lists: &[u32], defs: &[CDef]) {
    for i in 0..nodes.len() {
        if let Node::Var(d) = nodes[i] {
            if let Node::Input(k) = nodes[defs[d as usize].body as usize] {
                nodes[i] = Node::Input(k);
            }
        }
    }
    let list = |a: u32, n: u32| &lists[a as usize..(a + n) as usize];
    // Definitions whose value depends only on their parameters.
    let mut pure = vec![true; defs.len()];
    loop {
        let mut changed = false;
        for (d, cd) in defs.iter().enumerate() {
            if !pure[d] {
                continue;
            }
            let impure = nodes[cd.range.0 as usize..cd.range.1 as usize]
                .iter()
                .any(|n| match *n {
                    Node::Input(_) | Node::CallParam { .. } => true,
                    Node::Builtin { b, .. } => !b.is_pure(),
                    Node::Var(x) | Node::Call { def: x, .. } => !pure[x as usize],
                    _ => false,
                });
            if impure {
                pure[d] = false;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let mut closed = vec![false; nodes.len()];
    let dummy = Inputs::new(&[]);
    for i in 0..nodes.len() {
        let all = |a, n| list(a, n).iter().all(|&k| closed[k as usize]);
        closed[i] = match nodes[i] {
            Node::Num(_) => true,
            Node::Input(_) | Node::Param(_) | Node::FuncRef(_) | Node::CallParam { .. } => false,
            Node::Var(d) => pure[d as usize],
            Node::Neg(a) => closed[a as usize],
            Node::Bin(_, a, b) => closed[a as usize] && closed[b as usize],
            Node::Call { def, args, n } => pure[def as usize] && all(args, n),
            Node::Builtin { b, args, n } => b.is_pure() && all(args, n),
        };
        if closed[i] && !matches!(nodes[i], Node::Num(_)) {
            let code = Code { nodes, lists, defs };
            // A math error is left to happen at run time, where it zeroes
            // the library calls around it as calcomp's errno does.
            if let (Ok(v), 0) = code.run(&dummy, FOLD_CALLS, |ev, top| ev.eval(i as u32, top)) {
                nodes[i] = Node::Num(v);
            }
        }
    }
}

// ---------------------------------------------------------------- evaluate

#[derive(Clone, Copy)]
struct Code<'p> {
    nodes: &'p [Node],
    lists: &'p [u32],
    defs: &'p [CDef],
}

#[derive(Clone, Copy)]
enum Src<'a> {
    None,
    Nodes(&'a [u32], &'a Frame<'a>),
    Values(&'a [f64]),
}

impl Src<'_> {
    fn len(&self) -> usize {
        match self {
            Src::None => 0,
            Src::Nodes(l, _) => l.len(),
            Src::Values(v) => v.len(),
        }
    }
}

/// An activation: where a call's arguments come from, and those computed.
struct Frame<'a> {
    src: Src<'a>,
    cache: [Cell<f64>; ARG_CACHE],
    known: Cell<u32>,
    depth: u32,
    def: u32,
}

impl<'a> Frame<'a> {
    fn new(src: Src<'a>, depth: u32, def: u32) -> Self {
        Frame {
            src,
            cache: Default::default(),
            known: Cell::new(0),
            depth,
            def,
        }
    }
}

type R = Result<f64, EvalError>;

struct Eval<'p> {
    code: Code<'p>,
    inputs: &'p Inputs<'p>,
    /// calcomp's `errno`: set by a failed library call, division by zero or
    /// illegal power, and sticky through the library calls it happens in.
    err: Cell<bool>,
    warnings: Cell<u64>,
    calls: Cell<u64>,
    max_calls: u64,
    stack_base: usize,
    noise: Cell<Option<([f64; 3], [f64; 4])>>,
}

fn stack_addr() -> usize {
    let marker = 0u8;
    std::hint::black_box(&marker) as *const u8 as usize
}

impl<'p> Code<'p> {
    fn run<F>(&self, inputs: &'p Inputs<'p>, max_calls: u64, f: F) -> (R, u64)
    where
        F: FnOnce(&Eval<'p>, &Frame<'_>) -> R,
    {
        let ev = Eval {
            code: *self,
            inputs,
            err: Cell::new(false),
            warnings: Cell::new(0),
            calls: Cell::new(0),
            max_calls,
            stack_base: stack_addr(),
            noise: Cell::new(None),
        };
        let top = Frame::new(Src::None, 0, u32::MAX);
        let r = f(&ev, &top);
        (r, ev.warnings.get())
    }
}

impl<'p> Eval<'p> {
    fn fail(&self) -> f64 {
        self.err.set(true);
        self.warnings.set(self.warnings.get() + 1);
        0.0
    }

    fn def(&self, d: u32) -> &'p CDef {
        &self.code.defs[d as usize]
    }

    fn too_few(&self, f: &Frame<'_>) -> EvalError {
        match self.code.defs.get(f.def as usize) {
            Some(d) => EvalError::in_def(d, "too few arguments"),
            None => EvalError::new("too few arguments"),
        }
    }

    fn list(&self, a: u32, n: u32) -> &'p [u32] {
        &self.code.lists[a as usize..(a + n) as usize]
    }

    fn eval(&self, n: u32, f: &Frame<'_>) -> R {
        match self.code.nodes[n as usize] {
            Node::Num(v) => Ok(v),
            Node::Input(i) => Ok(self.inputs.values[i as usize]),
            Node::Param(i) => self.param(i as usize, f),
            Node::Var(d) => self.enter(d, Src::None, f.depth),
            Node::FuncRef(c) => Err(self.not_value(c)),
            Node::Neg(a) => Ok(-self.eval(a, f)?),
            Node::Bin(op, a, b) => match op {
                BinOp::Add => Ok(self.eval(a, f)? + self.eval(b, f)?),
                BinOp::Sub => Ok(self.eval(a, f)? - self.eval(b, f)?),
                BinOp::Mul => Ok(self.eval(a, f)? * self.eval(b, f)?),
                BinOp::Div => {
                    // calcomp evaluates the divisor first; x/0 is 0.
                    let d = self.eval(b, f)?;
                    if d == 0.0 {
                        Ok(self.fail())
                    } else {
                        Ok(self.eval(a, f)? / d)
                    }
                }
                BinOp::Pow => {
                    let saved = self.err.replace(false);
                    let x = self.eval(a, f)?;
                    let y = self.eval(b, f)?;
                    let r = x.powf(y);
                    let underflow = r.abs() < f64::MIN_POSITIVE && x != 0.0 && x.is_finite();
                    if self.err.get() || !r.is_finite() || underflow {
                        Ok(self.fail())
                    } else {
                        self.err.set(saved);
                        Ok(r)
                    }
                }
            },
            Node::Call { def, args, n } => {
                self.enter(def, Src::Nodes(self.list(args, n), f), f.depth)
            }
            Node::CallParam { param, args, n } => {
                let c = self.resolve(param as usize, f)?;
                let src = Src::Nodes(self.list(args, n), f);
                match c {
                    Callable::User(d) => self.enter(d, src, f.depth),
                    Callable::Builtin(b) => self.builtin(b, src),
                }
            }
            Node::Builtin { b, args, n } => self.builtin(b, Src::Nodes(self.list(args, n), f)),
        }
    }

    fn not_value(&self, c: Callable) -> EvalError {
        EvalError::new(match c {
            Callable::User(d) => {
                let d = self.def(d);
                format!("{}: function `{}` used as a value", d.loc, d.name)
            }
            Callable::Builtin(b) => format!("built-in function {b:?} used as a value"),
        })
    }

    /// A user function call or a variable's evaluation.
    fn enter(&self, d: u32, src: Src<'_>, depth: u32) -> R {
        let def = self.def(d);
        if depth >= MAX_DEPTH || self.stack_base.abs_diff(stack_addr()) > STACK_BUDGET {
            return Err(EvalError::in_def(
                def,
                &format!("recursion too deep (more than {MAX_DEPTH} nested calls)"),
            ));
        }
        let calls = self.calls.get() + 1;
        self.calls.set(calls);
        if calls > self.max_calls {
            return Err(EvalError::in_def(
                def,
                &format!("more than {} calls in one evaluation", self.max_calls),
            ));
        }
        let frame = Frame::new(src, depth + 1, d);
        self.eval(def.body, &frame)
    }

    fn param(&self, i: usize, f: &Frame<'_>) -> R {
        if i < ARG_CACHE && f.known.get() & (1 << i) != 0 {
            return Ok(f.cache[i].get());
        }
        let v = match f.src {
            Src::Nodes(list, caller) => match list.get(i) {
                Some(&n) => self.eval(n, caller)?,
                None => return Err(self.too_few(f)),
            },
            Src::Values(vals) => match vals.get(i) {
                Some(&v) => v,
                None => return Err(self.too_few(f)),
            },
            Src::None => return Err(self.too_few(f)),
        };
        if i < ARG_CACHE {
            f.cache[i].set(v);
            f.known.set(f.known.get() | 1 << i);
        }
        Ok(v)
    }

    /// The function a parameter called as a function stands for, following
    /// parameters passed on through enclosing calls.
    fn resolve(&self, mut i: usize, f: &Frame<'_>) -> Result<Callable, EvalError> {
        let mut fr = f;
        let not_fn = |fr: &Frame<'_>| match self.code.defs.get(fr.def as usize) {
            Some(d) => EvalError::in_def(d, "argument is not a function"),
            None => EvalError::new("argument is not a function"),
        };
        loop {
            match fr.src {
                Src::Nodes(list, caller) => {
                    let Some(&n) = list.get(i) else {
                        return Err(self.too_few(fr));
                    };
                    match self.code.nodes[n as usize] {
                        Node::FuncRef(c) => return Ok(c),
                        Node::Param(q) => {
                            i = q as usize;
                            fr = caller;
                        }
                        _ => return Err(not_fn(fr)),
                    }
                }
                _ => return Err(not_fn(fr)),
            }
        }
    }

    fn arg(&self, src: Src<'_>, i: usize) -> R {
        match src {
            Src::Nodes(list, caller) => match list.get(i) {
                Some(&n) => self.eval(n, caller),
                None => Err(EvalError::new("too few arguments to a built-in function")),
            },
            Src::Values(v) => v
                .get(i)
                .copied()
                .ok_or_else(|| EvalError::new("too few arguments to a built-in function")),
            Src::None => Err(EvalError::new("too few arguments to a built-in function")),
        }
    }

    /// A library call as calcomp's `libfunc` makes it: a NaN or infinite
    /// result, or a math error inside the call, gives 0.
    fn builtin(&self, b: Builtin, src: Src<'_>) -> R {
        let saved = self.err.replace(false);
        let r = self.builtin_raw(b, src)?;
        if self.err.get() || !r.is_finite() {
            Ok(self.fail())
        } else {
            self.err.set(saved);
            Ok(r)
        }
    }

    fn noise(&self, src: Src<'_>) -> Result<([f64; 3], [f64; 4]), EvalError> {
        let p = [self.arg(src, 0)?, self.arg(src, 1)?, self.arg(src, 2)?];
        if let Some((q, f)) = self.noise.get() {
            if q == p {
                return Ok((p, f));
            }
        }
        let f = super::noise::noise3(p);
        self.noise.set(Some((p, f)));
        Ok((p, f))
    }

    fn builtin_raw(&self, b: Builtin, src: Src<'_>) -> R {
        if let Some(func) = b.unary() {
            let x = self.arg(src, 0)?;
            let r = func(x);
            if builtins::underflows(b, x, r) {
                self.err.set(true);
            }
            return Ok(r);
        }
        let a = |i| self.arg(src, i);
        match b {
            Builtin::If => {
                if a(0)? > 0.0 {
                    a(1)
                } else {
                    a(2)
                }
            }
            Builtin::Select => {
                let narg = src.len() as i64;
                let numer = a(0)?;
                let n = (numer + 0.5) as i64;
                if numer < -0.5 || n >= narg {
                    self.err.set(true);
                    return Ok(0.0);
                }
                if n == 0 {
                    Ok((narg - 1) as f64)
                } else {
                    a(n as usize)
                }
            }
            Builtin::Min | Builtin::Max => {
                let mut m = a(0)?;
                for i in (1..src.len()).rev() {
                    let v = a(i)?;
                    if (b == Builtin::Max && m < v) || (b == Builtin::Min && m > v) {
                        m = v;
                    }
                }
                Ok(m)
            }
            Builtin::Atan2 => Ok(a(0)?.atan2(a(1)?)),
            Builtin::Noise3 | Builtin::Noise3x | Builtin::Noise3y | Builtin::Noise3z => {
                let (_, f) = self.noise(src)?;
                Ok(match b {
                    Builtin::Noise3x => f[0],
                    Builtin::Noise3y => f[1],
                    Builtin::Noise3z => f[2],
                    _ => f[3],
                })
            }
            Builtin::Fnoise3 => Ok(super::noise::fnoise3([a(0)?, a(1)?, a(2)?])),
            Builtin::Hermite => {
                let t = a(4)?;
                Ok(super::noise::hermite(a(0)?, a(1)?, a(2)?, a(3)?, t))
            }
            Builtin::Arg => {
                let n = (a(0)? + 0.5) as i64;
                let args = self.inputs.args;
                if n < 1 {
                    Ok(args.len() as f64)
                } else if let Some(&v) = args.get(n as usize - 1) {
                    Ok(v)
                } else {
                    Err(EvalError::new(format!("missing real argument {n}")))
                }
            }
            _ => unreachable!("unary built-ins are handled above"),
        }
    }
}

impl Program {
    fn code(&self) -> Code<'_> {
        Code {
            nodes: &self.nodes,
            lists: &self.lists,
            defs: &self.defs,
        }
    }

    fn finish_run(&self, (r, warnings): (R, u64)) -> R {
        if warnings > 0 {
            self.warnings.fetch_add(warnings, Ordering::Relaxed);
        }
        r
    }

    /// Evaluates an expression handed out by [`Library::expr`].
    pub fn eval(&self, e: ExprId, inputs: &Inputs) -> Result<f64, EvalError> {
        let root = self.exprs[e.0 as usize];
        if let Node::Num(v) = self.nodes[root as usize] {
            return Ok(v);
        }
        self.finish_run(
            self.code()
                .run(inputs, MAX_CALLS, |ev, top| ev.eval(root, top)),
        )
    }

    /// Calls a function handed out by [`Library::function`] with `args`
    /// (ignored when it names a variable).
    pub fn call(&self, f: FuncId, args: &[f64], inputs: &Inputs) -> Result<f64, EvalError> {
        let t = self.funcs[f.0 as usize];
        self.finish_run(self.code().run(inputs, MAX_CALLS, |ev, _| match t {
            Target::Var(d) => ev.enter(d, Src::None, 0),
            Target::Call(Callable::User(d)) => ev.enter(d, Src::Values(args), 0),
            Target::Call(Callable::Builtin(b)) => ev.builtin(b, Src::Values(args)),
        }))
    }

    /// An empty program (scenes without functions).
    pub fn empty() -> Program {
        Program {
            nodes: Vec::new(),
            lists: Vec::new(),
            defs: Vec::new(),
            exprs: Vec::new(),
            funcs: Vec::new(),
            warnings: AtomicU64::new(0),
        }
    }

    /// How many library calls, divisions and powers failed (and gave 0, as
    /// in calcomp) over all evaluations so far.
    pub fn warnings(&self) -> u64 {
        self.warnings.load(Ordering::Relaxed)
    }

    /// Number of compiled nodes (for tests and statistics).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }
}

const _: () = {
    const fn is<T: Send + Sync>() {}
    is::<Program>();
    is::<EvalError>();
};

//! The [`Library`] of definitions a scene collects while it loads, and the
//! handles it gives out for expressions, functions and contexts.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::parser::{self, Expr, ParseError, Parser};
use super::{builtins, prelude, NAMED_INPUTS, N_CHANNELS};
use crate::{Error, SourceLoc};

/// A naming context: the global one or one `.cal` file's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Context(pub(super) u32);

/// An expression handed out by [`Library::expr`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ExprId(pub(super) u32);

/// A function handed out by [`Library::function`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FuncId(pub(super) u32);

/// One definition as parsed.
#[derive(Debug, Clone)]
pub(crate) struct Def {
    pub name: String,
    pub ctx: Context,
    pub nparams: usize,
    pub body: Expr,
    /// The file the definition is in (or the scene record that held it).
    pub file: PathBuf,
    /// Line added to the text's own line numbers - 1 (for expressions given
    /// in a scene file, the record's line).
    pub line_base: usize,
    pub pos: parser::Pos,
}

impl Def {
    pub(super) fn loc(&self) -> SourceLoc {
        loc_of(&self.file, self.line_base, self.pos)
    }
}

pub(super) fn loc_of(file: &Path, line_base: usize, pos: parser::Pos) -> SourceLoc {
    SourceLoc::with_column(file, line_base + pos.line as usize, pos.col as usize)
}

#[derive(Debug)]
pub(crate) struct CtxInfo {
    pub name: String,
    pub defs: HashMap<String, usize>,
}

/// An expression or function request waiting for [`Library::finish`].
#[derive(Debug, Clone)]
pub(crate) struct Request {
    pub ctx: Context,
    pub body: Expr,
    pub file: PathBuf,
    pub line_base: usize,
}

/// A function a scene names.
#[derive(Debug, Clone)]
pub(crate) struct FuncRequest {
    pub ctx: Context,
    pub name: String,
    pub loc: SourceLoc,
}

/// Collects definitions while a scene loads.
#[derive(Debug)]
pub struct Library {
    search_path: Vec<PathBuf>,
    pub(crate) contexts: Vec<CtxInfo>,
    files: HashMap<PathBuf, Context>,
    pub(crate) defs: Vec<Def>,
    pub(crate) exprs: Vec<Request>,
    pub(crate) funcs: Vec<FuncRequest>,
}

fn parse_error(file: &Path, line_base: usize, e: ParseError) -> Error {
    Error::parse(loc_of(file, line_base, e.pos), e.reason)
}

impl Library {
    /// Built-ins and the prelude; `search_path` is where .cal files are found
    /// after the including file's own directory (like Radiance's RAYPATH).
    pub fn new(search_path: Vec<PathBuf>) -> crate::Result<Library> {
        let mut lib = Library {
            search_path,
            contexts: vec![CtxInfo {
                name: String::new(),
                defs: HashMap::new(),
            }],
            files: HashMap::new(),
            defs: Vec::new(),
            exprs: Vec::new(),
            funcs: Vec::new(),
        };
        let global = lib.global();
        let builtin = PathBuf::from("<built-in>");
        lib.define_text(global, prelude::CHANNELS, &builtin, 0)?;
        for (k, name) in NAMED_INPUTS.iter().enumerate() {
            lib.add_def(Def {
                name: (*name).to_string(),
                ctx: global,
                nparams: 0,
                body: Expr::Input((N_CHANNELS + k) as u32),
                file: builtin.clone(),
                line_base: 0,
                pos: parser::Pos { line: 0, col: 0 },
            });
        }
        let rayinit = lib
            .search_path
            .iter()
            .map(|d| d.join("rayinit.cal"))
            .find(|p| p.is_file());
        match rayinit {
            Some(path) => {
                let text = read_text(&path)?;
                lib.define_text(global, &text, &path, 0)?;
            }
            None => {
                lib.define_text(global, prelude::PRELUDE, Path::new("<rayinit>"), 0)?;
            }
        }
        Ok(lib)
    }

    /// The global context (what a file name of "." means).
    pub fn global(&self) -> Context {
        Context(0)
    }

    fn add_def(&mut self, def: Def) {
        let id = self.defs.len();
        let ctx = def.ctx.0 as usize;
        self.contexts[ctx].defs.insert(def.name.clone(), id);
        self.defs.push(def);
    }

    pub(super) fn define_text(
        &mut self,
        ctx: Context,
        text: &str,
        file: &Path,
        line_base: usize,
    ) -> crate::Result<()> {
        let stmts = Parser::new(text)
            .and_then(Parser::statements)
            .map_err(|e| parse_error(file, line_base, e))?;
        for s in stmts {
            // A back-quoted name lives in the global table.
            let ctx = if s.name.contains('`') {
                self.global()
            } else {
                ctx
            };
            self.add_def(Def {
                name: s.name,
                ctx,
                nparams: s.params.len(),
                body: s.body,
                file: file.to_path_buf(),
                line_base,
                pos: s.pos,
            });
        }
        Ok(())
    }

    /// Adds the definitions in `text` (statements such as `f(t) = 2*t;`
    /// `k : 3`, as in a `.cal` file) to `ctx`; later definitions replace
    /// earlier ones. `loc` is where the text came from: errors say its file
    /// and line (plus the text's own line - 1) and the column. Nothing is
    /// added unless the whole text parses.
    pub fn define(&mut self, ctx: Context, text: &str, loc: &SourceLoc) -> crate::Result<()> {
        let file = loc.file.clone();
        self.define_text(ctx, text, &file, loc.line.saturating_sub(1))
    }

    /// Loads `name` (absolute, or relative to `base_dir`, then to each
    /// search-path entry; "." → global) once, returning its context. `from`
    /// is where the scene named it, for the "cannot find" error. Parse errors
    /// name the .cal file:line:column.
    pub fn load_file(
        &mut self,
        name: &str,
        base_dir: &Path,
        from: &SourceLoc,
    ) -> crate::Result<Context> {
        if name == "." {
            return Ok(self.global());
        }
        let given = Path::new(name);
        let candidates: Vec<PathBuf> = if given.is_absolute() {
            vec![given.to_path_buf()]
        } else {
            std::iter::once(base_dir.join(given))
                .chain(self.search_path.iter().map(|d| d.join(given)))
                .collect()
        };
        let Some(path) = candidates.into_iter().find(|p| p.is_file()) else {
            return Err(Error::parse(
                from.clone(),
                format!("cannot find function file \"{name}\""),
            ));
        };
        let key = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
        if let Some(&ctx) = self.files.get(&key) {
            return Ok(ctx);
        }
        let text = read_text(&path)?;
        let ctx_name = given
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let ctx_name = ctx_name
            .strip_suffix(".cal")
            .unwrap_or(&ctx_name)
            .to_string();
        let ctx = Context(self.contexts.len() as u32);
        self.contexts.push(CtxInfo {
            name: ctx_name,
            defs: HashMap::new(),
        });
        // Statements are added only when the whole file parses.
        self.define_text(ctx, &text, &path, 0)?;
        self.files.insert(key, ctx);
        Ok(ctx)
    }

    /// Compiles an expression given in a scene's string argument in `ctx`.
    /// `loc` is the scene record's place; errors say file:line and the column
    /// inside the expression text.
    pub fn expr(&mut self, ctx: Context, text: &str, loc: &SourceLoc) -> crate::Result<ExprId> {
        let line_base = loc.line.saturating_sub(1);
        let body = Parser::new(text)
            .and_then(Parser::expression)
            .map_err(|e| parse_error(&loc.file, line_base, e))?;
        let id = ExprId(self.exprs.len() as u32);
        self.exprs.push(Request {
            ctx,
            body,
            file: loc.file.clone(),
            line_base,
        });
        Ok(id)
    }

    /// A function named in a scene's string argument, to be called with
    /// `arity` arguments; `name` may also be a variable's, then the
    /// arguments are ignored.
    pub fn function(
        &mut self,
        ctx: Context,
        name: &str,
        _arity: usize,
        loc: &SourceLoc,
    ) -> crate::Result<FuncId> {
        // The arity is not checked here: as in calcomp, a call with fewer
        // arguments than parameters fails only if the missing one is used.
        let id = FuncId(self.funcs.len() as u32);
        self.funcs.push(FuncRequest {
            ctx,
            name: name.trim().to_string(),
            loc: loc.clone(),
        });
        Ok(id)
    }

    /// True if `name` is defined in `ctx` or globally, or is a built-in
    /// function (used to choose between forms).
    pub fn is_defined(&self, ctx: Context, name: &str) -> bool {
        self.lookup(ctx, name).is_some() || builtins::Builtin::lookup(name).is_some()
    }

    /// The number of parameters of the user function `name` as seen from
    /// `ctx` (0 for a variable); `None` if it is not defined there.
    /// Radiance decides how to call some functions by it (`colorpict`).
    pub fn arity(&self, ctx: Context, name: &str) -> Option<usize> {
        self.lookup(ctx, name).map(|d| self.defs[d].nparams)
    }

    /// A context's name: a file's name without `.cal`; "" for the global one.
    pub fn context_name(&self, ctx: Context) -> &str {
        self.contexts
            .get(ctx.0 as usize)
            .map_or("", |c| c.name.as_str())
    }

    /// The definition `name` refers to when written in `ctx`.
    pub(crate) fn lookup(&self, ctx: Context, name: &str) -> Option<usize> {
        if !name.contains('`') {
            if let Some(&d) = self.contexts.get(ctx.0 as usize)?.defs.get(name) {
                return Some(d);
            }
        }
        self.contexts[0].defs.get(name).copied()
    }
}

fn read_text(path: &Path) -> crate::Result<String> {
    let bytes = crate::input::read_input(path, crate::input::MAX_INPUT_BYTES)
        .map_err(|e| Error::io(path, e))?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

//! Scanner and recursive-descent parser for calcomp's grammar.
//!
//! The grammar follows Radiance's `calexpr.c` / `caldefn.c`:
//!
//! ```text
//! E1 -> E1 ADDOP E2 | E2
//! E2 -> E2 MULOP E3 | E3
//! E3 -> E4 ^ E3 | E4            (right-associative power)
//! E4 -> - E5 | + E5 | E5        (a sign binds tighter than `^`: -2^2 = 4)
//! E5 -> ( E1 ) | $N | NAME | NAME ( E1, ... ) | NUMBER
//! statement -> NAME = E1 | NAME : E1 | NAME(P,...) = E1 | NAME(P,...) : E1
//! ```
//!
//! Unlike calcomp's character scanner, white space separates tokens (calcomp
//! would read `a b` as the name `ab`). Nesting is bounded so hostile input can
//! neither overflow the stack here nor later, when the tree is compiled.

/// Deepest parser recursion (parentheses, calls, `^` chains) accepted.
const MAX_NESTING: u32 = 200;
/// Deepest expression tree accepted (long `+` chains grow it too).
const MAX_TREE_DEPTH: u32 = 500;

/// A position in the parsed text: line and column, both from 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Pos {
    pub line: u32,
    pub col: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
}

/// What a call names: a definition or built-in by name, or a parameter of
/// the enclosing function (a function passed as an argument).
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Callee {
    Name(String),
    Param(u32),
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Expr {
    Num(f64),
    /// An input slot, 0-based (`$1` is slot 0).
    Input(u32),
    /// A parameter of the enclosing function, 0-based.
    Param(u32),
    Name(String, Pos),
    Neg(Box<Expr>),
    Bin(BinOp, Box<Expr>, Box<Expr>),
    Call {
        callee: Callee,
        args: Vec<Expr>,
        pos: Pos,
    },
}

/// One parsed statement.
#[derive(Debug, Clone)]
pub(crate) struct Statement {
    pub name: String,
    pub params: Vec<String>,
    pub body: Expr,
    pub pos: Pos,
}

/// A parse error with its place in the text.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ParseError {
    pub pos: Pos,
    pub reason: String,
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64),
    Ident(String),
    Chan(u64),
    Punct(u8),
    Eof,
}

struct Lexer<'a> {
    src: &'a [u8],
    i: usize,
    line: u32,
    col: u32,
}

fn is_id_start(c: u8) -> bool {
    c.is_ascii_alphabetic() || c == b'`'
}

fn is_id(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_' || c == b'.' || c == b'`'
}

impl<'a> Lexer<'a> {
    fn new(src: &'a str) -> Self {
        Lexer {
            src: src.as_bytes(),
            i: 0,
            line: 1,
            col: 1,
        }
    }

    fn pos(&self) -> Pos {
        Pos {
            line: self.line,
            col: self.col,
        }
    }

    fn peek(&self) -> Option<u8> {
        self.src.get(self.i).copied()
    }

    fn bump(&mut self) {
        if let Some(c) = self.peek() {
            self.i += 1;
            if c == b'\n' {
                self.line = self.line.saturating_add(1);
                self.col = 1;
            } else {
                self.col = self.col.saturating_add(1);
            }
        }
    }

    /// Skips white space and `{ ... }` comments (which nest, as in calcomp).
    fn skip_blank(&mut self) -> Result<(), ParseError> {
        loop {
            match self.peek() {
                Some(c) if c.is_ascii_whitespace() => self.bump(),
                Some(b'{') => {
                    let start = self.pos();
                    let mut depth = 0usize;
                    loop {
                        match self.peek() {
                            None => {
                                return Err(ParseError {
                                    pos: start,
                                    reason: "unterminated comment: '}' expected".into(),
                                })
                            }
                            Some(b'{') => depth += 1,
                            Some(b'}') => {
                                depth -= 1;
                                if depth == 0 {
                                    self.bump();
                                    break;
                                }
                            }
                            _ => {}
                        }
                        self.bump();
                    }
                }
                _ => return Ok(()),
            }
        }
    }

    /// The next token and where it starts.
    fn next(&mut self) -> Result<(Tok, Pos), ParseError> {
        self.skip_blank()?;
        let pos = self.pos();
        let Some(c) = self.peek() else {
            return Ok((Tok::Eof, pos));
        };
        if is_id_start(c) {
            let start = self.i;
            while self.peek().is_some_and(is_id) {
                self.bump();
            }
            // Only ASCII bytes were consumed, so this is valid UTF-8.
            let s = String::from_utf8_lossy(&self.src[start..self.i]).into_owned();
            return Ok((Tok::Ident(s), pos));
        }
        if c.is_ascii_digit() || c == b'.' {
            return Ok((Tok::Num(self.number()), pos));
        }
        if c == b'$' {
            self.bump();
            let mut n: u64 = 0;
            let mut any = false;
            while let Some(d) = self.peek().filter(u8::is_ascii_digit) {
                n = n.saturating_mul(10).saturating_add(u64::from(d - b'0'));
                any = true;
                self.bump();
            }
            if !any {
                return Err(ParseError {
                    pos,
                    reason: "channel number expected after '$'".into(),
                });
            }
            return Ok((Tok::Chan(n), pos));
        }
        if b"+-*/^(),;=:".contains(&c) {
            self.bump();
            return Ok((Tok::Punct(c), pos));
        }
        Err(ParseError {
            pos,
            reason: if c.is_ascii_graphic() {
                format!("unexpected character '{}'", c as char)
            } else {
                format!("unexpected character (byte 0x{c:02x})")
            },
        })
    }

    /// A number as calcomp's `getnum` reads it: digits, `.` digits, then an
    /// optional exponent (an `e` without digits is read and ignored, as
    /// `atof` would).
    fn number(&mut self) -> f64 {
        let mut text = String::new();
        while let Some(d) = self.peek().filter(u8::is_ascii_digit) {
            text.push(d as char);
            self.bump();
        }
        if self.peek() == Some(b'.') {
            text.push('.');
            self.bump();
            while let Some(d) = self.peek().filter(u8::is_ascii_digit) {
                text.push(d as char);
                self.bump();
            }
        }
        if matches!(self.peek(), Some(b'e' | b'E')) {
            let mut exp = String::from("e");
            self.bump();
            if let Some(s) = self.peek().filter(|&s| s == b'-' || s == b'+') {
                exp.push(s as char);
                self.bump();
            }
            let mut digits = false;
            while let Some(d) = self.peek().filter(u8::is_ascii_digit) {
                exp.push(d as char);
                digits = true;
                self.bump();
            }
            if digits {
                text.push_str(&exp);
            }
        }
        if text == "." {
            return 0.0;
        }
        text.parse().unwrap_or(0.0)
    }
}

/// Parser state: one token of look-ahead.
pub(crate) struct Parser<'a> {
    lex: Lexer<'a>,
    tok: Tok,
    pos: Pos,
    nesting: u32,
    /// Parameters of the function being defined.
    params: Vec<String>,
}

type PResult<T> = Result<T, ParseError>;

impl<'a> Parser<'a> {
    pub fn new(src: &'a str) -> PResult<Self> {
        let mut lex = Lexer::new(src);
        let (tok, pos) = lex.next()?;
        Ok(Parser {
            lex,
            tok,
            pos,
            nesting: 0,
            params: Vec::new(),
        })
    }

    fn advance(&mut self) -> PResult<()> {
        let (tok, pos) = self.lex.next()?;
        self.tok = tok;
        self.pos = pos;
        Ok(())
    }

    fn err<T>(&self, reason: impl Into<String>) -> PResult<T> {
        Err(ParseError {
            pos: self.pos,
            reason: reason.into(),
        })
    }

    fn is_punct(&self, c: u8) -> bool {
        self.tok == Tok::Punct(c)
    }

    /// All statements of a file.
    pub fn statements(mut self) -> PResult<Vec<Statement>> {
        let mut out = Vec::new();
        loop {
            while self.is_punct(b';') {
                self.advance()?;
            }
            if self.tok == Tok::Eof {
                return Ok(out);
            }
            out.push(self.statement()?);
            if self.tok != Tok::Eof {
                if !self.is_punct(b';') {
                    return self.err("';' expected");
                }
                self.advance()?;
            }
        }
    }

    fn statement(&mut self) -> PResult<Statement> {
        let pos = self.pos;
        let Tok::Ident(name) = self.tok.clone() else {
            return self.err("illegal variable name");
        };
        self.advance()?;
        let mut params = Vec::new();
        if self.is_punct(b'(') {
            loop {
                self.advance()?;
                match &self.tok {
                    Tok::Ident(p) if !p.contains('`') && p.as_bytes()[0].is_ascii_alphabetic() => {
                        params.push(p.clone());
                    }
                    _ => return self.err("illegal parameter name"),
                }
                self.advance()?;
                if !self.is_punct(b',') {
                    break;
                }
            }
            if !self.is_punct(b')') {
                return self.err("')' expected");
            }
            self.advance()?;
        }
        // `=` (recomputed) and `:` (constant) mean the same here: values are
        // pure, and constant subexpressions are folded at `finish`.
        if !matches!(self.tok, Tok::Punct(b'=' | b':')) {
            return self.err("'=' or ':' expected");
        }
        self.advance()?;
        self.params = params;
        let body = self.e1();
        let params = std::mem::take(&mut self.params);
        let (body, _) = body?;
        Ok(Statement {
            name,
            params,
            body,
            pos,
        })
    }

    /// A whole text that must be exactly one expression.
    pub fn expression(mut self) -> PResult<Expr> {
        let (e, _) = self.e1()?;
        if self.tok != Tok::Eof {
            return self.err("unexpected text after the expression");
        }
        Ok(e)
    }

    fn bin(&self, op: BinOp, (a, da): (Expr, u32), (b, db): (Expr, u32)) -> PResult<(Expr, u32)> {
        let d = da.max(db) + 1;
        if d > MAX_TREE_DEPTH {
            return self.err("expression too deeply nested");
        }
        Ok((Expr::Bin(op, Box::new(a), Box::new(b)), d))
    }

    fn e1(&mut self) -> PResult<(Expr, u32)> {
        let mut left = self.e2()?;
        loop {
            let op = match self.tok {
                Tok::Punct(b'+') => BinOp::Add,
                Tok::Punct(b'-') => BinOp::Sub,
                _ => return Ok(left),
            };
            self.advance()?;
            let right = self.e2()?;
            left = self.bin(op, left, right)?;
        }
    }

    fn e2(&mut self) -> PResult<(Expr, u32)> {
        let mut left = self.e3()?;
        loop {
            let op = match self.tok {
                Tok::Punct(b'*') => BinOp::Mul,
                Tok::Punct(b'/') => BinOp::Div,
                _ => return Ok(left),
            };
            self.advance()?;
            let right = self.e3()?;
            left = self.bin(op, left, right)?;
        }
    }

    fn e3(&mut self) -> PResult<(Expr, u32)> {
        self.nesting += 1;
        if self.nesting > MAX_NESTING {
            return self.err("expression too deeply nested");
        }
        let r = self.e3_inner();
        self.nesting -= 1;
        r
    }

    fn e3_inner(&mut self) -> PResult<(Expr, u32)> {
        let base = self.e4()?;
        if !self.is_punct(b'^') {
            return Ok(base);
        }
        self.advance()?;
        let exp = self.e3()?;
        self.bin(BinOp::Pow, base, exp)
    }

    fn e4(&mut self) -> PResult<(Expr, u32)> {
        if self.is_punct(b'-') {
            self.advance()?;
            let (e, d) = self.e5()?;
            return Ok(match e {
                Expr::Num(v) => (Expr::Num(-v), d),
                // calcomp does not build -(-E5).
                Expr::Neg(inner) => (*inner, d.saturating_sub(1)),
                e => (Expr::Neg(Box::new(e)), d + 1),
            });
        }
        if self.is_punct(b'+') {
            self.advance()?;
        }
        self.e5()
    }

    fn e5(&mut self) -> PResult<(Expr, u32)> {
        let pos = self.pos;
        match self.tok.clone() {
            Tok::Punct(b'(') => {
                self.advance()?;
                let e = self.e1()?;
                if !self.is_punct(b')') {
                    return self.err("')' expected");
                }
                self.advance()?;
                Ok(e)
            }
            Tok::Chan(n) => {
                if !(1..=super::N_CHANNELS as u64).contains(&n) {
                    return self.err(format!("illegal channel number ${n}"));
                }
                self.advance()?;
                Ok((Expr::Input(n as u32 - 1), 1))
            }
            Tok::Num(v) => {
                self.advance()?;
                Ok((Expr::Num(v), 1))
            }
            Tok::Ident(name) => {
                self.advance()?;
                let param = self
                    .params
                    .iter()
                    .position(|p| *p == name)
                    .map(|i| i as u32);
                if !self.is_punct(b'(') {
                    return Ok(match param {
                        Some(i) => (Expr::Param(i), 1),
                        None => (Expr::Name(name, pos), 1),
                    });
                }
                let mut args = Vec::new();
                let mut depth = 1;
                loop {
                    self.advance()?;
                    let (a, d) = self.e1()?;
                    depth = depth.max(d + 1);
                    args.push(a);
                    if !self.is_punct(b',') {
                        break;
                    }
                }
                if !self.is_punct(b')') {
                    return self.err("')' expected");
                }
                if depth > MAX_TREE_DEPTH {
                    return self.err("expression too deeply nested");
                }
                self.advance()?;
                let callee = match param {
                    Some(i) => Callee::Param(i),
                    None => Callee::Name(name),
                };
                Ok((Expr::Call { callee, args, pos }, depth))
            }
            Tok::Eof => self.err("unexpected end of expression"),
            Tok::Punct(c) => self.err(format!("unexpected '{}'", c as char)),
        }
    }
}

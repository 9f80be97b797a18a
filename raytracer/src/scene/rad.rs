//! Reading Radiance scene files (`.rad`) into raw primitives.
//!
//! This module does the text work: tokenising with line numbers, reading
//! `modifier type identifier  nS s..  nI i..  nR r..` records, and expanding
//! the in-line commands we implement in Rust (`!xform`, `!genbox`,
//! `!genprism`, `!genrev`, and pipes
//! of them). Turning raw primitives into materials and shapes is
//! [`super::build`]'s job. Scene files never run shell commands: any other
//! `!command` is an error naming its file and line.

use std::path::{Path, PathBuf};

use crate::geometry::Transform;
use crate::{Error, Result, SourceLoc};

/// Most primitives one load may produce (arrays of arrays can explode; a
/// clear error beats running out of memory). Scenes of several GiB are
/// this renderer's business: 8 million triangles of a generated city are 4
/// million primitives and about 4.5 GiB in memory, so the limit sits well
/// above that (at about 600 bytes a primitive, more than this project's
/// machines hold) and stops only what no real scene asks for.
pub(crate) const MAX_PRIMITIVES: usize = 64_000_000;
/// Deepest include nesting (`!xform` of a file that includes a file ...).
pub(crate) const MAX_INCLUDE_DEPTH: usize = 32;

/// One Radiance record before interpretation. `alias` records keep the
/// referenced name in `strs[0]` and have no argument groups.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RawPrim {
    pub modifier: String,
    pub ptype: String,
    pub id: String,
    pub strs: Vec<String>,
    pub ints: Vec<String>,
    pub reals: Vec<f64>,
    /// Where the record starts (its modifier word).
    pub loc: SourceLoc,
    /// Transform applied by enclosing `!xform` commands to an `instance` or
    /// `mesh` (after the transform in its own string arguments).
    pub post: Option<Transform>,
}

impl RawPrim {
    /// Directory that relative file names in this record are resolved against.
    pub fn base_dir(&self) -> PathBuf {
        base_dir_of(&self.loc.file)
    }
}

pub(crate) fn base_dir_of(file: &Path) -> PathBuf {
    match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A whitespace-separated word and the line it is on.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Token {
    pub text: String,
    pub line: usize,
}

/// Splits scene text into words, tracking line numbers. `#` starts a comment
/// that runs to the end of the line wherever a word could start (Radiance
/// only allows them between records; accepting them between arguments too
/// is harmless and friendlier).
pub(crate) struct Lexer<'a> {
    src: &'a str,
    pos: usize,
    line: usize,
    /// Line of the last word read (where an unexpected end of file is reported).
    last: usize,
}

impl<'a> Lexer<'a> {
    pub fn new(src: &'a str) -> Self {
        Self {
            src,
            pos: 0,
            line: 1,
            last: 1,
        }
    }

    /// The line of the last word read.
    pub fn last_line(&self) -> usize {
        self.last
    }

    fn skip_space(&mut self) {
        let bytes = self.src.as_bytes();
        while self.pos < bytes.len() {
            match bytes[self.pos] {
                b'\n' => {
                    self.line += 1;
                    self.pos += 1;
                }
                b'#' => {
                    while self.pos < bytes.len() && bytes[self.pos] != b'\n' {
                        self.pos += 1;
                    }
                }
                c if c.is_ascii_whitespace() => self.pos += 1,
                _ => break,
            }
        }
    }

    /// The first character of the next word, after skipping space and comments.
    pub fn peek_char(&mut self) -> Option<char> {
        self.skip_space();
        self.src[self.pos..].chars().next()
    }

    /// The next word. A word that starts with a double or single quote
    /// runs to the matching quote, spaces and newlines included, and the
    /// quotes are dropped (Radiance's `fgetword`: `"porsche #1"`); an
    /// unclosed quote runs to the end of the file, as there.
    pub fn next_token(&mut self) -> Option<Token> {
        self.skip_space();
        if self.pos >= self.src.len() {
            return None;
        }
        let start = self.pos;
        let rest = &self.src[start..];
        let line = self.line;
        self.last = self.line;
        if let Some(q) = rest.chars().next().filter(|c| *c == '"' || *c == '\'') {
            let body = &rest[1..];
            let len = body.find(q).unwrap_or(body.len());
            let text = &body[..len];
            self.line += text.bytes().filter(|b| *b == b'\n').count();
            self.pos += 1 + len + usize::from(len < body.len());
            return Some(Token {
                text: text.to_string(),
                line,
            });
        }
        let len = rest
            .find(|c: char| c.is_ascii_whitespace())
            .unwrap_or(rest.len());
        self.pos += len;
        Some(Token {
            text: rest[..len].to_string(),
            line,
        })
    }

    /// Reads an in-line command starting at the current position (which holds
    /// `!`) up to the end of the line; a backslash before the newline
    /// continues it. Returns the command without the `!` and its first line.
    pub fn command_line(&mut self) -> (String, usize) {
        self.skip_space();
        let line = self.line;
        let bytes = self.src.as_bytes();
        debug_assert!(self.pos < bytes.len() && bytes[self.pos] == b'!');
        self.pos += 1;
        let mut out = String::new();
        let mut start = self.pos;
        while self.pos < bytes.len() {
            if bytes[self.pos] == b'\n' {
                let seg = &self.src[start..self.pos];
                self.line += 1;
                self.pos += 1;
                if let Some(s) = seg.strip_suffix('\\') {
                    out.push_str(s);
                    out.push(' ');
                    start = self.pos;
                    continue;
                }
                if let Some(s) = seg.strip_suffix("\\\r") {
                    out.push_str(s);
                    out.push(' ');
                    start = self.pos;
                    continue;
                }
                out.push_str(seg);
                return (out, line);
            }
            self.pos += 1;
        }
        out.push_str(&self.src[start..]);
        (out, line)
    }
}

/// Expansion state shared by a whole load: the include stack (cycle
/// protection) and the running primitive count.
#[derive(Debug, Default)]
pub(crate) struct Expander {
    stack: Vec<PathBuf>,
    count: usize,
    /// Where generators' function files (`genrev -f`) are found after the
    /// scene file's folder (Radiance's `RAYPATH`).
    pub search_path: Vec<PathBuf>,
}

impl Expander {
    /// An expander whose generators find function files along `search_path`.
    pub fn with_search_path(search_path: Vec<PathBuf>) -> Self {
        Self {
            search_path,
            ..Self::default()
        }
    }

    /// Reads and expands a scene file. `from` is where it was named (for the
    /// error if it cannot be read).
    pub fn parse_file(
        &mut self,
        path: &Path,
        from: Option<&SourceLoc>,
        out: &mut Vec<RawPrim>,
    ) -> Result<()> {
        let bytes =
            crate::input::read_input(path, crate::input::MAX_INPUT_BYTES).map_err(
                |e| match from {
                    Some(loc) => Error::parse(
                        loc.clone(),
                        format!("cannot read scene file '{}': {e}", path.display()),
                    ),
                    None => Error::io(path, e),
                },
            )?;
        // Bytes that are not UTF-8 (Latin-1 comments, names) do not
        // reject a file: Radiance reads bytes.
        let text = String::from_utf8_lossy(&bytes);
        let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        if self.stack.contains(&key) {
            let loc = from.cloned().unwrap_or_else(|| SourceLoc::new(path, 0));
            let chain: Vec<String> = self.stack.iter().map(|p| p.display().to_string()).collect();
            return Err(Error::parse(
                loc,
                format!(
                    "include cycle: '{}' includes itself (via {})",
                    path.display(),
                    chain.join(" -> ")
                ),
            ));
        }
        if self.stack.len() >= MAX_INCLUDE_DEPTH {
            let loc = from.cloned().unwrap_or_else(|| SourceLoc::new(path, 0));
            return Err(Error::parse(
                loc,
                format!("includes nested deeper than {MAX_INCLUDE_DEPTH} files"),
            ));
        }
        self.stack.push(key);
        let r = self.parse_text(&text, path, out);
        self.stack.pop();
        r
    }

    /// Parses scene text that came from `file` (used for messages and to
    /// resolve relative file names).
    pub fn parse_text(&mut self, text: &str, file: &Path, out: &mut Vec<RawPrim>) -> Result<()> {
        let mut lx = Lexer::new(text);
        let loc_at = |line: usize| SourceLoc::new(file, line);
        loop {
            match lx.peek_char() {
                None => return Ok(()),
                Some('!') => {
                    let (cmd, line) = lx.command_line();
                    self.command(&cmd, &loc_at(line), out)?;
                    continue;
                }
                Some(_) => {}
            }
            let Some(m) = lx.next_token() else {
                return Ok(());
            };
            let loc = loc_at(m.line);
            let truncated = |what: &str, lx: &Lexer| {
                Error::parse(
                    loc_at(lx.last_line()),
                    format!("unexpected end of file: expected {what} of the primitive starting at line {}", m.line),
                )
            };
            let ptype = lx
                .next_token()
                .ok_or_else(|| truncated("a primitive type", &lx))?;
            let id = lx
                .next_token()
                .ok_or_else(|| truncated("an identifier", &lx))?;
            let mut prim = RawPrim {
                modifier: m.text,
                ptype: ptype.text,
                id: id.text,
                strs: Vec::new(),
                ints: Vec::new(),
                reals: Vec::new(),
                loc: loc.clone(),
                post: None,
            };
            if prim.ptype == "alias" {
                let r = lx
                    .next_token()
                    .ok_or_else(|| truncated("the aliased modifier name", &lx))?;
                prim.strs.push(r.text);
            } else {
                prim.strs = read_group(&mut lx, file, "string", &prim)?
                    .into_iter()
                    .map(|t| t.text)
                    .collect();
                let ints = read_group(&mut lx, file, "integer", &prim)?;
                for t in &ints {
                    if t.text.parse::<i64>().is_err() {
                        return Err(Error::parse(
                            loc_at(t.line),
                            format!(
                                "{} '{}': bad integer argument '{}'",
                                prim.ptype, prim.id, t.text
                            ),
                        ));
                    }
                }
                prim.ints = ints.into_iter().map(|t| t.text).collect();
                let reals = read_group(&mut lx, file, "real", &prim)?;
                prim.reals = reals
                    .iter()
                    .map(|t| {
                        parse_real(&t.text).map_err(|r| {
                            Error::parse(
                                loc_at(t.line),
                                format!("{} '{}': {r}", prim.ptype, prim.id),
                            )
                        })
                    })
                    .collect::<Result<_>>()?;
            }
            self.push(prim, out)?;
        }
    }

    pub(crate) fn push(&mut self, prim: RawPrim, out: &mut Vec<RawPrim>) -> Result<()> {
        self.reserve(1, &prim.loc)?;
        out.push(prim);
        Ok(())
    }

    /// Accounts for `n` more primitives, failing past [`MAX_PRIMITIVES`].
    pub(crate) fn reserve(&mut self, n: usize, loc: &SourceLoc) -> Result<()> {
        self.count = self.count.saturating_add(n);
        if self.count > MAX_PRIMITIVES {
            return Err(Error::parse(
                loc.clone(),
                format!(
                    "scene expands to more than {MAX_PRIMITIVES} primitives (check array counts)"
                ),
            ));
        }
        Ok(())
    }
}

fn read_group(lx: &mut Lexer, file: &Path, what: &str, prim: &RawPrim) -> Result<Vec<Token>> {
    let Some(count) = lx.next_token() else {
        return Err(Error::parse(
            SourceLoc::new(file, lx.last_line()),
            format!(
                "unexpected end of file: {} '{}' (line {}) is missing its {what} argument count",
                prim.ptype, prim.id, prim.loc.line
            ),
        ));
    };
    let n: usize = count.text.parse().map_err(|_| {
        Error::parse(
            SourceLoc::new(file, count.line),
            format!(
                "{} '{}': expected the number of {what} arguments, found '{}'",
                prim.ptype, prim.id, count.text
            ),
        )
    })?;
    let mut v = Vec::with_capacity(n.min(64));
    for i in 0..n {
        let Some(t) = lx.next_token() else {
            return Err(Error::parse(
                SourceLoc::new(file, lx.last_line()),
                format!(
                    "unexpected end of file: {} '{}' (line {}) declares {n} {what} arguments but only {i} follow",
                    prim.ptype, prim.id, prim.loc.line
                ),
            ));
        };
        v.push(t);
    }
    Ok(v)
}

/// Parses a finite real number as Radiance writes them (`.5`, `1e-3`, `+2`).
pub(crate) fn parse_real(s: &str) -> std::result::Result<f64, String> {
    let ok_chars = s
        .bytes()
        .all(|b| b.is_ascii_digit() || matches!(b, b'.' | b'e' | b'E' | b'+' | b'-'));
    match s.parse::<f64>() {
        Ok(v) if ok_chars && v.is_finite() => Ok(v),
        Ok(_) if ok_chars => Err(format!("real argument '{s}' is out of range")),
        _ => Err(format!("bad real argument '{s}'")),
    }
}

/// Splits an in-line command into pipeline stages of words as `sh` would
/// for the simple commands we run: words separated by blanks, `|` between
/// stages, `'...'` quoting everything and `"..."` everything but `$`,
/// `` ` `` and `\\` escapes, `\\` outside quotes escaping one character.
/// Redirections, `;`, `&`, substitutions and unterminated quotes are shell
/// syntax we refuse: the error says which.
pub(crate) fn split_command(cmd: &str) -> std::result::Result<Vec<Vec<String>>, String> {
    let mut stages = vec![Vec::new()];
    let mut word = String::new();
    let mut in_word = false;
    let mut chars = cmd.chars();
    while let Some(c) = chars.next() {
        match c {
            '\'' => {
                in_word = true;
                loop {
                    match chars.next() {
                        Some('\'') => break,
                        Some(q) => word.push(q),
                        None => return Err("an unterminated ' quote".to_string()),
                    }
                }
            }
            '"' => {
                in_word = true;
                loop {
                    match chars.next() {
                        Some('"') => break,
                        Some(q @ ('$' | '`')) => return Err(format!("'{q}' substitution")),
                        Some('\\') => match chars.next() {
                            Some(e @ ('$' | '`' | '"' | '\\')) => word.push(e),
                            Some('\n') => {}
                            Some(e) => {
                                word.push('\\');
                                word.push(e);
                            }
                            None => return Err("an unterminated \" quote".to_string()),
                        },
                        Some(q) => word.push(q),
                        None => return Err("an unterminated \" quote".to_string()),
                    }
                }
            }
            '\\' => match chars.next() {
                Some('\n') => {}
                Some(e) => {
                    in_word = true;
                    word.push(e);
                }
                None => {}
            },
            '(' | ')' => {
                return Err(format!("'{c}'; quote expressions, as in 'sin(t)'"));
            }
            '<' | '>' | ';' | '&' | '`' | '$' => {
                return Err(format!("'{c}'"));
            }
            c if c == '|' || c.is_whitespace() => {
                end_word(&mut stages, &mut word, &mut in_word);
                if c == '|' {
                    stages.push(Vec::new());
                }
            }
            c => {
                in_word = true;
                word.push(c);
            }
        }
    }
    end_word(&mut stages, &mut word, &mut in_word);
    Ok(stages)
}

/// Ends the word being read, if any, as the last stage's next word.
fn end_word(stages: &mut [Vec<String>], word: &mut String, in_word: &mut bool) {
    if std::mem::take(in_word) {
        if let Some(stage) = stages.last_mut() {
            stage.push(std::mem::take(word));
        }
    }
}

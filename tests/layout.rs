//! The shape the design promises, checked on the source tree itself:
//!
//! * no import loops: between the files of `framework/src` and of
//!   `raytracer/src` (file A uses B and B uses A, directly or through a
//!   chain), and between the renderer's top-level modules (`geometry`,
//!   `scene`, `accel`, `render`, `parallel`, ...), which sit in layers, and
//!   between the framework's top-level modules (`protocol`, `cache`,
//!   `store`, `processor`, `runtime`, ...): `protocol/` holds the
//!   `Workload` contract, the vocabulary it speaks (`Addr`, `Placement`,
//!   `DpOutcome`) and the messages generic over a workload, and uses none
//!   of the actors or runtimes built on it;
//! * the physics (`geometry`, `scene`, `accel`, `render`, `modifier`, `cal`,
//!   `image`) uses neither the parallel renderer nor the framework, only
//!   itself and the crate's `error` and `input` modules;
//! * no file in `framework/src` or `raytracer/src/parallel` over 600 lines.
//!
//! A "use" is any path into the crate a file's code names: `use
//! crate::a::b::{C, d::E}`, `crate::a::f(..)`, `super::x`, `self::y`, and in
//! a folder's `mod.rs` its children's names. A path is resolved to the file
//! that defines the item, through `pub use` re-exports (which are not uses
//! themselves: a folder's `mod.rs` re-exporting its children is the
//! folder's interface, not a dependency). Comments, string literals,
//! `#[cfg(test)]` items and files that are test modules are left out: tests
//! may reach across layers.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// One module of a crate: its path (`["render", "material"]`), its file and
/// what the checker read from it.
#[derive(Debug, Default)]
struct Module {
    file: PathBuf,
    /// Child modules declared in it (`mod x;`), with whether the declaration
    /// is test-only.
    children: BTreeMap<String, bool>,
    /// Names defined in the file (fn, struct, enum, trait, type, const,
    /// static, union, macro_rules).
    defines: BTreeSet<String>,
    /// `pub use` re-exports: name -> the path it stands for (absolute).
    reexports: BTreeMap<String, Vec<String>>,
    /// `pub use path::*` globs (absolute paths of the globbed modules).
    globs: Vec<Vec<String>>,
    /// Paths its code names (absolute), with the line they are on.
    uses: Vec<(Vec<String>, usize)>,
    /// Declared under `#[cfg(test)]` (or inside such a module).
    test_only: bool,
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    Colons,
    Open,
    Close,
    Comma,
    Star,
    Semi,
    Hash,
    Other(char),
}

/// Tokens of `src` with their line numbers: comments, strings and
/// character literals dropped, lifetimes kept apart from char literals.
fn tokenize(src: &str) -> Vec<(Tok, usize)> {
    let b: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    let n = b.len();
    while i < n {
        let c = b[i];
        match c {
            '\n' => {
                line += 1;
                i += 1;
            }
            c if c.is_whitespace() => i += 1,
            '/' if i + 1 < n && b[i + 1] == '/' => {
                while i < n && b[i] != '\n' {
                    i += 1;
                }
            }
            '/' if i + 1 < n && b[i + 1] == '*' => {
                let mut depth = 0;
                while i < n {
                    if b[i] == '/' && i + 1 < n && b[i + 1] == '*' {
                        depth += 1;
                        i += 2;
                    } else if b[i] == '*' && i + 1 < n && b[i + 1] == '/' {
                        depth -= 1;
                        i += 2;
                        if depth == 0 {
                            break;
                        }
                    } else {
                        if b[i] == '\n' {
                            line += 1;
                        }
                        i += 1;
                    }
                }
            }
            'r' | 'b' if is_raw_string(&b, i) => {
                // r"..", r#".."#, br".."
                let mut j = i + 1;
                if b[i] == 'b' {
                    j += 1;
                }
                let mut hashes = 0;
                while b[j] == '#' {
                    hashes += 1;
                    j += 1;
                }
                j += 1; // the quote
                loop {
                    if j >= n {
                        break;
                    }
                    if b[j] == '\n' {
                        line += 1;
                    }
                    if b[j] == '"' && (0..hashes).all(|k| j + 1 + k < n && b[j + 1 + k] == '#') {
                        j += 1 + hashes;
                        break;
                    }
                    j += 1;
                }
                i = j;
            }
            '"' => {
                i += 1;
                while i < n && b[i] != '"' {
                    if b[i] == '\\' {
                        i += 1;
                    }
                    if i < n && b[i] == '\n' {
                        line += 1;
                    }
                    i += 1;
                }
                i += 1;
            }
            '\'' => {
                // A char literal ('x', '\n', '\u{..}') or a lifetime ('a).
                if i + 2 < n && b[i + 1] == '\\' {
                    i += 2;
                    while i < n && b[i] != '\'' {
                        i += 1;
                    }
                    i += 1;
                } else if i + 2 < n && b[i + 2] == '\'' {
                    i += 3;
                } else {
                    i += 1; // lifetime: its name follows as an identifier
                }
            }
            c if c.is_alphabetic() || c == '_' => {
                let s = i;
                while i < n && (b[i].is_alphanumeric() || b[i] == '_') {
                    i += 1;
                }
                let word: String = b[s..i].iter().collect();
                // b'x' and b"..": byte literals.
                if word == "b" && i < n && (b[i] == '\'' || b[i] == '"') {
                    continue;
                }
                out.push((Tok::Ident(word), line));
            }
            ':' if i + 1 < n && b[i + 1] == ':' => {
                out.push((Tok::Colons, line));
                i += 2;
            }
            '{' => {
                out.push((Tok::Open, line));
                i += 1;
            }
            '}' => {
                out.push((Tok::Close, line));
                i += 1;
            }
            ',' => {
                out.push((Tok::Comma, line));
                i += 1;
            }
            '*' => {
                out.push((Tok::Star, line));
                i += 1;
            }
            ';' => {
                out.push((Tok::Semi, line));
                i += 1;
            }
            '#' => {
                out.push((Tok::Hash, line));
                i += 1;
            }
            c => {
                out.push((Tok::Other(c), line));
                i += 1;
            }
        }
    }
    out
}

fn is_raw_string(b: &[char], i: usize) -> bool {
    let mut j = i;
    if b[j] == 'b' {
        j += 1;
        if j >= b.len() || b[j] != 'r' {
            return false;
        }
    }
    if i > 0 && (b[i - 1].is_alphanumeric() || b[i - 1] == '_') {
        return false;
    }
    j += 1;
    while j < b.len() && b[j] == '#' {
        j += 1;
    }
    j < b.len() && b[j] == '"'
}

fn ident(t: &Tok) -> Option<&str> {
    match t {
        Tok::Ident(s) => Some(s),
        _ => None,
    }
}

/// Removes `#[cfg(test)]` items: the attribute and the item after it (up to
/// its `;` or its matching `}`). Returns the names of test-only `mod x;`
/// declarations, which are dropped too.
fn strip_test_items(toks: &mut Vec<(Tok, usize)>) -> BTreeSet<String> {
    let mut test_mods = BTreeSet::new();
    let mut out = Vec::with_capacity(toks.len());
    let mut i = 0;
    while i < toks.len() {
        let is_cfg_test = toks[i].0 == Tok::Hash
            && toks.get(i + 1).map(|t| &t.0) == Some(&Tok::Other('['))
            && toks.get(i + 2).and_then(|t| ident(&t.0)) == Some("cfg")
            && toks.get(i + 3).map(|t| &t.0) == Some(&Tok::Other('('))
            && toks.get(i + 4).and_then(|t| ident(&t.0)) == Some("test")
            && toks.get(i + 5).map(|t| &t.0) == Some(&Tok::Other(')'))
            && toks.get(i + 6).map(|t| &t.0) == Some(&Tok::Other(']'));
        if !is_cfg_test {
            out.push(toks[i].clone());
            i += 1;
            continue;
        }
        // Skip the item: to the first `;` at depth 0, or the `}` closing the
        // first `{`.
        let mut j = i + 7;
        let mut depth = 0usize;
        let mut words = Vec::new();
        while j < toks.len() {
            match &toks[j].0 {
                Tok::Open => depth += 1,
                Tok::Close => {
                    depth -= 1;
                    if depth == 0 {
                        break;
                    }
                }
                Tok::Semi if depth == 0 => break,
                Tok::Ident(w) if depth == 0 => words.push(w.clone()),
                _ => {}
            }
            j += 1;
        }
        if let Some(p) = words.iter().position(|w| w == "mod") {
            if let Some(name) = words.get(p + 1) {
                test_mods.insert(name.clone());
            }
        }
        i = j + 1;
    }
    *toks = out;
    test_mods
}

/// Parses a path tree at `toks[i..]` (after its first segment `first`),
/// e.g. `a::{b::C, d}`; returns the expanded paths and the index after it.
fn path_tree(
    toks: &[(Tok, usize)],
    mut i: usize,
    prefix: Vec<String>,
) -> (Vec<Vec<String>>, usize) {
    let mut path = prefix;
    loop {
        if toks.get(i).map(|t| &t.0) != Some(&Tok::Colons) {
            return (vec![path], i);
        }
        i += 1;
        match toks.get(i).map(|t| &t.0) {
            Some(Tok::Ident(s)) => {
                path.push(s.clone());
                i += 1;
            }
            Some(Tok::Star) => {
                path.push("*".into());
                return (vec![path], i + 1);
            }
            Some(Tok::Open) => {
                i += 1;
                let mut all = Vec::new();
                loop {
                    match toks.get(i).map(|t| &t.0) {
                        Some(Tok::Close) => return (all, i + 1),
                        Some(Tok::Comma) => i += 1,
                        Some(Tok::Ident(s)) if s == "self" => {
                            all.push(path.clone());
                            i += 1;
                        }
                        Some(Tok::Ident(s)) => {
                            let mut p = path.clone();
                            p.push(s.clone());
                            let (sub, j) = path_tree(toks, i + 1, p);
                            all.extend(sub);
                            i = j;
                        }
                        Some(Tok::Star) => {
                            let mut p = path.clone();
                            p.push("*".into());
                            all.push(p);
                            i += 1;
                        }
                        // `as` renames and anything else: skip the token.
                        Some(_) => i += 1,
                        None => return (all, i),
                    }
                }
            }
            _ => return (vec![path], i),
        }
    }
}

/// Reads one file: its children, definitions, re-exports and uses, with
/// paths made absolute from the module path `me`.
fn read_module(file: &Path, me: &[String], is_folder: bool) -> Module {
    let src = std::fs::read_to_string(file).unwrap();
    let mut toks = tokenize(&src);
    let test_mods = strip_test_items(&mut toks);
    let mut m = Module {
        file: file.to_path_buf(),
        ..Module::default()
    };
    for t in &test_mods {
        m.children.insert(t.clone(), true);
    }
    // The module a relative path starts from: `self` is `me`, `super` its
    // parent.
    let resolve_rel = |first: &str, rest: &[String]| -> Option<Vec<String>> {
        let mut base: Vec<String> = me.to_vec();
        match first {
            "crate" => base.clear(),
            "self" => {}
            "super" => {
                base.pop()?;
            }
            _ => return None,
        }
        let mut it = rest.iter().peekable();
        while it.peek().map(|s| s.as_str()) == Some("super") {
            base.pop()?;
            it.next();
        }
        base.extend(it.cloned());
        Some(base)
    };
    let mut i = 0;
    while i < toks.len() {
        let (tok, line) = (&toks[i].0, toks[i].1);
        let word = ident(tok);
        match word {
            Some("mod") => {
                if let (Some(Tok::Ident(name)), Some(Tok::Semi)) =
                    (toks.get(i + 1).map(|t| &t.0), toks.get(i + 2).map(|t| &t.0))
                {
                    m.children.entry(name.clone()).or_insert(false);
                    i += 3;
                    continue;
                }
                i += 1;
            }
            Some(
                kw @ ("fn" | "struct" | "enum" | "trait" | "type" | "const" | "static" | "union"),
            ) => {
                let _ = kw;
                if let Some(Tok::Ident(name)) = toks.get(i + 1).map(|t| &t.0) {
                    m.defines.insert(name.clone());
                }
                i += 1;
            }
            Some("macro_rules") => {
                if let Some(Tok::Ident(name)) = toks.get(i + 2).map(|t| &t.0) {
                    m.defines.insert(name.clone());
                }
                i += 1;
            }
            Some("use") => {
                let public = i > 0 && ident(&toks[i - 1].0) == Some("pub")
                    || i > 3
                        && toks[i - 1].0 == Tok::Other(')')
                        && ident(&toks[i - 4].0) == Some("pub");
                let Some(Tok::Ident(first)) = toks.get(i + 1).map(|t| &t.0) else {
                    i += 1;
                    continue;
                };
                let (paths, j) = path_tree(&toks, i + 2, vec![first.clone()]);
                // `as` renames: `use a::b as c;` re-exports `c`.
                let rename = match (toks.get(j).map(|t| &t.0), toks.get(j + 1).map(|t| &t.0)) {
                    (Some(Tok::Ident(a)), Some(Tok::Ident(c))) if a == "as" => Some(c.clone()),
                    _ => None,
                };
                for p in paths {
                    let abs = match p[0].as_str() {
                        "crate" | "self" | "super" => resolve_rel(&p[0], &p[1..]),
                        // A child module named directly (in a folder's mod.rs
                        // or any file with inline children).
                        c if m.children.contains_key(c)
                            || is_folder && child_file_exists(file, c) =>
                        {
                            let mut a = me.to_vec();
                            a.extend(p.iter().cloned());
                            Some(a)
                        }
                        _ => None, // another crate
                    };
                    let Some(abs) = abs else { continue };
                    if public {
                        if abs.last().map(String::as_str) == Some("*") {
                            m.globs.push(abs[..abs.len() - 1].to_vec());
                        } else {
                            let name = rename
                                .clone()
                                .unwrap_or_else(|| abs.last().unwrap().clone());
                            m.reexports.insert(name, abs);
                        }
                    } else {
                        m.uses.push((abs, line));
                    }
                }
                i = j;
            }
            Some(first @ ("crate" | "super" | "self"))
                if toks.get(i + 1).map(|t| &t.0) == Some(&Tok::Colons) =>
            {
                let (paths, j) = path_tree(&toks, i + 1, vec![first.to_string()]);
                for p in paths {
                    if let Some(abs) = resolve_rel(&p[0], &p[1..]) {
                        m.uses.push((abs, line));
                    }
                }
                i = j;
            }
            Some(name)
                if is_folder
                    && toks.get(i + 1).map(|t| &t.0) == Some(&Tok::Colons)
                    && (i == 0 || toks[i - 1].0 != Tok::Colons)
                    && (m.children.contains_key(name) || child_file_exists(file, name)) =>
            {
                let mut abs = me.to_vec();
                let (paths, j) = path_tree(&toks, i + 1, vec![name.to_string()]);
                for p in paths {
                    abs.truncate(me.len());
                    abs.extend(p);
                    m.uses.push((abs.clone(), line));
                }
                i = j;
            }
            _ => i += 1,
        }
    }
    m
}

fn child_file_exists(file: &Path, name: &str) -> bool {
    let dir = file.parent().unwrap();
    dir.join(format!("{name}.rs")).exists() || dir.join(name).join("mod.rs").exists()
}

/// Every module of the crate whose root is `src/lib.rs`.
fn read_crate(src: &Path) -> BTreeMap<Vec<String>, Module> {
    let mut mods = BTreeMap::new();
    let mut stack = vec![(src.join("lib.rs"), Vec::<String>::new(), false)];
    while let Some((file, me, test_only)) = stack.pop() {
        let is_folder =
            file.file_name().unwrap() == "mod.rs" || file.file_name().unwrap() == "lib.rs";
        let mut m = read_module(&file, &me, is_folder);
        m.test_only = test_only;
        let dir = if is_folder {
            file.parent().unwrap().to_path_buf()
        } else {
            file.with_extension("")
        };
        for (child, test) in &m.children {
            let mut path = me.clone();
            path.push(child.clone());
            let f = dir.join(format!("{child}.rs"));
            let f = if f.exists() {
                f
            } else {
                dir.join(child).join("mod.rs")
            };
            if f.exists() {
                stack.push((f, path, test_only || *test));
            }
        }
        mods.insert(me, m);
    }
    mods
}

/// The module that defines what `path` names: the longest module prefix,
/// then through that module's re-exports.
fn resolve(
    mods: &BTreeMap<Vec<String>, Module>,
    path: &[String],
    depth: usize,
) -> Option<Vec<String>> {
    if depth > 16 {
        return None;
    }
    let mut k = path.len();
    while k > 0 && !mods.contains_key(&path[..k]) {
        k -= 1;
    }
    let module = &path[..k];
    let m = &mods[module];
    let Some(item) = path.get(k) else {
        return Some(module.to_vec());
    };
    if item == "*" || m.defines.contains(item) {
        return Some(module.to_vec());
    }
    if let Some(target) = m.reexports.get(item) {
        let mut t = target.clone();
        t.extend(path[k + 1..].iter().cloned());
        return resolve(mods, &t, depth + 1).or(Some(module.to_vec()));
    }
    for g in &m.globs {
        let mut t = g.clone();
        t.extend(path[k..].iter().cloned());
        if let Some(r) = resolve(mods, &t, depth + 1) {
            if r.as_slice() != g.as_slice()
                || mods.get(g).is_some_and(|gm| gm.defines.contains(item))
            {
                return Some(r);
            }
        }
    }
    Some(module.to_vec())
}

/// Edges `from -> to` between modules (with the first line naming it),
/// leaving out test-only modules and uses of oneself.
type Edges = BTreeMap<(Vec<String>, Vec<String>), usize>;

fn edges(mods: &BTreeMap<Vec<String>, Module>) -> Edges {
    let mut e = Edges::new();
    for (me, m) in mods {
        if m.test_only {
            continue;
        }
        for (path, line) in &m.uses {
            let Some(to) = resolve(mods, path, 0) else {
                continue;
            };
            if &to == me || to.is_empty() || mods[&to].test_only {
                continue;
            }
            e.entry((me.clone(), to)).or_insert(*line);
        }
    }
    e
}

/// Strongly connected components with more than one member (Tarjan).
fn cycles<N: Ord + Clone>(nodes: &BTreeSet<N>, edges: &BTreeSet<(N, N)>) -> Vec<Vec<N>> {
    let idx: BTreeMap<&N, usize> = nodes.iter().enumerate().map(|(i, n)| (n, i)).collect();
    let list: Vec<&N> = nodes.iter().collect();
    let mut adj = vec![Vec::new(); nodes.len()];
    for (a, b) in edges {
        adj[idx[a]].push(idx[b]);
    }
    struct T {
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<usize>>,
    }
    fn visit(v: usize, adj: &[Vec<usize>], t: &mut T) {
        t.index[v] = Some(t.next);
        t.low[v] = t.next;
        t.next += 1;
        t.stack.push(v);
        t.on[v] = true;
        for &w in &adj[v] {
            match t.index[w] {
                None => {
                    visit(w, adj, t);
                    t.low[v] = t.low[v].min(t.low[w]);
                }
                Some(iw) if t.on[w] => t.low[v] = t.low[v].min(iw),
                _ => {}
            }
        }
        if Some(t.low[v]) == t.index[v] {
            let mut comp = Vec::new();
            loop {
                let w = t.stack.pop().unwrap();
                t.on[w] = false;
                comp.push(w);
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                t.out.push(comp);
            }
        }
    }
    let n = nodes.len();
    let mut t = T {
        index: vec![None; n],
        low: vec![0; n],
        on: vec![false; n],
        stack: Vec::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if t.index[v].is_none() {
            visit(v, &adj, &mut t);
        }
    }
    t.out
        .into_iter()
        .map(|c| {
            let mut c: Vec<N> = c.into_iter().map(|i| list[i].clone()).collect();
            c.sort();
            c
        })
        .collect()
}

fn name(p: &[String]) -> String {
    if p.is_empty() {
        "crate".into()
    } else {
        p.join("::")
    }
}

/// A shortest cycle through the nodes of `comp` (a strongly connected
/// component of `edges`).
fn shortest_cycle<N: Ord + Clone>(comp: &[N], edges: &BTreeSet<(N, N)>) -> Vec<N> {
    let inside: BTreeSet<&N> = comp.iter().collect();
    let mut best: Option<Vec<N>> = None;
    for start in comp {
        // Breadth-first from `start` back to it.
        let mut prev: BTreeMap<&N, &N> = BTreeMap::new();
        let mut frontier = vec![start];
        let mut found = false;
        'bfs: while !frontier.is_empty() {
            let mut next = Vec::new();
            for a in frontier {
                for (x, b) in edges.range((a.clone(), comp[0].clone())..) {
                    if x != a {
                        break;
                    }
                    if !inside.contains(b) {
                        continue;
                    }
                    if b == start {
                        prev.insert(start, a);
                        found = true;
                        break 'bfs;
                    }
                    if !prev.contains_key(b) {
                        prev.insert(b, a);
                        next.push(b);
                    }
                }
            }
            frontier = next;
        }
        if found {
            let mut cyc = vec![start.clone()];
            let mut at = prev[start];
            while at != start {
                cyc.push(at.clone());
                at = prev[at];
            }
            cyc.reverse();
            if best.as_ref().is_none_or(|b| cyc.len() < b.len()) {
                best = Some(cyc);
            }
        }
    }
    best.unwrap_or_default()
}

/// Import loops in the crate at `src`: between files, and between the
/// top-level modules. Each loop is shown as one shortest cycle, with the
/// use that makes each step.
fn import_loops(src: &Path, folders_are_layers: bool) -> Vec<String> {
    let mods = read_crate(src);
    let e = edges(&mods);
    let mut problems = Vec::new();
    let mut check = |kind: &str, level: &dyn Fn(&[String]) -> Vec<String>| {
        let nodes: BTreeSet<Vec<String>> = mods
            .iter()
            .filter(|(_, m)| !m.test_only)
            .map(|(k, _)| level(k))
            .filter(|k| !k.is_empty())
            .collect();
        let lifted: BTreeSet<(Vec<String>, Vec<String>)> = e
            .keys()
            .map(|(a, b)| (level(a), level(b)))
            .filter(|(a, b)| a != b && !a.is_empty() && !b.is_empty())
            .collect();
        for comp in cycles(&nodes, &lifted) {
            let cyc = shortest_cycle(&comp, &lifted);
            let mut steps = Vec::new();
            for (i, a) in cyc.iter().enumerate() {
                let b = &cyc[(i + 1) % cyc.len()];
                // One use that makes this step.
                if let Some(((fa, fb), line)) = e
                    .iter()
                    .find(|((fa, fb), _)| &level(fa) == a && &level(fb) == b)
                {
                    steps.push(format!(
                        "    {} uses {} ({}:{line})",
                        name(fa),
                        name(fb),
                        mods[fa].file.display()
                    ));
                }
            }
            let names: Vec<String> = comp.iter().map(|c| name(c)).collect();
            problems.push(format!(
                "import loop between {kind} {{{}}}, for example:\n{}",
                names.join(", "),
                steps.join("\n")
            ));
        }
    };
    check("files", &|p: &[String]| {
        if p.is_empty() {
            vec!["crate".into()]
        } else {
            p.to_vec()
        }
    });
    if !folders_are_layers {
        return problems;
    }
    check("modules", &|p: &[String]| {
        p.iter().take(1).cloned().collect()
    });
    problems
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

#[test]
fn framework_has_no_import_loops() {
    let problems = import_loops(&workspace().join("framework/src"), true);
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn renderer_has_no_import_loops() {
    let problems = import_loops(&workspace().join("raytracer/src"), true);
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The physics knows nothing of processors, partitions or the framework.
#[test]
fn physics_does_not_use_the_parallel_renderer() {
    let src = workspace().join("raytracer/src");
    let mods = read_crate(&src);
    let e = edges(&mods);
    let physics = [
        "geometry", "scene", "accel", "render", "modifier", "cal", "image",
    ];
    let mut bad = Vec::new();
    for ((a, b), line) in &e {
        let (Some(ta), Some(tb)) = (a.first(), b.first()) else {
            continue;
        };
        if physics.contains(&ta.as_str())
            && !physics.contains(&tb.as_str())
            && !["error", "input"].contains(&tb.as_str())
        {
            bad.push(format!(
                "{} uses {} ({}:{line})",
                name(a),
                name(b),
                mods[a].file.display()
            ));
        }
    }
    for (me, m) in &mods {
        if m.test_only || !me.first().is_some_and(|t| physics.contains(&t.as_str())) {
            continue;
        }
        let text = std::fs::read_to_string(&m.file).unwrap();
        let mut toks = tokenize(&text);
        strip_test_items(&mut toks);
        if let Some((_, line)) = toks.iter().find(|(t, _)| ident(t) == Some("hybrid_sched")) {
            bad.push(format!(
                "{} uses the framework ({}:{line})",
                name(me),
                m.file.display()
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn no_oversized_files() {
    let mut big = Vec::new();
    for dir in ["framework/src", "raytracer/src/parallel"] {
        let mut stack = vec![workspace().join(dir)];
        while let Some(d) = stack.pop() {
            for entry in std::fs::read_dir(&d).unwrap() {
                let p = entry.unwrap().path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    let lines = std::fs::read_to_string(&p).unwrap().lines().count();
                    if lines > 600 {
                        big.push(format!("{}: {lines} lines", p.display()));
                    }
                }
            }
        }
    }
    assert!(big.is_empty(), "files over 600 lines:\n{}", big.join("\n"));
}

/// The checker finds a loop it is shown, through a re-export, and not one
/// that only a test module or a comment makes.
#[test]
fn the_checker_sees_loops() {
    let dir = std::env::temp_dir().join(format!("layout-check-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let write = |p: &str, s: &str| {
        let f = dir.join(p);
        std::fs::create_dir_all(f.parent().unwrap()).unwrap();
        std::fs::write(f, s).unwrap();
    };
    write("lib.rs", "pub mod a;\npub mod b;\n#[cfg(test)]\nmod t;\n");
    write("a/mod.rs", "mod x;\npub use x::X;\npub fn f() {}\n");
    write("a/x.rs", "pub struct X;\nfn g() { crate::b::h(); }\n");
    write(
        "b.rs",
        "// crate::a::X in a comment\npub fn h() { let _ = \"crate::a::X\"; }\n",
    );
    write("t.rs", "use crate::a::X;\nuse crate::b;\n");
    assert!(
        import_loops(&dir, true).is_empty(),
        "{:?}",
        import_loops(&dir, true)
    );
    write("b.rs", "use crate::a::X;\npub fn h() {}\n");
    let loops = import_loops(&dir, true);
    assert_eq!(loops.len(), 2, "{loops:?}");
    assert!(
        loops[0].contains("a::x uses b") && loops[0].contains("b uses a::x"),
        "{}",
        loops[0]
    );
    assert!(loops[1].contains("between modules {a, b}"), "{}", loops[1]);
    // A child using its folder's mod.rs, which uses the child: a loop.
    write("b.rs", "pub fn h() {}\n");
    write(
        "a/mod.rs",
        "mod x;\npub use x::X;\npub fn f() -> x::X { x::X }\n",
    );
    write("a/x.rs", "pub struct X;\nfn g() { super::f(); }\n");
    let loops = import_loops(&dir, true);
    assert_eq!(loops.len(), 1, "{loops:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

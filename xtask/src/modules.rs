//! `cargo xtask check-modules`: three rules about the source tree that the
//! compiler does not enforce.
//!
//! 1. **Folders are layers: no import cycle between modules.** In each crate's
//!    `src/`, every `crate::…`, `super::…` and `self::…` path (in `use`
//!    trees, nested groups included, and inline in code, unit tests
//!    included) is an edge from the file's module to the deepest file module
//!    the path names (`crate::data::spec::X` → `data::spec` when
//!    `src/data/spec.rs` exists, else `data`). A module and its own
//!    submodules may use each other (a `mod.rs` re-exports its children; a
//!    child uses its parent's types; a path through the crate root's
//!    re-exports, `crate::Model`, names the root and is not counted). Every
//!    other edge is counted between the two modules it joins right below
//!    their common parent: `a::x → b::y` is an edge `a → b` between two
//!    top-level modules (each folder one node, whatever its files import),
//!    `a::x → a::y` one between two children of `a`. At each level the strongly connected components of those edges
//!    are the cycles: two modules that import each other, or three or more
//!    that reach each other round a longer loop. Each is reported with its
//!    modules and, per edge inside it, the files whose imports make the edge.
//!    Cycles that were there when the check was introduced are listed in
//!    `xtask/known-module-cycles.txt`: those are reported, every other one
//!    fails the check, and so does a listed one that is gone (remove its line).
//! 2. **Every test file is compiled.** A crate with `tests/it.rs` has one
//!    integration-test binary (`autotests = false`): each `tests/<name>.rs`
//!    and `tests/<name>/mod.rs` must be declared `mod <name>;` in `tests/it.rs`,
//!    or cargo would silently skip it.
//! 3. **No unit test goes unrun.** A target whose manifest says `test = false`
//!    gets no test harness (CI builds fewer binaries): the package's `src/`
//!    then holds no `#[test]` and no `#[cfg(test)]`, which would never run.
//!
//! Comments, strings and character literals are skipped; paths are read from
//! the tokens, so `use crate::{a::X, b::{c, d}};` gives edges to `a`, `b::c`
//! and `b::d` (or `b` where those are items, not files).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::root;

/// The cycles present when this check was introduced, one `crate: a, b, …` per line.
const KNOWN: &str = "xtask/known-module-cycles.txt";

/// Every package of the repository (its own workspace or not), by directory.
fn packages(dir: &Path, depth: usize, out: &mut Vec<(String, PathBuf)>) {
    let manifest = dir.join("Cargo.toml");
    if let Ok(text) = std::fs::read_to_string(&manifest) {
        if let Some(name) = package_name(&text) {
            out.push((name, dir.to_path_buf()));
        }
    }
    if depth == 0 {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut dirs: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .filter(|p| {
            let n = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            !n.starts_with('.') && n != "target" && n != "src"
        })
        .collect();
    dirs.sort();
    for d in dirs {
        packages(&d, depth - 1, out);
    }
}

/// `name` of the `[package]` table of a manifest.
fn package_name(manifest: &str) -> Option<String> {
    let mut in_package = false;
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            in_package = line == "[package]";
        } else if in_package {
            if let Some(v) = line.strip_prefix("name") {
                let v = v.trim_start().strip_prefix('=')?.trim();
                return Some(v.trim_matches('"').to_string());
            }
        }
    }
    None
}

/// Every `.rs` file below `dir`, sorted.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for p in paths {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The module a file of `src/` is: `lib.rs`/`main.rs` the crate root (empty),
/// `a/mod.rs` and `a.rs` `a`, `a/b.rs` `a::b`. `None` for `src/bin/` (each its own crate).
fn module_of(src: &Path, file: &Path) -> Option<Vec<String>> {
    let rel = file.strip_prefix(src).ok()?;
    let mut parts: Vec<String> = rel
        .iter()
        .map(|c| c.to_string_lossy().into_owned())
        .collect();
    if parts.first().is_some_and(|p| p == "bin") {
        return None;
    }
    let last = parts.pop()?;
    let stem = last.strip_suffix(".rs")?;
    if parts.is_empty() && (stem == "lib" || stem == "main") {
        return Some(Vec::new());
    }
    if stem != "mod" {
        parts.push(stem.to_string());
    }
    Some(parts)
}

#[derive(Debug, PartialEq)]
enum Tok {
    Ident(String),
    Colons,
    Open,
    Close,
    Comma,
    Semi,
    Other,
}

/// Rust source as the tokens this check needs: identifiers, `::`, braces,
/// commas and semicolons; comments, strings, chars and everything else are
/// dropped (or `Other`).
fn tokens(src: &str) -> Vec<Tok> {
    let b = src.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_whitespace() {
            i += 1;
        } else if c == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if c == b'/' && b.get(i + 1) == Some(&b'*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
                    depth += 1;
                    i += 2;
                } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if c == b'"' || ((c == b'r' || c == b'b') && raw_or_byte_string(b, i).is_some()) {
            i = skip_string(b, i);
            out.push(Tok::Other);
        } else if c == b'\'' {
            // A char literal ('x', '\n', '\u{..}') or a lifetime ('a).
            if b.get(i + 1) == Some(&b'\\') {
                i += 2;
                while i < b.len() && b[i] != b'\'' {
                    i += 1;
                }
                i += 1;
            } else {
                let ch_len = src[i + 1..].chars().next().map_or(1, char::len_utf8);
                if b.get(i + 1 + ch_len) == Some(&b'\'') {
                    i += 2 + ch_len;
                } else {
                    i += 1;
                }
            }
            out.push(Tok::Other);
        } else if c.is_ascii_alphabetic() || c == b'_' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            let word = &src[start..i];
            // r#ident
            if word == "r" && b.get(i) == Some(&b'#') {
                i += 1;
                continue;
            }
            out.push(Tok::Ident(word.to_string()));
        } else if c == b':' && b.get(i + 1) == Some(&b':') {
            out.push(Tok::Colons);
            i += 2;
        } else {
            out.push(match c {
                b'{' => Tok::Open,
                b'}' => Tok::Close,
                b',' => Tok::Comma,
                b';' => Tok::Semi,
                _ => Tok::Other,
            });
            i += if c.is_ascii() {
                1
            } else {
                src[i..].chars().next().map_or(1, char::len_utf8)
            };
        }
    }
    out
}

/// At `i`: the number of `#` of a raw string (`r"`, `r#"`, `br"`), or 0 for `b"`.
fn raw_or_byte_string(b: &[u8], i: usize) -> Option<usize> {
    if i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_') {
        return None;
    }
    let mut j = i;
    if b[j] == b'b' {
        j += 1;
        if b.get(j) == Some(&b'"') {
            return Some(0);
        }
    }
    if b.get(j) != Some(&b'r') {
        return None;
    }
    j += 1;
    let hashes = b[j..].iter().take_while(|&&c| c == b'#').count();
    (b.get(j + hashes) == Some(&b'"')).then_some(hashes)
}

/// Index after the string literal starting at `i`.
fn skip_string(b: &[u8], i: usize) -> usize {
    if b[i] == b'"' || (b[i] == b'b' && b.get(i + 1) == Some(&b'"')) {
        let mut j = if b[i] == b'"' { i + 1 } else { i + 2 };
        while j < b.len() {
            match b[j] {
                b'\\' => j += 2,
                b'"' => return j + 1,
                _ => j += 1,
            }
        }
        return j;
    }
    let hashes = raw_or_byte_string(b, i).unwrap_or(0);
    let mut j = i;
    while b[j] != b'"' {
        j += 1;
    }
    j += 1;
    while j < b.len() {
        if b[j] == b'"'
            && b[j + 1..]
                .iter()
                .take(hashes)
                .filter(|&&c| c == b'#')
                .count()
                == hashes
        {
            return j + 1 + hashes;
        }
        j += 1;
    }
    j
}

/// Reads a path tree after `crate::` (or `super::`…) at `i`: `a::b`, `a::{b, c::d}`, `*`.
/// Appends every full path (prefix included) to `out`; returns the index after the tree.
fn path_tree(t: &[Tok], mut i: usize, prefix: &[String], out: &mut Vec<Vec<String>>) -> usize {
    let mut path = prefix.to_vec();
    loop {
        match t.get(i) {
            Some(Tok::Ident(id)) => {
                path.push(id.clone());
                i += 1;
                if t.get(i) == Some(&Tok::Colons) {
                    i += 1;
                    continue;
                }
                out.push(path);
                return i;
            }
            Some(Tok::Open) => {
                i += 1;
                loop {
                    match t.get(i) {
                        Some(Tok::Close) => return i + 1,
                        Some(Tok::Comma) => i += 1,
                        None => return i,
                        Some(_) => {
                            let before = i;
                            i = path_tree(t, i, &path, out);
                            if i == before {
                                i += 1;
                            }
                        }
                    }
                }
            }
            _ => {
                out.push(path);
                return i;
            }
        }
    }
}

/// The module paths `file` (module `me`) refers to, each resolved to an absolute
/// module path (crate root = empty); `self` and `super` resolved against the
/// inline module the path appears in.
fn references(src: &str, me: &[String]) -> Vec<Vec<String>> {
    let t = tokens(src);
    let mut out = Vec::new();
    // Inline modules (`mod tests { … }`): names and the brace depth they close at.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let mut i = 0;
    while i < t.len() {
        match &t[i] {
            Tok::Open => depth += 1,
            Tok::Close => {
                depth = depth.saturating_sub(1);
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
            }
            Tok::Ident(kw) if kw == "mod" => {
                if let (Some(Tok::Ident(name)), Some(Tok::Open)) = (t.get(i + 1), t.get(i + 2)) {
                    inline.push((name.clone(), depth));
                }
            }
            Tok::Ident(head)
                if (head == "crate" || head == "super" || head == "self")
                    && t.get(i + 1) == Some(&Tok::Colons)
                    // `crate::x` inside a longer path (`other::crate::x`) does not occur;
                    // `pub(in crate::a)` is a visibility, not a use.
                    && !matches!(i.checked_sub(1).map(|p| &t[p]), Some(Tok::Colons))
                    && !matches!(i.checked_sub(1).map(|p| &t[p]), Some(Tok::Ident(w)) if w == "in") =>
            {
                let mut here: Vec<String> = me.to_vec();
                here.extend(inline.iter().map(|(n, _)| n.clone()));
                let mut base = if head == "crate" { Vec::new() } else { here };
                let mut j = i + 2;
                if head == "super" {
                    base.pop();
                    // super::super::…
                    while matches!(t.get(j), Some(Tok::Ident(w)) if w == "super")
                        && t.get(j + 1) == Some(&Tok::Colons)
                    {
                        base.pop();
                        j += 2;
                    }
                }
                let mut paths = Vec::new();
                i = path_tree(&t, j, &base, &mut paths);
                out.extend(paths);
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// The deepest module of `modules` that `path` starts with (the crate root when none).
fn resolve<'a>(path: &[String], modules: &'a BTreeSet<Vec<String>>) -> &'a [String] {
    (0..=path.len())
        .rev()
        .find_map(|n| modules.get(&path[..n]))
        .map_or(&[], Vec::as_slice)
}

/// Whether `a` is `b` or contains it.
fn contains(a: &[String], b: &[String]) -> bool {
    b.starts_with(a)
}

/// One import cycle of a crate: sibling modules (children of one module, the
/// crate root for top-level ones; a folder counts as one node) that reach
/// each other through their imports.
#[derive(Debug, PartialEq)]
struct Cycle {
    /// The modules, full paths (`a::b`), sorted.
    modules: Vec<String>,
    /// Each edge inside the cycle, `(from, to, files)`: the files below
    /// `from` whose imports reach below `to`, sorted.
    edges: Vec<(String, String, Vec<PathBuf>)>,
}

impl Cycle {
    /// The cycle as `xtask/known-module-cycles.txt` lists it (without the crate).
    fn line(&self) -> String {
        self.modules.join(", ")
    }
}

/// The strongly connected components of `edges` with more than one node,
/// each sorted (Tarjan's algorithm; the graphs are a crate's modules, small).
fn components(edges: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    let names: Vec<&String> = edges
        .iter()
        .flat_map(|(a, bs)| std::iter::once(a).chain(bs))
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let id = |n: &String| names.binary_search(&n).unwrap_or(0);
    let adj: Vec<Vec<usize>> = names
        .iter()
        .map(|n| edges.get(*n).into_iter().flatten().map(id).collect())
        .collect();
    struct Tarjan {
        adj: Vec<Vec<usize>>,
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on_stack: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<usize>>,
    }
    impl Tarjan {
        fn visit(&mut self, v: usize) {
            self.index[v] = Some(self.next);
            self.low[v] = self.next;
            self.next += 1;
            self.stack.push(v);
            self.on_stack[v] = true;
            for k in 0..self.adj[v].len() {
                let w = self.adj[v][k];
                match self.index[w] {
                    None => {
                        self.visit(w);
                        self.low[v] = self.low[v].min(self.low[w]);
                    }
                    Some(iw) if self.on_stack[w] => self.low[v] = self.low[v].min(iw),
                    Some(_) => {}
                }
            }
            if Some(self.low[v]) == self.index[v] {
                let mut comp = Vec::new();
                while let Some(w) = self.stack.pop() {
                    self.on_stack[w] = false;
                    comp.push(w);
                    if w == v {
                        break;
                    }
                }
                self.out.push(comp);
            }
        }
    }
    let n = names.len();
    let mut t = Tarjan {
        adj,
        index: vec![None; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: Vec::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if t.index[v].is_none() {
            t.visit(v);
        }
    }
    let mut out: Vec<Vec<String>> = t
        .out
        .into_iter()
        .filter(|c| c.len() > 1)
        .map(|c| {
            let mut c: Vec<String> = c.into_iter().map(|i| names[i].clone()).collect();
            c.sort();
            c
        })
        .collect();
    out.sort();
    out
}

/// The import cycles of one crate's `src/` (rule 1), at every level: between
/// its top-level modules (a folder is one node), then between the children
/// of each folder.
fn crate_cycles(src: &Path) -> Vec<Cycle> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let by_file: Vec<(Vec<String>, &PathBuf)> = files
        .iter()
        .filter_map(|f| module_of(src, f).map(|m| (m, f)))
        .collect();
    let modules: BTreeSet<Vec<String>> = by_file.iter().map(|(m, _)| m.clone()).collect();
    // Per parent module: the edges between its children, each with its files.
    type Edges = BTreeMap<(String, String), BTreeSet<PathBuf>>;
    let mut levels: BTreeMap<Vec<String>, Edges> = BTreeMap::new();
    for (me, file) in &by_file {
        let text = std::fs::read_to_string(file).unwrap_or_default();
        for path in references(&text, me) {
            let to = resolve(&path, &modules);
            if contains(me, to) || contains(to, me) {
                continue;
            }
            // Neither contains the other: they differ right below their common parent.
            let common = me.iter().zip(to).take_while(|(a, b)| a == b).count();
            let parent = me[..common].to_vec();
            let node = |m: &[String]| m[..=common].join("::");
            levels
                .entry(parent)
                .or_default()
                .entry((node(me), node(to)))
                .or_default()
                .insert((*file).clone());
        }
    }
    let mut cycles = Vec::new();
    for edges in levels.values() {
        let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b) in edges.keys() {
            graph.entry(a.clone()).or_default().insert(b.clone());
        }
        for comp in components(&graph) {
            let inside = |m: &String| comp.binary_search(m).is_ok();
            let edges = edges
                .iter()
                .filter(|((a, b), _)| inside(a) && inside(b))
                .map(|((a, b), f)| (a.clone(), b.clone(), f.iter().cloned().collect()))
                .collect();
            cycles.push(Cycle {
                modules: comp,
                edges,
            });
        }
    }
    cycles
}

/// Rule 2 for one package: the `tests/` files `tests/it.rs` does not declare.
fn undeclared_tests(dir: &Path) -> Vec<String> {
    let tests = dir.join("tests");
    let Ok(root) = std::fs::read_to_string(tests.join("it.rs")) else {
        return Vec::new();
    };
    let declared: BTreeSet<String> = root
        .lines()
        .filter_map(|l| l.trim().strip_prefix("mod "))
        .filter_map(|l| l.strip_suffix(';'))
        .map(str::to_string)
        .collect();
    let mut missing = Vec::new();
    let Ok(entries) = std::fs::read_dir(&tests) else {
        return missing;
    };
    for p in entries.filter_map(|e| e.ok().map(|e| e.path())) {
        let name = if p.extension().is_some_and(|e| e == "rs") {
            p.file_stem()
        } else if p.join("mod.rs").is_file() {
            p.file_name()
        } else {
            None
        };
        let Some(name) = name.and_then(|n| n.to_str()) else {
            continue;
        };
        if name != "it" && !declared.contains(name) {
            missing.push(p.display().to_string());
        }
    }
    missing.sort();
    missing
}

/// Rule 3 for one package: with `test = false` in its manifest, the `src/` files that
/// hold a unit test (`#[test]` or `#[cfg(test)]`).
fn unrun_unit_tests(dir: &Path) -> Vec<String> {
    let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap_or_default();
    let no_harness = manifest
        .lines()
        .any(|l| l.split('#').next().unwrap_or("").replace(' ', "") == "test=false");
    if !no_harness {
        return Vec::new();
    }
    let mut files = Vec::new();
    rust_files(&dir.join("src"), &mut files);
    files
        .into_iter()
        .filter(|f| {
            std::fs::read_to_string(f)
                .is_ok_and(|t| t.contains("#[test]") || t.contains("#[cfg(test)]"))
        })
        .map(|f| f.display().to_string())
        .collect()
}

/// `cargo xtask check-modules`.
pub(crate) fn check_modules() -> i32 {
    let root = root();
    let mut pkgs = Vec::new();
    packages(&root, 3, &mut pkgs);
    let known_text = std::fs::read_to_string(root.join(KNOWN)).unwrap_or_default();
    let known: BTreeSet<&str> = known_text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .collect();
    let mut found = BTreeSet::new();
    let mut failed = false;
    for (name, dir) in &pkgs {
        let rel = dir.strip_prefix(&root).unwrap_or(dir).display().to_string();
        let cycles = crate_cycles(&dir.join("src"));
        for c in &cycles {
            let line = format!("{name}: {}", c.line());
            let is_known = known.contains(line.as_str());
            if !is_known {
                failed = true;
            }
            println!(
                "check-modules: {name}: import cycle of {} modules: {}{}",
                c.modules.len(),
                c.line(),
                if is_known {
                    " (known, listed in xtask/known-module-cycles.txt)"
                } else {
                    "  <- NEW CYCLE"
                }
            );
            for (a, b, files) in &c.edges {
                let files: Vec<String> = files
                    .iter()
                    .map(|f| f.strip_prefix(&root).unwrap_or(f).display().to_string())
                    .collect();
                println!("check-modules:     {a} -> {b}: {}", files.join(", "));
            }
            found.insert(line);
        }
        let missing = undeclared_tests(dir);
        for m in &missing {
            println!("check-modules: {m} is not a module of {rel}/tests/it.rs: it is never compiled  <- FAIL");
        }
        failed |= !missing.is_empty();
        let unrun = unrun_unit_tests(dir);
        for f in &unrun {
            println!("check-modules: {f} holds unit tests but {rel}/Cargo.toml says `test = false`: they never run  <- FAIL");
        }
        failed |= !unrun.is_empty();
        println!(
            "check-modules: {name:<20} ({rel}) {} import cycle(s){}",
            cycles.len(),
            if dir.join("tests/it.rs").is_file() {
                ", every tests/ file in tests/it.rs"
            } else {
                ""
            }
        );
    }
    for k in &known {
        if !found.contains(*k) {
            println!("check-modules: {k}: listed in {KNOWN} but gone: remove the line  <- FAIL");
            failed = true;
        }
    }
    println!("check-modules: {}", if failed { "FAIL" } else { "ok" });
    i32::from(failed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(p: &[&str]) -> Vec<String> {
        p.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn use_trees_inline_paths_super_and_self() {
        let src = r#"
            use crate::{a::X, b::{c, d::Y}};
            use super::sib::Z; // crate::gone in a comment
            fn f() { let _ = crate::e::f(); let _ = "crate::in_a_string"; let _c = 'x'; }
            pub(in crate::vis) struct S<'a>(&'a u8);
            mod tests { use super::*; use self::inner::W; }
        "#;
        let refs = references(src, &s(&["m", "n"]));
        assert_eq!(
            refs,
            vec![
                s(&["a", "X"]),
                s(&["b", "c"]),
                s(&["b", "d", "Y"]),
                s(&["m", "sib", "Z"]),
                s(&["e", "f"]),
                s(&["m", "n"]),
                s(&["m", "n", "tests", "inner", "W"]),
            ]
        );
    }

    #[test]
    fn resolves_to_the_deepest_file_module() {
        let modules: BTreeSet<Vec<String>> = [s(&[]), s(&["data"]), s(&["data", "spec"])]
            .into_iter()
            .collect();
        assert_eq!(
            resolve(&s(&["data", "spec", "X"]), &modules),
            s(&["data", "spec"])
        );
        assert_eq!(resolve(&s(&["data", "Window"]), &modules), s(&["data"]));
        assert_eq!(resolve(&s(&["Error"]), &modules), s(&[]));
    }

    /// Writes `files` (path below `src/`, text) into a fresh crate and returns its cycles.
    fn cycles_of(tag: &str, files: &[(&str, &str)]) -> (PathBuf, Vec<Cycle>) {
        let dir = std::env::temp_dir().join(format!("xtask-modules-{tag}-{}", std::process::id()));
        let src = dir.join("src");
        for (path, text) in files {
            let f = src.join(path);
            std::fs::create_dir_all(f.parent().unwrap()).unwrap();
            std::fs::write(f, text).unwrap();
        }
        let cycles = crate_cycles(&src);
        let _ = std::fs::remove_dir_all(&dir);
        (src, cycles)
    }

    #[test]
    fn a_mutual_import_is_a_cycle_a_parent_and_child_are_not() {
        let (src, cycles) = cycles_of(
            "pair",
            &[
                ("lib.rs", "mod a; mod b; mod p;"),
                ("a.rs", "use crate::b::B; pub struct A;"),
                ("b.rs", "pub struct B(crate::a::A);"),
                ("p/mod.rs", "mod c; pub use c::C; pub struct P;"),
                ("p/c.rs", "pub struct C(super::P);"),
            ],
        );
        assert_eq!(
            cycles,
            vec![Cycle {
                modules: s(&["a", "b"]),
                edges: vec![
                    (String::from("a"), String::from("b"), vec![src.join("a.rs")]),
                    (String::from("b"), String::from("a"), vec![src.join("b.rs")]),
                ],
            }]
        );
        assert_eq!(cycles[0].line(), "a, b");
    }

    #[test]
    fn a_longer_cycle_through_folders_is_one_component_with_its_files() {
        // blob/model.rs -> engine -> planner -> blob/layer.rs: no two modules
        // import each other, but the three folders reach each other; `sink`
        // is imported by all and imports nothing back, so it is outside.
        let (src, cycles) = cycles_of(
            "loop",
            &[
                ("lib.rs", "mod blob; mod engine; mod planner; mod sink;"),
                ("blob/mod.rs", "mod layer; mod model;"),
                ("blob/layer.rs", "pub struct Layer; use crate::sink::S;"),
                (
                    "blob/model.rs",
                    "use crate::engine::E; use super::layer::Layer;",
                ),
                ("engine.rs", "use crate::planner::P; use crate::sink::S;"),
                ("planner.rs", "pub struct P(crate::blob::layer::Layer);"),
                ("sink.rs", "pub struct S;"),
            ],
        );
        assert_eq!(cycles.len(), 1);
        assert_eq!(cycles[0].line(), "blob, engine, planner");
        assert_eq!(
            cycles[0].edges,
            vec![
                (
                    String::from("blob"),
                    String::from("engine"),
                    vec![src.join("blob/model.rs")]
                ),
                (
                    String::from("engine"),
                    String::from("planner"),
                    vec![src.join("engine.rs")]
                ),
                (
                    String::from("planner"),
                    String::from("blob"),
                    vec![src.join("planner.rs")]
                ),
            ]
        );
    }

    #[test]
    fn cycles_inside_a_folder_are_found_among_its_children() {
        // Inside `f`, `x` and `y` import each other; seen from the crate
        // root `f` is one node and has no cycle with `g`, which only uses it.
        let (_, cycles) = cycles_of(
            "nested",
            &[
                ("lib.rs", "mod f; mod g;"),
                ("f/mod.rs", "mod x; mod y;"),
                ("f/x.rs", "use super::y::Y; pub struct X;"),
                ("f/y.rs", "pub struct Y(crate::f::x::X);"),
                ("g.rs", "use crate::f::x::X;"),
            ],
        );
        assert_eq!(cycles.len(), 1);
        assert_eq!(cycles[0].line(), "f::x, f::y");
    }

    #[test]
    fn a_test_file_missing_from_it_rs_is_reported() {
        let dir = std::env::temp_dir().join(format!("xtask-it-{}", std::process::id()));
        let tests = dir.join("tests");
        std::fs::create_dir_all(tests.join("common")).unwrap();
        std::fs::create_dir_all(tests.join("data")).unwrap();
        std::fs::write(tests.join("it.rs"), "//! docs\nmod a;\nmod common;\n").unwrap();
        for f in ["a.rs", "forgotten.rs", "common/mod.rs", "data/x.csv"] {
            std::fs::write(tests.join(f), "").unwrap();
        }
        let missing = undeclared_tests(&dir);
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(
            missing,
            vec![tests.join("forgotten.rs").display().to_string()]
        );
    }

    #[test]
    fn a_unit_test_under_test_false_is_reported() {
        let dir = std::env::temp_dir().join(format!("xtask-harness-{}", std::process::id()));
        let src = dir.join("src");
        std::fs::create_dir_all(&src).unwrap();
        std::fs::write(src.join("lib.rs"), "mod a;\npub fn f() {}\n").unwrap();
        std::fs::write(src.join("a.rs"), "#[cfg(test)]\nmod tests {}\n").unwrap();
        let manifest = |extra: &str| {
            let text = format!("[package]\nname = \"p\"\n\n[lib]\n{extra}\n");
            std::fs::write(dir.join("Cargo.toml"), text).unwrap();
            unrun_unit_tests(&dir)
        };
        let with_harness = manifest("");
        let commented = manifest("# test = false");
        let without = manifest("test = false");
        std::fs::write(src.join("a.rs"), "pub fn g() {}\n").unwrap();
        let without_tests = manifest("test = false");
        let _ = std::fs::remove_dir_all(&dir);
        assert!(with_harness.is_empty() && commented.is_empty() && without_tests.is_empty());
        assert_eq!(without, vec![src.join("a.rs").display().to_string()]);
    }
}

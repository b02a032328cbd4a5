//! No import cycles between the files of `backends` and `core`.
//!
//! Each `.rs` file is a module (`lib.rs` the root, `a/mod.rs` is `a`,
//! `a/b.rs` is `a::b`). The checker strips comments, literals and
//! `#[cfg(test)]` items (tests may use anything), expands every `use` tree,
//! and reads every path that names a module: `crate::…`, `super::…`,
//! `self::…`, or a name a `use` brought in. A path resolves to the deepest
//! module it names; when its next segment is a name that module imports with
//! a `use` (a re-export), the resolution follows the `use` to the file that
//! defines it, so a facade `mod.rs` that only re-exports its children is not
//! a dependency of theirs. File A depends on file B when a path in A resolves
//! into B. Any cycle in that graph fails the test, printed file by file.
//!
//! Deliberately small (no `syn`): it reads the source as tokens, which is
//! enough for the paths this workspace writes. Macros that build paths from
//! fragments would escape it; the workspace has none that name modules.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// Removes comments, string/char/byte literals and keeps everything else,
/// so braces and `::` inside literals or comments cannot mislead the parser.
fn strip(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = String::with_capacity(src.len());
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c == b'/' && b.get(i + 1) == Some(&b'/') {
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
            out.push(' ');
        } else if c == b'r' && matches!(b.get(i + 1), Some(b'#') | Some(b'"')) && !ident_byte(prev(b, i)) {
            // raw string r#"…"#
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&b'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&b'"') {
                out.push(c as char);
                i += 1;
                continue;
            }
            j += 1;
            loop {
                if j >= b.len() {
                    break;
                }
                if b[j] == b'"' && (0..hashes).all(|k| b.get(j + 1 + k) == Some(&b'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            out.push_str("\"\"");
            i = j;
        } else if c == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    i += 1;
                }
                i += 1;
            }
            i += 1;
            out.push_str("\"\"");
        } else if c == b'\'' {
            // a char literal ('x', '\n', '\u{..}') or a lifetime ('a)
            if b.get(i + 1) == Some(&b'\\') {
                let mut j = i + 2;
                while j < b.len() && b[j] != b'\'' {
                    j += 1;
                }
                i = j + 1;
                out.push_str("' '");
            } else if b.get(i + 2) == Some(&b'\'') {
                i += 3;
                out.push_str("' '");
            } else if let Some(ch) = src[i + 1..].chars().next()
                && src[i + 1 + ch.len_utf8()..].starts_with('\'')
            {
                i += 2 + ch.len_utf8();
                out.push_str("' '");
            } else {
                out.push('\'');
                i += 1;
            }
        } else {
            // copy one whole UTF-8 character
            let ch = src[i..].chars().next().unwrap();
            out.push(ch);
            i += ch.len_utf8();
        }
    }
    out
}

fn prev(b: &[u8], i: usize) -> u8 {
    if i == 0 { b' ' } else { b[i - 1] }
}

fn ident_byte(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Ident(String),
    Path, // ::
    Punct(char),
}

fn tokens(s: &str) -> Vec<Tok> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_whitespace() {
            i += 1;
        } else if ident_byte(c) || c >= 0x80 {
            let start = i;
            while i < b.len() && (ident_byte(b[i]) || b[i] >= 0x80) {
                i += 1;
            }
            let word = &s[start..i];
            let word = word.strip_prefix("r#").unwrap_or(word);
            out.push(Tok::Ident(word.to_string()));
        } else if c == b':' && b.get(i + 1) == Some(&b':') {
            out.push(Tok::Path);
            i += 2;
        } else {
            out.push(Tok::Punct(c as char));
            i += 1;
        }
    }
    out
}

/// Drops test-only items (`#[cfg(test)]`, `#[cfg(all(test, …))]`): the
/// attribute, then everything up to the end of the item (a `;` at depth 0 or
/// a balanced `{…}`).
fn drop_test_items(t: Vec<Tok>) -> Vec<Tok> {
    let mut out = Vec::with_capacity(t.len());
    let mut i = 0;
    let id = |x: &Tok, w: &str| matches!(x, Tok::Ident(s) if s == w);
    while i < t.len() {
        let cfg = t[i] == Tok::Punct('#')
            && t.get(i + 1) == Some(&Tok::Punct('['))
            && t.get(i + 2).is_some_and(|x| id(x, "cfg"))
            && t.get(i + 3) == Some(&Tok::Punct('('));
        // the attribute's tokens, up to its closing `]`
        let end = if cfg { (i..t.len()).find(|&j| t[j] == Tok::Punct(']')) } else { None };
        let test_only = end.is_some_and(|e| {
            let attr = &t[i + 4..e];
            attr.iter().any(|x| id(x, "test")) && !attr.iter().any(|x| id(x, "not") || id(x, "any"))
        });
        if !test_only {
            out.push(t[i].clone());
            i += 1;
            continue;
        }
        i = end.unwrap_or(i) + 1;
        let mut depth = 0;
        while i < t.len() {
            match t[i] {
                Tok::Punct('{') => depth += 1,
                Tok::Punct('}') => {
                    depth -= 1;
                    if depth == 0 {
                        i += 1;
                        break;
                    }
                }
                Tok::Punct(';') if depth == 0 => {
                    i += 1;
                    break;
                }
                _ => {}
            }
            i += 1;
        }
    }
    out
}

/// One source file: its module path and the paths it names.
struct Module {
    file: PathBuf,
    /// `use` imports: local name → absolute path (segments, `*` for a glob).
    uses: BTreeMap<String, Vec<String>>,
    /// Absolute paths named outside `use` (and glob imports).
    refs: Vec<Vec<String>>,
}

/// Makes a path absolute: `crate::`, `super::`, `self::` are resolved against
/// `here`, a first segment that is a child module of `here` too; anything
/// else (another crate, a local item, a primitive) returns `None`.
fn absolute(here: &[String], path: &[String], modules: &BTreeSet<Vec<String>>) -> Option<Vec<String>> {
    let mut base: Vec<String>;
    let mut rest = path;
    match path.first().map(String::as_str) {
        Some("crate") => {
            base = Vec::new();
            rest = &path[1..];
        }
        Some("self") => {
            base = here.to_vec();
            rest = &path[1..];
        }
        Some("super") => {
            base = here.to_vec();
            while rest.first().map(String::as_str) == Some("super") {
                base.pop()?;
                rest = &rest[1..];
            }
        }
        Some(first) => {
            let mut child = here.to_vec();
            child.push(first.to_string());
            if !modules.contains(&child) {
                return None;
            }
            base = here.to_vec();
        }
        None => return None,
    }
    base.extend(rest.iter().cloned());
    Some(base)
}

/// Expands a `use` tree starting at `t[i]` (after `use`) into (prefix, alias) pairs.
fn use_tree(t: &[Tok], i: &mut usize, prefix: &[String], out: &mut Vec<(Vec<String>, String)>) {
    let mut path = prefix.to_vec();
    loop {
        match t.get(*i) {
            Some(Tok::Ident(s)) => {
                *i += 1;
                if t.get(*i) == Some(&Tok::Path) {
                    path.push(s.clone());
                    *i += 1;
                    continue;
                }
                if s == "self" {
                    let alias = path.last().cloned().unwrap_or_default();
                    out.push((path.clone(), alias));
                    return;
                }
                path.push(s.clone());
                let mut alias = s.clone();
                if matches!(t.get(*i), Some(Tok::Ident(a)) if a == "as") {
                    if let Some(Tok::Ident(a)) = t.get(*i + 1) {
                        alias = a.clone();
                    }
                    *i += 2;
                }
                out.push((path, alias));
                return;
            }
            Some(Tok::Punct('*')) => {
                *i += 1;
                path.push("*".into());
                out.push((path, "*".into()));
                return;
            }
            Some(Tok::Punct('{')) => {
                *i += 1;
                loop {
                    match t.get(*i) {
                        Some(Tok::Punct('}')) => {
                            *i += 1;
                            return;
                        }
                        Some(Tok::Punct(',')) => *i += 1,
                        None => return,
                        _ => use_tree(t, i, &path, out),
                    }
                }
            }
            Some(Tok::Path) => *i += 1, // a leading `::`
            _ => return,
        }
    }
}

fn module_path(root: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(root).unwrap();
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    let last = parts.pop().unwrap();
    match last.as_str() {
        "lib.rs" | "main.rs" | "mod.rs" => {}
        other => parts.push(other.trim_end_matches(".rs").to_string()),
    }
    parts
}

fn rs_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rs_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

fn parse(root: &Path, file: &Path, modules: &BTreeSet<Vec<String>>) -> (Vec<String>, Module) {
    let here = module_path(root, file);
    let src = fs::read_to_string(file).unwrap();
    let t = drop_test_items(tokens(&strip(&src)));
    let mut uses = BTreeMap::new();
    let mut refs = Vec::new();
    let mut raw_paths: Vec<Vec<String>> = Vec::new();
    let mut i = 0;
    while i < t.len() {
        if matches!(&t[i], Tok::Ident(s) if s == "use") && !(i > 0 && t[i - 1] == Tok::Path) {
            i += 1;
            let mut pairs = Vec::new();
            use_tree(&t, &mut i, &[], &mut pairs);
            for (path, alias) in pairs {
                let Some(abs) = absolute(&here, &path, modules) else {
                    continue;
                };
                if alias == "*" {
                    refs.push(abs[..abs.len() - 1].to_vec());
                } else {
                    uses.insert(alias, abs);
                }
            }
            continue;
        }
        // a path expression: ident (:: ident)+
        if let Tok::Ident(first) = &t[i]
            && t.get(i + 1) == Some(&Tok::Path)
            && !(i > 0 && t[i - 1] == Tok::Path)
        {
            let mut path = vec![first.clone()];
            let mut j = i + 1;
            while t.get(j) == Some(&Tok::Path) {
                match t.get(j + 1) {
                    Some(Tok::Ident(s)) => {
                        path.push(s.clone());
                        j += 2;
                    }
                    _ => {
                        j += 1;
                        break;
                    }
                }
            }
            raw_paths.push(path);
            i = j;
            continue;
        }
        i += 1;
    }
    for path in raw_paths {
        if let Some(target) = uses.get(&path[0]) {
            let mut abs = target.clone();
            abs.extend(path[1..].iter().cloned());
            refs.push(abs);
        } else if let Some(abs) = absolute(&here, &path, modules) {
            refs.push(abs);
        }
    }
    // a single name imported by `use` and used bare is a dependency too
    for target in uses.values() {
        refs.push(target.clone());
    }
    (here, Module { file: file.to_path_buf(), uses, refs })
}

/// The file a path lands in, following re-exports.
fn resolve(mods: &BTreeMap<Vec<String>, Module>, path: &[String], depth: usize) -> Option<Vec<String>> {
    let mut k = path.len();
    while !mods.contains_key(&path[..k]) {
        if k == 0 {
            return None;
        }
        k -= 1;
    }
    let m = &path[..k];
    if depth < 16
        && let Some(next) = path.get(k)
        && let Some(target) = mods[m].uses.get(next)
    {
        let mut followed = target.clone();
        followed.extend(path[k + 1..].iter().cloned());
        if followed != path {
            return resolve(mods, &followed, depth + 1).or_else(|| Some(m.to_vec()));
        }
    }
    Some(m.to_vec())
}

/// Each file's module path and the files it uses.
type Graph = BTreeMap<Vec<String>, BTreeSet<Vec<String>>>;

fn graph(src: &Path) -> (BTreeMap<Vec<String>, Module>, Graph) {
    let mut files = Vec::new();
    rs_files(src, &mut files);
    let modules: BTreeSet<_> = files.iter().map(|f| module_path(src, f)).collect();
    let mods: BTreeMap<_, _> = files.iter().map(|f| parse(src, f, &modules)).collect();
    let mut edges: Graph = BTreeMap::new();
    for (name, m) in &mods {
        let out = edges.entry(name.clone()).or_default();
        for r in &m.refs {
            // A file's own ancestors (`mod.rs` files, `lib.rs`) hold the
            // items its module shares: using them is not a layer edge.
            if let Some(target) = resolve(&mods, r, 0)
                && !name.starts_with(&target)
            {
                out.insert(target);
            }
        }
    }
    (mods, edges)
}

/// Every strongly connected component with more than one file (Tarjan).
fn cycles(edges: &Graph) -> Vec<Vec<Vec<String>>> {
    struct State<'a> {
        edges: &'a Graph,
        index: BTreeMap<&'a Vec<String>, usize>,
        low: BTreeMap<&'a Vec<String>, usize>,
        stack: Vec<&'a Vec<String>>,
        on: BTreeSet<&'a Vec<String>>,
        out: Vec<Vec<Vec<String>>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a Vec<String>) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on.insert(v);
        for w in s.edges.get(v).into_iter().flatten() {
            if !s.edges.contains_key(w) {
                continue;
            }
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if s.on.contains(w) {
                let iw = s.index[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut comp = Vec::new();
            loop {
                let w = s.stack.pop().unwrap();
                s.on.remove(w);
                comp.push(w.clone());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                s.out.push(comp);
            }
        }
    }
    let mut s = State {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out
}

/// One shortest cycle through `start` inside `comp`, for the message.
fn one_cycle(edges: &Graph, comp: &[Vec<String>], start: &Vec<String>) -> Vec<Vec<String>> {
    let inside: BTreeSet<_> = comp.iter().collect();
    let mut prev: BTreeMap<&Vec<String>, &Vec<String>> = BTreeMap::new();
    let mut queue = std::collections::VecDeque::from([start]);
    while let Some(v) = queue.pop_front() {
        for w in &edges[v] {
            if w == start {
                let mut path = vec![v.clone()];
                let mut x = v;
                while x != start {
                    x = prev[x];
                    path.push(x.clone());
                }
                path.reverse();
                path.push(start.clone());
                return path;
            }
            if inside.contains(w) && !prev.contains_key(w) {
                prev.insert(w, v);
                queue.push_back(w);
            }
        }
    }
    vec![start.clone()]
}

fn name(m: &[String]) -> String {
    if m.is_empty() { "crate".into() } else { m.join("::") }
}

fn check(krate: &str) {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(krate).join("src");
    let (mods, edges) = graph(&src);
    assert!(mods.len() > 5, "read {} files from {}", mods.len(), src.display());
    let found = cycles(&edges);
    let mut msg = String::new();
    for comp in &found {
        msg += &format!("\n{krate}: {} files in one cycle:", comp.len());
        for f in comp {
            let within: Vec<String> = edges[f].iter().filter(|t| comp.contains(t)).map(|t| name(t)).collect();
            let file = mods[f].file.strip_prefix(&src).unwrap().display();
            msg += &format!("\n  {file} uses {}", within.join(", "));
        }
        let c = one_cycle(&edges, comp, &comp[0]);
        msg += &format!("\n  e.g. {}", c.iter().map(|m| name(m)).collect::<Vec<_>>().join(" -> "));
    }
    assert!(found.is_empty(), "import cycles:{msg}");
}

#[test]
fn backends_has_no_import_cycles() {
    check("backends");
}

#[test]
fn core_has_no_import_cycles() {
    check("core");
}

/// The checker itself finds a cycle, follows re-exports and ignores tests.
#[test]
fn checker_sees_cycles_through_reexports_and_skips_tests() {
    let dir = std::env::temp_dir().join(format!("itgfx-layers-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(dir.join("a")).unwrap();
    fs::write(dir.join("lib.rs"), "pub mod a; pub mod b; pub mod c;").unwrap();
    // a/mod.rs only re-exports: not a node anyone depends on
    fs::write(dir.join("a/mod.rs"), "mod x; pub use x::X; // use crate::c::Z;\n").unwrap();
    fs::write(dir.join("a/x.rs"), "pub struct X; fn f() { let _ = \"crate::c::Z\"; crate::b::g(); }").unwrap();
    fs::write(dir.join("b.rs"), "use crate::c; pub fn g() { c::h(); }").unwrap();
    fs::write(
        dir.join("c.rs"),
        "pub fn h() {}\n#[cfg(all(test, unix))]\nmod tests { use crate::a::X; }\n#[cfg(test)]\nuse crate::a::X;\n",
    )
    .unwrap();
    let (_, edges) = graph(&dir);
    assert!(cycles(&edges).is_empty(), "{edges:?}");
    // now c uses a::X, which lives in a/x.rs: a::x -> b -> c -> a::x
    fs::write(dir.join("c.rs"), "use super::a::X;\npub fn h() { let _: X; }\n").unwrap();
    let (_, edges) = graph(&dir);
    let found = cycles(&edges);
    fs::remove_dir_all(&dir).unwrap();
    let names: Vec<Vec<String>> = found.iter().map(|c| c.iter().map(|m| name(m)).collect()).collect();
    assert_eq!(names, vec![vec!["a::x".to_string(), "b".into(), "c".into()]]);
}

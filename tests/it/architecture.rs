//! The dependency ladder of `src/` (see ARCHITECTURE.md), checked from the source text:
//! every `crate::` and `super::` path of every module is read, and
//!
//! * a module may use only modules on lower rungs of [`LADDER`] (a module that is not
//!   on the ladder fails the test, so a new one must be placed);
//! * inside a module directory (`src/env/`, `src/lanes/`, ...) the files may not use
//!   each other in a circle.
//!
//! Comments are not read (an intra-doc link may point anywhere), nor is test code
//! (each item under `#[cfg(test)]`, and `tests.rs` files): tests sit above every layer.
//! And only `src/python/` names the Python crates (`pyo3`, `numpy`) or their
//! attributes.
//! The crate root (`lib.rs`) and each directory's `mod.rs` declare modules and
//! re-export names (some `mod.rs` also define what their whole module shares); a path
//! through such a re-export counts as a use of the file the name comes from.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// The rungs from the bottom up: a module may use the modules of the rungs below its
/// own, never those of its own rung or above.
const LADDER: &[(&str, &[&str])] = &[
    ("errors", &["error"]),
    ("sizes and solvers", &["limits", "tridiagonal"]),
    ("parameters", &["params"]),
    ("scenes", &["geometry"]),
    ("dynamics", &["model"]),
    ("oracles and invariants", &["dense", "invariants"]),
    ("integrators", &["integrate"]),
    (
        "analysis, lanes, rendering, one chain from front ends",
        &["analysis", "lanes", "render", "scaling", "any_chain"],
    ),
    ("controllers", &["control"]),
    ("the batch engine", &["engine"]),
    ("the task", &["env"]),
    ("the Python bindings", &["python"]),
];

/// Rung of top-level module `name`, if it is on the ladder.
fn rung(name: &str) -> Option<usize> {
    LADDER.iter().position(|(_, mods)| mods.contains(&name))
}

/// The crates of Python (PyO3) and NumPy (rust-numpy), and PyO3's item attributes:
/// names only the bindings (`src/python/`) may write.
const PYTHON_NAMES: &[&str] = &[
    "pyo3",
    "numpy",
    "pyclass",
    "pymethods",
    "pyfunction",
    "pymodule",
];

/// A source file: its module path (`env::step`, `lanes`, `` for the crate root) and
/// its code without comments and tests.
struct Source {
    module: Vec<String>,
    is_facade: bool,
    code: String,
}

fn module_path(src: &Path, file: &Path) -> (Vec<String>, bool) {
    let rel = file.strip_prefix(src).unwrap();
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs").to_string();
    let facade = stem == "mod" || (stem == "lib" && parts.is_empty());
    if !facade {
        parts.push(stem);
    }
    (parts, facade)
}

/// The code of `text` without comments, string literals, char literals and test code.
fn code_of(text: &str) -> String {
    without_test_items(&without_comments(text))
}

/// `code` without the items marked `#[cfg(test)]` (or `#[cfg(all(test, ...))]`): each
/// such attribute and the item after it, up to its `;` or its closing brace, go; the
/// code after them stays. `code` has no comments or literals (its braces are code).
fn without_test_items(code: &str) -> String {
    let b = code.as_bytes();
    let mut out = String::with_capacity(b.len());
    let mut i = 0;
    while let Some(at) = code[i..].find("#[") {
        let start = i + at;
        let Some(attr_end) = closing(b, start + 1) else {
            break;
        };
        let attr: String = code[start + 2..attr_end]
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect();
        if attr != "cfg(test)" && !attr.starts_with("cfg(all(test,") {
            out.push_str(&code[i..attr_end + 1]);
            i = attr_end + 1;
            continue;
        }
        out.push_str(&code[i..start]);
        // The item: to a `;` outside brackets, or through its first top-level block.
        let mut j = attr_end + 1;
        let mut depth = 0i32;
        while j < b.len() {
            match b[j] {
                b'(' | b'[' => depth += 1,
                b')' | b']' => depth -= 1,
                b';' if depth == 0 => break,
                b'{' if depth == 0 => {
                    j = closing(b, j).unwrap_or(b.len() - 1);
                    break;
                }
                _ => {}
            }
            j += 1;
        }
        i = (j + 1).min(b.len());
    }
    out.push_str(&code[i..]);
    out
}

/// Position of the bracket closing the one at `open` (`(`, `[` or `{`), counting all
/// three kinds.
fn closing(b: &[u8], open: usize) -> Option<usize> {
    let mut depth = 0i32;
    for (k, &c) in b.iter().enumerate().skip(open) {
        match c {
            b'(' | b'[' | b'{' => depth += 1,
            b')' | b']' | b'}' => {
                depth -= 1;
                if depth == 0 {
                    return Some(k);
                }
            }
            _ => {}
        }
    }
    None
}

/// `text` without comments, string literals (left as `""`) and char literals.
fn without_comments(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            let mut depth = 0;
            while i < b.len() {
                if b[i..].starts_with(b"/*") {
                    depth += 1;
                    i += 2;
                } else if b[i..].starts_with(b"*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' && i + 2 < b.len() && (b[i + 2] == b'\'' || b[i + 1] == b'\\') {
            // A char literal ('x' or '\n'); a lifetime has no closing quote.
            let end = text[i + 1..].find('\'').map_or(b.len(), |e| i + 2 + e);
            i = end;
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    out
}

/// Every `.rs` file under `src`, sorted.
fn rust_files(src: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut dirs = vec![src.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        for entry in fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

fn sources(src: &Path) -> Vec<Source> {
    rust_files(src)
        .into_iter()
        // A `tests.rs` file is a test module.
        .filter(|path| path.file_stem().is_some_and(|s| s != "tests"))
        .map(|file| {
            let (module, is_facade) = module_path(src, &file);
            let code = code_of(&fs::read_to_string(&file).unwrap());
            Source {
                module,
                is_facade,
                code,
            }
        })
        .collect()
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Every path of a `use` tree (`a::{b, c::{d, e}}` -> `a::b`, `a::c::d`, `a::c::e`).
fn expand_use(tree: &str, prefix: &str, out: &mut Vec<String>) {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        let path = tree.split(" as ").next().unwrap().trim();
        if !path.is_empty() {
            out.push(format!("{prefix}{path}"));
        }
        return;
    };
    let head = &tree[..open];
    let inner = &tree[open + 1..tree.rfind('}').unwrap()];
    let mut depth = 0;
    let mut start = 0;
    for (k, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                expand_use(&inner[start..k], &format!("{prefix}{head}"), out);
                start = k + 1;
            }
            _ => {}
        }
    }
    expand_use(&inner[start..], &format!("{prefix}{head}"), out);
}

/// The `crate::`, `super::` and `self::` paths `code` uses, as written (segments joined by `::`).
fn paths_in(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    // `use` statements first (they may group paths in braces).
    let mut rest = code;
    while let Some(at) = find_word(rest, "use") {
        let after = &rest[at + 3..];
        let end = after.find(';').unwrap_or(after.len());
        let mut paths = Vec::new();
        expand_use(&after[..end], "", &mut paths);
        out.extend(paths.into_iter().map(|p| p.replace(' ', "")));
        rest = &after[end..];
    }
    // Then paths written inline in the code.
    let compact: String = code.chars().filter(|c| !c.is_whitespace()).collect();
    for root in ["crate::", "super::", "self::"] {
        let mut from = 0;
        while let Some(at) = compact[from..].find(root) {
            let start = from + at;
            let preceded = compact[..start].chars().last().is_some_and(is_ident);
            let mut end = start;
            while end < compact.len() {
                let c = compact[end..].chars().next().unwrap();
                if is_ident(c) || compact[end..].starts_with("::") {
                    end += if c == ':' { 2 } else { c.len_utf8() };
                } else {
                    break;
                }
            }
            if !preceded {
                out.push(compact[start..end].trim_end_matches("::").to_string());
            }
            from = end.max(start + root.len());
        }
    }
    out
}

/// Position of the keyword `word` standing alone in `text`.
fn find_word(text: &str, word: &str) -> Option<usize> {
    let mut from = 0;
    while let Some(at) = text[from..].find(word) {
        let start = from + at;
        let before = text[..start].chars().last();
        let after = text[start + word.len()..].chars().next();
        if !before.is_some_and(is_ident) && after.is_some_and(char::is_whitespace) {
            return Some(start);
        }
        from = start + word.len();
    }
    None
}

/// The module files of the crate and what each facade re-exports (`env` + `TaskConfig`
/// -> `env::config`).
struct Crate {
    files: BTreeSet<Vec<String>>,
    exports: BTreeMap<(Vec<String>, String), Vec<String>>,
}

impl Crate {
    fn new(sources: &[Source]) -> Self {
        let files = sources.iter().map(|s| s.module.clone()).collect();
        let mut krate = Self {
            files,
            exports: BTreeMap::new(),
        };
        for s in sources.iter().filter(|s| s.is_facade) {
            for line in s.code.split(';') {
                let Some(at) = find_word(line, "use") else {
                    continue;
                };
                if !line[..at].contains("pub") {
                    continue;
                }
                let mut paths = Vec::new();
                expand_use(&line[at + 3..], "", &mut paths);
                for p in paths {
                    let p = p.replace(' ', "");
                    let target = krate.absolute(&s.module, true, &p);
                    if let Some(name) = p.rsplit("::").next() {
                        let alias = line
                            .split(" as ")
                            .nth(1)
                            .filter(|_| line.matches(" as ").count() == 1)
                            .map(|a| a.trim().trim_end_matches('}').trim().to_string());
                        let name = alias.unwrap_or_else(|| name.to_string());
                        krate.exports.insert((s.module.clone(), name), target);
                    }
                }
            }
        }
        krate
    }

    /// Whether `path` starts with a child module of the facade `module` (`config::X` in
    /// `env/mod.rs`).
    fn is_child(&self, module: &[String], path: &str) -> bool {
        let first = path.split("::").next().unwrap_or("");
        let mut child = module.to_vec();
        child.push(first.to_string());
        self.files.contains(&child)
    }

    /// `path` as written in module `module` made absolute (segments from the crate root);
    /// empty for a path that leaves the crate. In a facade (`mod.rs`) the module is its
    /// directory, so `super` is the parent directory and a bare path names a child.
    fn absolute(&self, module: &[String], facade: bool, path: &str) -> Vec<String> {
        let segs: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
        let mut base: Vec<String> = module.to_vec();
        let rest = match segs.first() {
            Some(&"crate") => {
                base.clear();
                &segs[1..]
            }
            Some(&"self") => &segs[1..],
            Some(&"super") => {
                let ups = segs.iter().take_while(|s| **s == "super").count();
                for _ in 0..ups {
                    base.pop();
                }
                &segs[ups..]
            }
            _ if facade => &segs[..],
            _ => return Vec::new(),
        };
        base.extend(rest.iter().map(|s| s.to_string()));
        base
    }

    /// The module file a full path ends in: the longest prefix that is a file, followed
    /// through a facade's re-exports.
    fn file_of(&self, path: &[String]) -> Option<Vec<String>> {
        for len in (0..=path.len()).rev() {
            let prefix = path[..len].to_vec();
            if !self.files.contains(&prefix) {
                continue;
            }
            if let Some(name) = path.get(len) {
                if let Some(target) = self.exports.get(&(prefix.clone(), name.clone())) {
                    if target.as_slice() != path {
                        return self.file_of(target);
                    }
                }
            }
            return Some(prefix);
        }
        None
    }
}

/// (using module file, used module file) pairs.
type Edges = BTreeSet<(Vec<String>, Vec<String>)>;

/// Every (using module file, used module file) pair of the crate; the crate root, which
/// only declares and re-exports, is left out.
fn edges(sources: &[Source], krate: &Crate) -> Edges {
    let mut out = BTreeSet::new();
    for s in sources.iter().filter(|s| !s.module.is_empty()) {
        for p in paths_in(&s.code) {
            let rooted = p.starts_with("crate") || p.starts_with("super") || p.starts_with("self");
            // A facade also names its own child modules directly (`pub use config::X`).
            if !(rooted || s.is_facade && krate.is_child(&s.module, &p)) {
                continue;
            }
            let abs = krate.absolute(&s.module, s.is_facade, &p);
            if let Some(used) = krate.file_of(&abs) {
                if used != s.module && !used.is_empty() {
                    out.insert((s.module.clone(), used));
                }
            }
        }
    }
    out
}

fn crate_edges() -> (Vec<Source>, Edges) {
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src");
    let sources = sources(&src);
    let krate = Crate::new(&sources);
    let edges = edges(&sources, &krate);
    (sources, edges)
}

#[test]
fn every_module_is_on_the_ladder() {
    let (sources, _) = crate_edges();
    let off: BTreeSet<&str> = sources
        .iter()
        .filter_map(|s| s.module.first())
        .map(String::as_str)
        .filter(|m| rung(m).is_none())
        .collect();
    assert!(
        off.is_empty(),
        "modules not placed on the ladder (add them to LADDER and ARCHITECTURE.md): {off:?}"
    );
}

#[test]
fn no_module_uses_one_on_its_own_rung_or_above() {
    let (_, edges) = crate_edges();
    let mut wrong = Vec::new();
    for (from, to) in &edges {
        let (a, b) = (&from[0], &to[0]);
        if a == b {
            continue;
        }
        if let (Some(ra), Some(rb)) = (rung(a), rung(b)) {
            if rb >= ra {
                wrong.push(format!(
                    "{} uses {} ({} may use only rungs below \"{}\")",
                    from.join("::"),
                    to.join("::"),
                    a,
                    LADDER[ra].0
                ));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "imports against the ladder:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_files_of_a_module_use_each_other_without_circles() {
    let (_, edges) = crate_edges();
    // Tarjan-free check: repeatedly remove files that use no remaining sibling.
    let inside: Vec<_> = edges
        .iter()
        .filter(|(a, b)| a.len() > 1 && b.len() > 1 && a[0] == b[0])
        .collect();
    let mut left: BTreeSet<Vec<String>> = inside
        .iter()
        .flat_map(|(a, b)| [a.clone(), b.clone()])
        .collect();
    loop {
        let leaves: Vec<_> = left
            .iter()
            .filter(|m| !inside.iter().any(|(a, b)| a == *m && left.contains(b)))
            .cloned()
            .collect();
        if leaves.is_empty() {
            break;
        }
        for m in leaves {
            left.remove(&m);
        }
    }
    let circle: Vec<String> = inside
        .iter()
        .filter(|(a, b)| left.contains(a) && left.contains(b))
        .map(|(a, b)| format!("{} -> {}", a.join("::"), b.join("::")))
        .collect();
    assert!(
        circle.is_empty(),
        "files in a circle:\n{}",
        circle.join("\n")
    );
}

#[test]
fn the_reader_finds_the_paths_it_must() {
    // The test is only as good as its reading of the source: check it on known text.
    let code = code_of(
        "use crate::{a::{B, c::D}, e};\n// use crate::hidden;\nfn f() { super::g::h(); \
         let s = \"crate::in_string\"; crate::x::Y::new() }\n#[cfg(test)]\nuse crate::tests_only;",
    );
    let mut paths = paths_in(&code);
    paths.sort();
    paths.dedup();
    for expected in [
        "crate::a::B",
        "crate::a::c::D",
        "crate::e",
        "super::g::h",
        "crate::x::Y::new",
    ] {
        assert!(
            paths.iter().any(|p| p == expected),
            "{expected} in {paths:?}"
        );
    }
    assert!(!paths
        .iter()
        .any(|p| p.contains("hidden") || p.contains("in_string") || p.contains("tests_only")));
    // And on the crate: the lanes' kernel is known to use the model's layout.
    let (_, edges) = crate_edges();
    let has = |a: &str, b: &str| {
        edges
            .iter()
            .any(|(x, y)| x.join("::") == a && y.join("::") == b)
    };
    assert!(has("lanes::guarded_rk4", "geometry"), "{edges:?}");
    assert!(has("model", "params"));
}

/// Whether the identifier `name` stands alone in `code` (not part of a longer one).
fn names(code: &str, name: &str) -> bool {
    code.match_indices(name).any(|(at, _)| {
        !code[..at].chars().last().is_some_and(is_ident)
            && !code[at + name.len()..].chars().next().is_some_and(is_ident)
    })
}

#[test]
fn only_the_bindings_know_python() {
    // Every file, tests included: `cargo test` builds none of the Python crates.
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src");
    let bindings = src.join("python");
    let mut wrong = Vec::new();
    for file in rust_files(&src) {
        if file.starts_with(&bindings) {
            continue;
        }
        let code = without_comments(&fs::read_to_string(&file).unwrap());
        for name in PYTHON_NAMES.iter().filter(|n| names(&code, n)) {
            wrong.push(format!("{} names {name}", file.display()));
        }
    }
    assert!(
        wrong.is_empty(),
        "Python outside src/python/:\n{}",
        wrong.join("\n")
    );
    // The check itself sees what it must, and only that.
    let sample =
        without_comments("use pyo3::prelude::*; // numpy\nlet s = \"numpy\"; let numpy_like = 1;");
    assert!(names(&sample, "pyo3") && !names(&sample, "numpy"));
    let bound = without_comments(&fs::read_to_string(bindings.join("mod.rs")).unwrap());
    assert!(names(&bound, "pyo3") && names(&bound, "pymodule"));
}

#[test]
fn test_items_are_left_out_and_the_code_after_them_read() {
    let code = code_of(
        "use crate::a;\n#[cfg(test)]\nmod tests {\n    use crate::t1;\n    fn f() { if x { crate::t2(); } }\n}\n\
         fn g() -> [u8; 2] { crate::b::c() }\n\
         #[cfg(all(test, target_arch = \"x86_64\"))]\n#[allow(unused)]\nfn h() -> [u8; 2] { crate::t3() }\n\
         #[cfg(test)]\nconst N: [u8; 2] = [0; 2];\n#[inline]\nfn k() { crate::d::e(); }",
    );
    let paths = paths_in(&code);
    for expected in ["crate::a", "crate::b::c", "crate::d::e"] {
        assert!(
            paths.iter().any(|p| p == expected),
            "{expected} in {paths:?}"
        );
    }
    assert!(
        !paths.iter().any(|p| p.starts_with("crate::t")),
        "{paths:?}"
    );
    assert!(code.contains("#[inline]") && !code.contains("const N"));
}

#[test]
fn the_files_of_a_layer_are_private_and_its_mod_rs_is_its_surface() {
    // Only lib.rs declares public modules (the layers); inside a layer every file is a
    // private module whose public items the layer's mod.rs re-exports.
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut public = Vec::new();
    for file in rust_files(&src) {
        if file.ends_with("lib.rs") {
            continue;
        }
        let code = without_comments(&fs::read_to_string(&file).unwrap());
        for line in code.lines().map(str::trim) {
            // `pub mod name;` declares a file; an inline `pub mod name { .. }` is an item.
            if line.starts_with("pub mod ") && line.ends_with(';') {
                public.push(format!("{}: {line}", file.display()));
            }
        }
    }
    assert!(public.is_empty(), "public files inside layers: {public:#?}");
    let lib = without_comments(&fs::read_to_string(src.join("lib.rs")).unwrap());
    assert!(lib.contains("pub mod env;") && lib.contains("pub mod analysis;"));
}

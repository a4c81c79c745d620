//! The source files of the library (and, apart, of the `haze` command) import one another without
//! a circle: every file stands above everything it imports, so each can be read, tested and
//! changed from the ground up. The check parses every file under `src/` with `syn` and draws an
//! arrow from file A to file B wherever A names an item that B defines:
//!
//! - a `use` of A (`crate::`, `super::`, `self::` or a child module), resolved through the
//!   re-exports of the files on the way to the file that defines the item (a `pub use` that only
//!   hands a name on, and is not used in its own file, draws no arrow: a module's face is no
//!   import);
//! - a path written out in code, types or macro arguments (`crate::math::Rgb::ZERO`,
//!   `super::MAX_COORDINATE`, `grid::voxel` after `use crate::medium::grid`).
//!
//! Code under `#[cfg(test)]` (or in a file that begins `#![cfg(test)]`) is left out: tests may
//! reach anywhere. A circle is reported with the arrows that tie it and the names each takes, so
//! the mend can start from the message.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use proc_macro2::{TokenStream, TokenTree};
use syn::visit::Visit;

/// A module path from the crate root (`["medium", "grid"]`); the root is empty.
type ModPath = Vec<String>;

/// One `use` of a file: the name it brings in (`None` for a glob), the absolute path it stands
/// for, whether it is public, and the module it was written in.
#[derive(Clone, Debug)]
struct Import {
    name: Option<String>,
    target: ModPath,
    public: bool,
    module: ModPath,
}

impl Import {
    /// `pub(crate) use choices;`: a macro of this very module made nameable by path.
    fn is_local(&self) -> bool {
        self.target.len() == 1 && self.name.as_ref() == Some(&self.target[0])
    }
}

/// What one file says: its `use`s, the paths written in its code, and the single names used in it.
#[derive(Default, Debug)]
struct FileFacts {
    imports: Vec<Import>,
    /// (module the path was written in, path segments as written).
    paths: Vec<(ModPath, Vec<String>)>,
    names: BTreeSet<String>,
    /// Functions outside test code: (name, lines from `fn` to its closing brace).
    functions: Vec<(String, usize)>,
}

struct Crate {
    /// Module path -> the file that holds it (inline modules map to their file).
    modules: BTreeMap<ModPath, PathBuf>,
    facts: BTreeMap<PathBuf, FileFacts>,
}

fn is_test_attr(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg")
            && matches!(&a.meta, syn::Meta::List(l) if l.tokens.to_string().trim() == "test")
    })
}

struct Collector<'a> {
    module: ModPath,
    facts: &'a mut FileFacts,
    inline: Vec<ModPath>,
}

impl Collector<'_> {
    fn use_tree(&mut self, tree: &syn::UseTree, prefix: &mut Vec<String>, public: bool) {
        match tree {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                self.use_tree(&p.tree, prefix, public);
                prefix.pop();
            }
            syn::UseTree::Name(n) => {
                let name = n.ident.to_string();
                let mut target = prefix.clone();
                if name != "self" {
                    target.push(name.clone());
                }
                let name = if name == "self" { prefix.last().cloned() } else { Some(name) };
                self.push_import(name, target, public);
            }
            syn::UseTree::Rename(r) => {
                let mut target = prefix.clone();
                if r.ident != "self" {
                    target.push(r.ident.to_string());
                }
                self.push_import(Some(r.rename.to_string()), target, public);
            }
            syn::UseTree::Glob(_) => self.push_import(None, prefix.clone(), public),
            syn::UseTree::Group(g) => {
                for t in &g.items {
                    self.use_tree(t, prefix, public);
                }
            }
        }
    }

    fn push_import(&mut self, name: Option<String>, target: ModPath, public: bool) {
        self.facts.imports.push(Import { name, target, public, module: self.module.clone() });
    }

    /// Paths inside a macro's tokens: `a::b::c` runs of identifiers joined by `::`.
    fn tokens(&mut self, tokens: TokenStream) {
        let trees: Vec<TokenTree> = tokens.into_iter().collect();
        let mut i = 0;
        while i < trees.len() {
            match &trees[i] {
                TokenTree::Group(g) => {
                    self.tokens(g.stream());
                    i += 1;
                }
                TokenTree::Ident(id) => {
                    let preceded_by_colons = i >= 2
                        && matches!(&trees[i - 1], TokenTree::Punct(p) if p.as_char() == ':')
                        && matches!(&trees[i - 2], TokenTree::Punct(p) if p.as_char() == ':');
                    let mut segs = vec![id.to_string()];
                    let mut j = i + 1;
                    while j + 2 < trees.len()
                        && matches!(&trees[j], TokenTree::Punct(p) if p.as_char() == ':')
                        && matches!(&trees[j + 1], TokenTree::Punct(p) if p.as_char() == ':')
                    {
                        if let TokenTree::Ident(next) = &trees[j + 2] {
                            segs.push(next.to_string());
                            j += 3;
                        } else {
                            break;
                        }
                    }
                    if !preceded_by_colons {
                        self.facts.names.insert(segs[0].clone());
                        if segs.len() > 1 {
                            self.facts.paths.push((self.module.clone(), segs));
                        }
                    }
                    i = j.max(i + 1);
                }
                TokenTree::Punct(_) | TokenTree::Literal(_) => i += 1,
            }
        }
    }
}

impl Collector<'_> {
    fn function(&mut self, name: String, sig: &syn::Signature, block: &syn::Block) {
        use syn::spanned::Spanned;
        let (first, last) = (sig.span().start().line, block.span().end().line);
        self.facts.functions.push((name, last + 1 - first));
    }
}

impl<'ast> Visit<'ast> for Collector<'_> {
    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        self.function(f.sig.ident.to_string(), &f.sig, &f.block);
        syn::visit::visit_item_fn(self, f);
    }

    fn visit_impl_item_fn(&mut self, f: &'ast syn::ImplItemFn) {
        self.function(f.sig.ident.to_string(), &f.sig, &f.block);
        syn::visit::visit_impl_item_fn(self, f);
    }

    fn visit_trait_item_fn(&mut self, f: &'ast syn::TraitItemFn) {
        if let Some(block) = &f.default {
            self.function(f.sig.ident.to_string(), &f.sig, block);
        }
        syn::visit::visit_trait_item_fn(self, f);
    }

    fn visit_item(&mut self, item: &'ast syn::Item) {
        let attrs = match item {
            syn::Item::Const(i) => &i.attrs,
            syn::Item::Enum(i) => &i.attrs,
            syn::Item::Fn(i) => &i.attrs,
            syn::Item::Impl(i) => &i.attrs,
            syn::Item::Macro(i) => &i.attrs,
            syn::Item::Mod(i) => &i.attrs,
            syn::Item::Static(i) => &i.attrs,
            syn::Item::Struct(i) => &i.attrs,
            syn::Item::Trait(i) => &i.attrs,
            syn::Item::Type(i) => &i.attrs,
            syn::Item::Union(i) => &i.attrs,
            syn::Item::Use(i) => &i.attrs,
            _ => return syn::visit::visit_item(self, item),
        };
        if is_test_attr(attrs) {
            return;
        }
        match item {
            syn::Item::Use(u) => {
                let public = !matches!(u.vis, syn::Visibility::Inherited);
                self.use_tree(&u.tree, &mut Vec::new(), public);
            }
            syn::Item::Mod(m) if m.content.is_some() => {
                self.module.push(m.ident.to_string());
                self.inline.push(self.module.clone());
                for i in &m.content.as_ref().unwrap().1 {
                    self.visit_item(i);
                }
                self.module.pop();
            }
            _ => syn::visit::visit_item(self, item),
        }
    }

    fn visit_impl_item(&mut self, item: &'ast syn::ImplItem) {
        let test = match item {
            syn::ImplItem::Fn(f) => is_test_attr(&f.attrs),
            syn::ImplItem::Const(c) => is_test_attr(&c.attrs),
            _ => false,
        };
        if !test {
            syn::visit::visit_impl_item(self, item);
        }
    }

    fn visit_stmt(&mut self, stmt: &'ast syn::Stmt) {
        if let syn::Stmt::Item(item) = stmt {
            // Items inside function bodies (`use` included) belong to the enclosing module.
            return self.visit_item(item);
        }
        syn::visit::visit_stmt(self, stmt);
    }

    fn visit_path(&mut self, path: &'ast syn::Path) {
        if path.leading_colon.is_none() {
            let segs: Vec<String> = path.segments.iter().map(|s| s.ident.to_string()).collect();
            self.facts.names.insert(segs[0].clone());
            if segs.len() > 1 {
                self.facts.paths.push((self.module.clone(), segs));
            }
        }
        syn::visit::visit_path(self, path);
    }

    fn visit_macro(&mut self, mac: &'ast syn::Macro) {
        self.visit_path(&mac.path);
        self.tokens(mac.tokens.clone());
    }
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The crate whose root file is `root` and whose modules are the `.rs` files under `dir`,
/// leaving out `skip`.
fn read_crate(dir: &Path, root: &str, skip: Option<&Path>) -> Crate {
    let mut files = Vec::new();
    rust_files(dir, &mut files);
    files.retain(|f| skip.is_none_or(|s| !f.starts_with(s)));
    files.sort();
    let mut modules = BTreeMap::new();
    let mut facts = BTreeMap::new();
    for file in files {
        let rel = file.strip_prefix(dir).unwrap();
        let mut module: ModPath = rel.iter().map(|c| c.to_string_lossy().into_owned()).collect();
        let last = module.pop().unwrap();
        if last != "mod.rs" && last != root {
            module.push(last.trim_end_matches(".rs").to_string());
        }
        let text = std::fs::read_to_string(&file).unwrap();
        let ast = syn::parse_file(&text).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        // A module's tests moved to a file of their own say `#![cfg(test)]`: test code too.
        if is_test_attr(&ast.attrs) {
            continue;
        }
        let mut f = FileFacts::default();
        let mut c = Collector { module: module.clone(), facts: &mut f, inline: Vec::new() };
        c.visit_file(&ast);
        for m in std::mem::take(&mut c.inline) {
            modules.insert(m, file.clone());
        }
        modules.insert(module, file.clone());
        facts.insert(file, f);
    }
    Crate { modules, facts }
}

impl Crate {
    /// The absolute path that `segs`, written in module `module`, names; `None` outside the crate.
    fn absolute(&self, module: &[String], segs: &[String], file: &Path) -> Option<ModPath> {
        self.absolute_at(module, segs, file, 0)
    }

    fn absolute_at(
        &self,
        module: &[String],
        segs: &[String],
        file: &Path,
        depth: usize,
    ) -> Option<ModPath> {
        if depth > 16 {
            return None;
        }
        let mut base: ModPath = module.to_vec();
        let mut rest = segs;
        match rest.first()?.as_str() {
            "crate" => {
                base.clear();
                rest = &rest[1..];
            }
            "self" => rest = &rest[1..],
            "super" => {
                while rest.first().is_some_and(|s| s == "super") {
                    base.pop()?;
                    rest = &rest[1..];
                }
            }
            first => {
                let mut child = base.clone();
                child.push(first.to_string());
                if !self.modules.contains_key(&child) {
                    // A name brought in by a `use` of this module: `grid::voxel` after
                    // `use crate::medium::grid`.
                    let import = self.facts[file].imports.iter().find(|i| {
                        i.module == module && i.name.as_deref() == Some(first) && !i.is_local()
                    })?;
                    let mut abs =
                        self.absolute_at(&import.module, &import.target, file, depth + 1)?;
                    abs.extend(rest[1..].iter().cloned());
                    return Some(abs);
                }
            }
        }
        base.extend(rest.iter().cloned());
        Some(base)
    }

    /// The file that defines the item at absolute path `abs`, following re-exports; `None` where
    /// the path leaves the crate or names a module.
    fn definer(&self, abs: &[String], depth: usize) -> Option<(PathBuf, String)> {
        if depth > 16 {
            return None;
        }
        let split = (0..=abs.len()).rev().find(|&n| self.modules.contains_key(&abs[..n]))?;
        let (module, rest) = abs.split_at(split);
        let file = &self.modules[module];
        let name = rest.first()?;
        let facts = &self.facts[file];
        let here = |i: &&Import| i.module == module;
        let named = |i: &&Import| i.name.as_ref() == Some(name) && !i.is_local();
        if let Some(i) = facts.imports.iter().filter(here).find(named) {
            let target = self.absolute(&i.module, &i.target, file)?;
            let mut next = target;
            next.extend(rest[1..].iter().cloned());
            return self.definer(&next, depth + 1);
        }
        for glob in facts.imports.iter().filter(here).filter(|i| i.name.is_none()) {
            if let Some(target) = self.absolute(&glob.module, &glob.target, file)
                && self.modules.contains_key(&target)
            {
                let mut next = target;
                next.extend(rest.iter().cloned());
                if let Some(d) = self.definer(&next, depth + 1) {
                    return Some(d);
                }
            }
        }
        Some((file.clone(), name.clone()))
    }

    /// Arrows file -> file, each with the names taken.
    fn arrows(&self) -> BTreeMap<(PathBuf, PathBuf), BTreeSet<String>> {
        let mut arrows: BTreeMap<(PathBuf, PathBuf), BTreeSet<String>> = BTreeMap::new();
        let mut add = |from: &Path, to: Option<(PathBuf, String)>| {
            if let Some((to, name)) = to
                && to != from
            {
                arrows.entry((from.to_path_buf(), to)).or_default().insert(name);
            }
        };
        for (file, facts) in &self.facts {
            for i in &facts.imports {
                let Some(name) = &i.name else { continue };
                if i.public && !facts.names.contains(name) {
                    continue; // a face: the name is only handed on
                }
                if let Some(abs) = self.absolute(&i.module, &i.target, file) {
                    add(file, self.definer(&abs, 0));
                }
            }
            for (module, segs) in &facts.paths {
                if let Some(abs) = self.absolute(module, segs, file) {
                    add(file, self.definer(&abs, 0));
                }
            }
        }
        arrows
    }
}

/// Strongly connected components of more than one file (Tarjan).
fn circles(arrows: &BTreeMap<(PathBuf, PathBuf), BTreeSet<String>>) -> Vec<Vec<PathBuf>> {
    let mut next: BTreeMap<&PathBuf, Vec<&PathBuf>> = BTreeMap::new();
    for (a, b) in arrows.keys() {
        next.entry(a).or_default().push(b);
        next.entry(b).or_default();
    }
    struct State<'a> {
        index: BTreeMap<&'a PathBuf, usize>,
        low: BTreeMap<&'a PathBuf, usize>,
        stack: Vec<&'a PathBuf>,
        on: BTreeSet<&'a PathBuf>,
        out: Vec<Vec<PathBuf>>,
    }
    fn visit<'a>(
        v: &'a PathBuf,
        next: &BTreeMap<&'a PathBuf, Vec<&'a PathBuf>>,
        s: &mut State<'a>,
    ) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        s.on.insert(v);
        for &w in &next[v] {
            if !s.index.contains_key(w) {
                visit(w, next, s);
                let l = s.low[w].min(s.low[v]);
                s.low.insert(v, l);
            } else if s.on.contains(w) {
                let l = s.index[w].min(s.low[v]);
                s.low.insert(v, l);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            loop {
                let w = s.stack.pop().unwrap();
                s.on.remove(w);
                component.push(w.clone());
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                s.out.push(component);
            }
        }
    }
    let mut s = State {
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in next.keys() {
        if !s.index.contains_key(v) {
            visit(v, &next, &mut s);
        }
    }
    s.out
}

fn report(src: &Path, c: &Crate) -> String {
    let arrows = c.arrows();
    let mut text = String::new();
    for circle in circles(&arrows) {
        let name = |p: &Path| p.strip_prefix(src).unwrap().display().to_string();
        let files: Vec<String> = circle.iter().map(|p| name(p)).collect();
        text += &format!("circle of {} files: {}\n", circle.len(), files.join(", "));
        for ((a, b), names) in &arrows {
            if circle.contains(a) && circle.contains(b) {
                let names: Vec<&str> = names.iter().map(String::as_str).collect();
                text += &format!("  {} -> {}: {}\n", name(a), name(b), names.join(", "));
            }
        }
    }
    text
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn the_library_has_no_import_circle() {
    let src = src();
    let lib = read_crate(&src, "lib.rs", Some(&src.join("bin")));
    assert!(lib.modules.len() > 40, "only {} modules found under src/", lib.modules.len());
    let text = report(&src, &lib);
    assert!(text.is_empty(), "files of src/ that import each other in a loop:\n{text}");
}

#[test]
fn the_command_has_no_import_circle() {
    let src = src();
    let bin = read_crate(&src.join("bin/haze"), "main.rs", None);
    let text = report(&src, &bin);
    assert!(text.is_empty(), "files of src/bin/haze that import each other in a loop:\n{text}");
}

/// Longest function, in lines from `fn` to its closing brace, outside test code.
const MAX_FUNCTION_LINES: usize = 80;

/// Functions over [`MAX_FUNCTION_LINES`] that stand, each with the reason (docs/design.md lists
/// them): the list may only shrink. A function that has come under the limit must leave it.
const LONG_FUNCTIONS: &[(&str, &str)] = &[
    (
        "accel/mod.rs::through",
        "one traversal loop of the BVH4 (stack, four-wide box tests, leaves, pass-through hits)",
    ),
    (
        "integrator/single.rs::single_scattering",
        "two strategies that share their draws and densities; the draw order is the image's",
    ),
];

#[test]
fn no_function_runs_over_80_lines() {
    let src = src();
    let mut long = Vec::new();
    for (dir, root, skip) in
        [(src.clone(), "lib.rs", Some(src.join("bin"))), (src.join("bin/haze"), "main.rs", None)]
    {
        let c = read_crate(&dir, root, skip.as_deref());
        for (file, facts) in &c.facts {
            for (name, lines) in &facts.functions {
                let at = format!("{}::{name}", file.strip_prefix(&src).unwrap().display());
                long.push((at, *lines));
            }
        }
    }
    let listed = |at: &str| LONG_FUNCTIONS.iter().any(|(f, _)| *f == at);
    let over: Vec<String> = long
        .iter()
        .filter(|(at, lines)| *lines > MAX_FUNCTION_LINES && !listed(at))
        .map(|(at, lines)| format!("{at}: {lines} lines"))
        .collect();
    assert!(over.is_empty(), "functions over {MAX_FUNCTION_LINES} lines:\n{}", over.join("\n"));
    let shrunk: Vec<&str> = LONG_FUNCTIONS
        .iter()
        .map(|(f, _)| *f)
        .filter(|f| !long.iter().any(|(at, lines)| at == f && *lines > MAX_FUNCTION_LINES))
        .collect();
    assert!(shrunk.is_empty(), "listed as long but no longer over the limit (or gone): {shrunk:?}");
}

/// The check sees a circle where one is: two files of a small crate that name each other; and
/// none through a file of tests.
#[test]
fn a_circle_is_seen() {
    let dir = std::env::temp_dir().join(format!("haze-layers-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("a")).unwrap();
    std::fs::write(dir.join("lib.rs"), "mod a;\nmod b;\npub use a::Face;\n").unwrap();
    std::fs::write(dir.join("a/mod.rs"), "pub mod c;\npub use c::Face;\nuse crate::b::B;\n")
        .unwrap();
    // c.rs reaches b.rs through a path in code; b.rs reaches c.rs through a's re-export.
    std::fs::write(dir.join("a/c.rs"), "pub struct Face;\nfn f() { crate::b::g(); }\n").unwrap();
    // A file of tests (`#![cfg(test)]`) that b.rs names and that names b.rs: test code, no
    // circle; the same file without the attribute ties one.
    let tests = |attr: &str| format!("{attr}\npub fn t() {{ crate::b::g(); }}\n");
    std::fs::write(
        dir.join("b.rs"),
        "pub struct B(crate::a::Face);\npub fn g() { crate::t::t(); }\n",
    )
    .unwrap();
    std::fs::write(dir.join("t.rs"), tests("#![cfg(test)]")).unwrap();
    let text = report(&dir, &read_crate(&dir, "lib.rs", None));
    std::fs::write(dir.join("t.rs"), tests("")).unwrap();
    let untested = report(&dir, &read_crate(&dir, "lib.rs", None));
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(text.contains("a/c.rs -> b.rs: g"), "{text}");
    assert!(text.contains("b.rs -> a/c.rs: Face"), "{text}");
    // a/mod.rs takes B from b.rs, but nothing leads back to a/mod.rs itself.
    assert!(!text.contains("a/mod.rs,"), "{text}");
    assert!(!text.contains("t.rs"), "{text}");
    assert!(untested.contains("t.rs -> b.rs: g"), "{untested}");
}

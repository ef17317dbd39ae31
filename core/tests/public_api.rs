//! The public API, snapshotted: every item an integrator can name (public
//! modules and items not marked `#[doc(hidden)]`, with their signatures), read
//! from the crate's source with `syn` and compared with `tests/public-api.txt`.
//! A change to the surface fails here until the snapshot is updated on
//! purpose:
//!
//! ```sh
//! UPDATE_PUBLIC_API=1 cargo test -p gpecnet-core --test it public_api::
//! ```
use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use quote::ToTokens;
use syn::{Attribute, Fields, ImplItem, Item, TraitItem, Visibility};

fn hidden(attrs: &[Attribute]) -> bool {
    attrs.iter().any(|a| {
        let t = a.to_token_stream().to_string();
        t.contains("doc (hidden)") || t.contains("cfg (test)")
    })
}

fn public(v: &Visibility) -> bool {
    matches!(v, Visibility::Public(_))
}

/// Tokens as one normalised line.
fn tokens(t: &impl ToTokens) -> String {
    t.to_token_stream().to_string()
}

/// `cfg(feature = ..)` gates, written before the item so gated API is visible as such.
fn gate(attrs: &[Attribute]) -> String {
    attrs
        .iter()
        .filter(|a| a.path().is_ident("cfg"))
        .map(|a| format!("{} ", tokens(a)))
        .collect()
}

/// The bodiless `fn` signatures a macro invocation lists (none when its
/// input is anything else).
fn signatures(mac: &syn::Macro) -> Vec<syn::ForeignItemFn> {
    let parse = |s: syn::parse::ParseStream<'_>| {
        let mut fns = Vec::new();
        while !s.is_empty() {
            fns.push(s.parse::<syn::ForeignItemFn>()?);
        }
        Ok(fns)
    };
    mac.parse_body_with(parse).unwrap_or_default()
}

fn module_file(src: &Path, path: &str) -> PathBuf {
    let f = src.join(format!("{path}.rs"));
    if f.exists() {
        f
    } else {
        src.join(path).join("mod.rs")
    }
}

fn walk(src: &Path, module: &str, items: &[Item], krate: &Crate, out: &mut Vec<String>) {
    for item in items {
        let mut push = |s: String| out.push(format!("{module}: {s}"));
        match item {
            Item::Mod(m) if public(&m.vis) && !hidden(&m.attrs) => {
                let name = m.ident.to_string();
                push(format!("{}mod {name}", gate(&m.attrs)));
                let path = if module == "crate" {
                    name.clone()
                } else {
                    format!(
                        "{}/{name}",
                        module.trim_start_matches("crate::").replace("::", "/")
                    )
                };
                let child = format!("{module}::{name}");
                if let Some((_, inline)) = &m.content {
                    walk(src, &child, inline, krate, out);
                } else {
                    let text = std::fs::read_to_string(module_file(src, &path)).unwrap();
                    let file = syn::parse_file(&text).unwrap();
                    walk(src, &child, &file.items, krate, out);
                }
            }
            // A private file module of a public module (e.g. `blob/header.rs`)
            // is a split of its parent: its public items are the parent's,
            // re-exported with `pub use`, so they are listed under the parent.
            Item::Mod(m)
                if module != "crate"
                    && matches!(m.vis, Visibility::Inherited)
                    && m.content.is_none() =>
            {
                let dir = module.trim_start_matches("crate::").replace("::", "/");
                let path = format!("{dir}/{}", m.ident);
                let text = std::fs::read_to_string(module_file(src, &path)).unwrap();
                let file = syn::parse_file(&text).unwrap();
                walk(src, module, &file.items, krate, out);
            }
            Item::Use(u) if public(&u.vis) && !hidden(&u.attrs) => push(tokens(u)),
            Item::Fn(f) if public(&f.vis) && !hidden(&f.attrs) => {
                push(format!("{}{}", gate(&f.attrs), tokens(&f.sig)))
            }
            Item::Const(c) if public(&c.vis) && !hidden(&c.attrs) => push(format!(
                "{}const {}: {}",
                gate(&c.attrs),
                c.ident,
                tokens(&c.ty)
            )),
            Item::Static(c) if public(&c.vis) && !hidden(&c.attrs) => {
                push(format!("static {}: {}", c.ident, tokens(&c.ty)))
            }
            Item::Type(t) if public(&t.vis) && !hidden(&t.attrs) => push(format!(
                "type {}{} = {}",
                t.ident,
                tokens(&t.generics),
                tokens(&t.ty)
            )),
            Item::Struct(s) if public(&s.vis) && !hidden(&s.attrs) => {
                let derives: Vec<String> = s
                    .attrs
                    .iter()
                    .filter(|a| a.path().is_ident("derive"))
                    .map(tokens)
                    .collect();
                push(format!(
                    "{}struct {}{} {}",
                    gate(&s.attrs),
                    s.ident,
                    tokens(&s.generics),
                    derives.join(" ")
                ));
                if let Fields::Named(f) = &s.fields {
                    for field in f.named.iter().filter(|f| public(&f.vis)) {
                        let name = field
                            .ident
                            .as_ref()
                            .map(|i| i.to_string())
                            .unwrap_or_default();
                        push(format!("  field {}.{name}: {}", s.ident, tokens(&field.ty)));
                    }
                }
            }
            Item::Enum(e) if public(&e.vis) && !hidden(&e.attrs) => {
                // Whether downstream matches must have a wildcard arm is part of the surface.
                let non_exhaustive = e.attrs.iter().any(|a| a.path().is_ident("non_exhaustive"));
                push(format!(
                    "{}{}enum {}{}",
                    gate(&e.attrs),
                    if non_exhaustive {
                        "#[non_exhaustive] "
                    } else {
                        ""
                    },
                    e.ident,
                    tokens(&e.generics)
                ));
                for v in &e.variants {
                    push(format!("  variant {}::{}", e.ident, tokens(&v.ident)))
                }
            }
            Item::Trait(t) if public(&t.vis) && !hidden(&t.attrs) => {
                push(format!(
                    "trait {}{}: {}",
                    t.ident,
                    tokens(&t.generics),
                    tokens(&t.supertraits)
                ));
                for ti in &t.items {
                    match ti {
                        TraitItem::Fn(f) => push(format!("  {}", tokens(&f.sig))),
                        TraitItem::Const(c) => {
                            push(format!("  const {}: {}", c.ident, tokens(&c.ty)))
                        }
                        TraitItem::Type(ty) => {
                            push(format!("  type {}: {}", ty.ident, tokens(&ty.bounds)))
                        }
                        _ => {}
                    }
                }
            }
            // An impl of a trait the crate keeps to itself is no part of the surface.
            Item::Impl(i)
                if i.trait_.as_ref().is_some_and(|(_, path, _)| {
                    path.segments
                        .last()
                        .is_some_and(|s| krate.private.contains(&s.ident.to_string()))
                }) => {}
            Item::Impl(i) if !hidden(&i.attrs) => {
                let head = match &i.trait_ {
                    Some((_, path, _)) => format!(
                        "impl{} {} for {}",
                        tokens(&i.generics),
                        tokens(path),
                        tokens(&i.self_ty)
                    ),
                    None => format!("impl{} {}", tokens(&i.generics), tokens(&i.self_ty)),
                };
                let g = gate(&i.attrs);
                if i.trait_.is_some() {
                    push(format!("{g}{head}"));
                    continue;
                }
                for ii in &i.items {
                    match ii {
                        ImplItem::Fn(f) if public(&f.vis) && !hidden(&f.attrs) => {
                            push(format!("{g}{head} :: {}", tokens(&f.sig)))
                        }
                        ImplItem::Const(c) if public(&c.vis) && !hidden(&c.attrs) => {
                            push(format!("{g}{head} :: const {}: {}", c.ident, tokens(&c.ty)))
                        }
                        // Methods a macro generates from their written signatures
                        // (`pub fn name(..) -> T;`, as `batch`'s `forward!`).
                        // Methods a one-rule macro writes itself (as `tracks`'
                        // `table_views!`).
                        ImplItem::Macro(m) if signatures(&m.mac).is_empty() => {
                            for f in expand(krate, &m.mac) {
                                if public(&f.vis) && !hidden(&f.attrs) {
                                    push(format!("{g}{head} :: {}", tokens(&f.sig)))
                                }
                            }
                        }
                        ImplItem::Macro(m) => {
                            for mut f in signatures(&m.mac) {
                                // Written on one line there; listed as rustfmt writes
                                // a signature it breaks over lines (a trailing comma).
                                if !f.sig.inputs.empty_or_trailing() {
                                    f.sig.inputs.push_punct(Default::default());
                                }
                                if public(&f.vis) && !hidden(&f.attrs) {
                                    push(format!("{g}{head} :: {}", tokens(&f.sig)))
                                }
                            }
                        }
                        _ => {}
                    }
                }
            }
            _ => {}
        }
    }
}

/// What the walk needs to know of the whole crate: the traits declared
/// without `pub` (`pub(crate)` and narrower), whose impls are internal, and
/// the `macro_rules!` definitions by name (their tokens), for the methods a
/// macro generates.
#[derive(Default)]
struct Crate {
    private: HashSet<String>,
    macros: HashMap<String, String>,
}

/// [`Crate`] of the sources below `dir`.
fn scan(dir: &Path, krate: &mut Crate) {
    fn items(list: &[Item], krate: &mut Crate) {
        for item in list {
            match item {
                Item::Trait(t) if !public(&t.vis) => {
                    krate.private.insert(t.ident.to_string());
                }
                Item::Macro(m) if m.mac.path.is_ident("macro_rules") => {
                    if let Some(name) = &m.ident {
                        krate
                            .macros
                            .insert(name.to_string(), m.mac.tokens.to_string());
                    }
                }
                Item::Mod(m) => {
                    if let Some((_, inline)) = &m.content {
                        items(inline, krate);
                    }
                }
                _ => {}
            }
        }
    }
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            scan(&path, krate);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let text = std::fs::read_to_string(&path).unwrap();
            items(&syn::parse_file(&text).unwrap().items, krate);
        }
    }
}

/// The methods an invocation of a one-rule macro with one metavariable
/// (`($name:frag) => { items }`) generates: its items with the invocation's
/// tokens put in for `$name` (none for any other macro).
fn expand(krate: &Crate, mac: &syn::Macro) -> Vec<syn::ImplItemFn> {
    let Some(rule) = mac
        .path
        .get_ident()
        .and_then(|n| krate.macros.get(&n.to_string()))
    else {
        return Vec::new();
    };
    let Some((matcher, body)) = rule.split_once("=>") else {
        return Vec::new();
    };
    let vars: Vec<&str> = matcher.split('$').skip(1).collect();
    let [var] = vars.as_slice() else {
        return Vec::new();
    };
    let name = var.split(':').next().unwrap_or_default().trim();
    let body = body.trim().trim_end_matches(';').trim();
    let body = body.replace(&format!("$ {name}"), &mac.tokens.to_string());
    let Ok(block) = syn::parse_str::<syn::ItemImpl>(&format!("impl X {body}")) else {
        return Vec::new();
    };
    block
        .items
        .into_iter()
        .filter_map(|i| match i {
            ImplItem::Fn(f) => Some(f),
            _ => None,
        })
        .collect()
}

fn surface() -> String {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let text = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let file = syn::parse_file(&text).unwrap();
    let mut krate = Crate::default();
    scan(&src, &mut krate);
    let mut lines = Vec::new();
    walk(&src, "crate", &file.items, &krate, &mut lines);
    let mut out = String::from(
        "# gpecnet-core public API (generated by tests/public_api.rs; \
         UPDATE_PUBLIC_API=1 to rewrite)\n",
    );
    for l in lines {
        let _ = writeln!(out, "{l}");
    }
    out
}

#[test]
fn public_api_matches_the_snapshot() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/public-api.txt");
    let now = surface();
    if std::env::var_os("UPDATE_PUBLIC_API").is_some() {
        std::fs::write(&path, &now).unwrap();
        return;
    }
    let snap = std::fs::read_to_string(&path).unwrap_or_default();
    if snap != now {
        let (a, b): (Vec<&str>, Vec<&str>) = (snap.lines().collect(), now.lines().collect());
        let gone: Vec<&&str> = a.iter().filter(|l| !b.contains(l)).collect();
        let new: Vec<&&str> = b.iter().filter(|l| !a.contains(l)).collect();
        panic!(
            "the public API changed (rerun with UPDATE_PUBLIC_API=1 if on purpose):\n\
             removed:\n  {}\nadded:\n  {}",
            gone.iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join("\n  "),
            new.iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join("\n  ")
        );
    }
}

#[test]
fn hidden_internals_stay_out_of_the_snapshot() {
    let s = surface();
    for internal in [
        "mod math",
        "mod prng",
        "mod golden",
        "mod cluster",
        "LayerWire",
        "QUARTER_SINE",
    ] {
        assert!(!s.contains(internal), "{internal} is in the public surface");
    }
    for needed in [
        "struct Predictor",
        "struct Model",
        "enum PredictError",
        "mod tracks",
    ] {
        assert!(
            s.contains(needed),
            "{needed} is missing from the public surface"
        );
    }
}

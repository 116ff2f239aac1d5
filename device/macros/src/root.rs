//! The path through which generated code reaches `raykit-device`: the crate
//! itself when the calling crate depends on it (under any name), else
//! `raykit::device` when it depends only on the host crate `raykit`.

use proc_macro2::{Group, Ident, Span, TokenStream, TokenTree};
use proc_macro_crate::{crate_name, FoundCrate};
use quote::quote;

/// The tokens that stand for `::raykit_device` in the calling crate.
fn device_root() -> TokenStream {
    match crate_name("raykit-device") {
        Ok(FoundCrate::Name(name)) => {
            let name = Ident::new(&name, Span::call_site());
            quote!(::#name)
        }
        // Inside raykit-device (its own tests), or when neither crate is found:
        // `::raykit_device`, which names what the error will be about.
        Ok(FoundCrate::Itself) => quote!(::raykit_device),
        Err(_) => match crate_name("raykit") {
            Ok(FoundCrate::Name(name)) => {
                let name = Ident::new(&name, Span::call_site());
                quote!(::#name::device)
            }
            Ok(FoundCrate::Itself) => quote!(crate::device),
            Err(_) => quote!(::raykit_device),
        },
    }
}

/// Rewrites every `::raykit_device` in `tokens` to the calling crate's path.
pub fn resolve(tokens: TokenStream) -> TokenStream {
    let root = device_root();
    if root.to_string() == quote!(::raykit_device).to_string() {
        return tokens;
    }
    rewrite(tokens, &root)
}

fn rewrite(tokens: TokenStream, root: &TokenStream) -> TokenStream {
    let trees: Vec<TokenTree> = tokens.into_iter().collect();
    let mut out = Vec::with_capacity(trees.len());
    let mut i = 0;
    while i < trees.len() {
        let is_root = matches!(
            (&trees[i], trees.get(i + 1), trees.get(i + 2)),
            (TokenTree::Punct(a), Some(TokenTree::Punct(b)), Some(TokenTree::Ident(id)))
                if a.as_char() == ':' && b.as_char() == ':' && id == "raykit_device"
        );
        // Not when the `::` continues a longer path (`a::raykit_device`).
        let after_path = i > 0 && matches!(&trees[i - 1], TokenTree::Ident(id) if !is_keyword(&id.to_string()));
        if is_root && !after_path {
            out.extend(root.clone());
            i += 3;
            continue;
        }
        match &trees[i] {
            TokenTree::Group(g) => {
                let mut group = Group::new(g.delimiter(), rewrite(g.stream(), root));
                group.set_span(g.span());
                out.push(TokenTree::Group(group));
            }
            other => out.push(other.clone()),
        }
        i += 1;
    }
    out.into_iter().collect()
}

/// Keywords after which `::raykit_device` starts a path.
fn is_keyword(word: &str) -> bool {
    matches!(
        word,
        "impl"
            | "for"
            | "as"
            | "dyn"
            | "in"
            | "where"
            | "let"
            | "const"
            | "static"
            | "fn"
            | "mut"
            | "return"
            | "use"
            | "type"
            | "if"
            | "else"
            | "match"
            | "move"
            | "ref"
            | "break"
            | "unsafe"
            | "pub"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rewrites_the_root_everywhere_but_inside_longer_paths() {
        let tokens =
            quote!(impl ::raykit_device::LaunchParams for P { const L: ::raykit_device::X = a::raykit_device::Y; });
        let out = rewrite(tokens, &quote!(::raykit::device));
        assert_eq!(
            out.to_string(),
            quote!(impl ::raykit::device::LaunchParams for P { const L: ::raykit::device::X = a::raykit_device::Y; })
                .to_string()
        );
    }
}

//! `#[derive(Element)]`: a `#[repr(C)]` struct that a `Buffer<T>` can hold, its
//! fields one after the other in 32-bit words.
//!
//! The derive emits:
//! * the `Element` impl, reading and writing each field at the word after the
//!   previous field's last;
//! * compile-time checks, on every target, that the compiler put each field at
//!   4 × its first word (so the host's bytes are the device's words), each naming
//!   its field;
//! * the layout as a `Shape::Struct`, for the check against the SPIR-V;
//! * in a device crate only: a hidden compute entry point (`__raykit_element__<Struct>`) that
//!   declares the struct as its push constants, so the SPIR-V records the layout
//!   the device compiler gave it, and a host test (run by `cargo xtask
//!   build-shaders` with the params layout tests) that compares the two.

use proc_macro2::TokenStream;
use quote::{format_ident, quote, quote_spanned};
use syn::spanned::Spanned;
use syn::{Data, DeriveInput, Fields};

use crate::launch_params::{has_repr_c, refuse};

pub fn derive(input: TokenStream) -> TokenStream {
    match try_derive(input) {
        Ok(t) => t,
        Err(e) => e.to_compile_error(),
    }
}

fn try_derive(input: TokenStream) -> syn::Result<TokenStream> {
    let input: DeriveInput = syn::parse2(input)?;
    let name = &input.ident;
    if !input.generics.params.is_empty() {
        return Err(syn::Error::new(input.generics.span(), "a buffer element cannot be generic"));
    }
    let Data::Struct(data) = &input.data else {
        return Err(syn::Error::new(input.span(), "a buffer element must be a struct"));
    };
    if !has_repr_c(&input) {
        return Err(syn::Error::new(
            name.span(),
            "a buffer element needs `#[repr(C)]`, so host and device lay the fields out by the same rules",
        ));
    }
    let Fields::Named(fields) = &data.fields else {
        return Err(syn::Error::new(data.fields.span(), "a buffer element needs named fields"));
    };
    if fields.named.is_empty() {
        return Err(syn::Error::new(name.span(), "a buffer element needs at least one field"));
    }
    let mut errors: Option<syn::Error> = None;
    for field in &fields.named {
        if let (Some(ident), Some(reason)) = (&field.ident, refuse(&field.ty)) {
            let e = syn::Error::new(field.ty.span(), format!("field `{ident}`: {reason}"));
            match &mut errors {
                Some(all) => all.combine(e),
                None => errors = Some(e),
            }
        }
    }
    if let Some(e) = errors {
        return Err(e);
    }

    let element = quote!(::raykit_device::Element);
    let mut checks = Vec::new();
    let mut reads = Vec::new();
    let mut reads_unchecked = Vec::new();
    let mut writes = Vec::new();
    let mut writes_unchecked = Vec::new();
    let mut entries = Vec::new();
    // The first word of the field being emitted: the sum of the words before it.
    let mut first_word = quote!(0u32);
    for field in &fields.named {
        let Some(ident) = &field.ident else { continue };
        let ty = &field.ty;
        // `<T as Element>` with the field's span: a type that is not an element is
        // an error pointing at the field, with Element's explanation.
        let words = quote_spanned! {ty.span()=> <#ty as #element>::WORDS };
        let at = quote!((base + (#first_word) as usize));
        reads.push(quote! { #ident: <#ty as #element>::read(words, #at) });
        // SAFETY (of the generated code): the caller's, `base + WORDS <= words.len()`,
        // and this field's words lie within the element's.
        reads_unchecked.push(quote! { #ident: unsafe { <#ty as #element>::read_unchecked(words, #at) } });
        writes.push(quote! { <#ty as #element>::write(self.#ident, words, #at); });
        writes_unchecked.push(quote! { unsafe { <#ty as #element>::write_unchecked(self.#ident, words, #at) }; });
        let offset_message = format!(
            "buffer element `{name}`: field `{ident}` does not start right after the previous field's words \
             (4 bytes a word): there is padding before it, or its type is aligned to more than 4 bytes on this \
             target (glam's SIMD types); reorder the fields, add explicit `_pad: u32` fields, or use 4-byte-aligned \
             types (`Vec3`, `[f32; 4]`)"
        );
        let size_message = format!(
            "buffer element `{name}`: field `{ident}` takes more bytes on this target than its words \
             (`Element::WORDS` × 4); use a type without SIMD padding"
        );
        checks.push(quote_spanned! {ident.span()=>
            const _: () = ::core::assert!(
                ::core::mem::offset_of!(#name, #ident) == 4 * (#first_word) as usize,
                #offset_message
            );
            const _: () = ::core::assert!(::core::mem::size_of::<#ty>() == 4 * (#words) as usize, #size_message);
        });
        let field_name = ident.to_string();
        let type_name = quote!(#ty).to_string().replace(' ', "");
        entries.push(quote! {
            ::raykit_device::FieldLayout {
                name: #field_name,
                type_name: #type_name,
                offset: 4 * (#first_word),
                size: 4 * (#words),
                shape: <#ty as #element>::SHAPE,
            }
        });
        first_word = quote!(#first_word + #words);
    }
    let total_words = first_word;
    let struct_name = name.to_string();
    let tail_message = format!(
        "buffer element `{name}` has padding after its last field: add an explicit padding field at the end \
         (e.g. `_pad: u32`)"
    );
    let skip_test = skips_layout_test(&input)?;
    let probe = if crate::manifest::is_device_crate() { probe(name, skip_test) } else { quote!() };
    Ok(quote! {
        #(#checks)*
        const _: () = ::core::assert!(::core::mem::size_of::<#name>() == 4 * (#total_words) as usize, #tail_message);
        impl #element for #name {
            const WORDS: u32 = #total_words;
            const SHAPE: ::raykit_device::Shape = {
                const LAYOUT: ::raykit_device::ParamsLayout = ::raykit_device::ParamsLayout {
                    name: #struct_name,
                    size: 4 * (#total_words),
                    fields: &[#(#entries),*],
                };
                ::raykit_device::Shape::Struct(&LAYOUT)
            };
            #[inline]
            fn read(words: &[u32], base: usize) -> Self {
                #name { #(#reads),* }
            }
            #[inline]
            fn write(self, words: &mut [u32], base: usize) {
                #(#writes)*
            }
            #[inline]
            #[allow(unused_unsafe)]
            unsafe fn read_unchecked(words: &[u32], base: usize) -> Self {
                #name { #(#reads_unchecked),* }
            }
            #[inline]
            #[allow(unused_unsafe)]
            unsafe fn write_unchecked(self, words: &mut [u32], base: usize) {
                #(#writes_unchecked)*
            }
        }
        #probe
    })
}

/// The hidden entry point that records the struct's device layout in the SPIR-V, and the
/// host test that compares it with the host's.
fn probe(name: &syn::Ident, skip_test: bool) -> TokenStream {
    let entry_name = format!("{}{name}", raykit_abi::ELEMENT_LAYOUT_ENTRY_PREFIX);
    let function = format_ident!("__raykit_element_layout_{}", name);
    let test = format_ident!("__raykit_params_layout_element_{}", name);
    let table_set = proc_macro2::Literal::u32_unsuffixed(raykit_abi::BUFFER_TABLE_SET);
    let table_binding = proc_macro2::Literal::u32_unsuffixed(raykit_abi::BUFFER_TABLE_BINDING);
    let test = if skip_test {
        quote!()
    } else {
        quote! {
            #[cfg(test)]
            #[test]
            #[allow(non_snake_case)]
            fn #test() {
                let path = ::raykit_device::__private::raykit_spirv::built_spirv_path(
                    env!("CARGO_MANIFEST_DIR"),
                    env!("CARGO_PKG_NAME"),
                );
                if let Err(e) = ::raykit_device::__private::check_element_file::<#name>(&path) {
                    panic!("{} (in {})", e, path.display());
                }
            }
        }
    };
    quote! {
        #[cfg(target_arch = "spirv")]
        #[doc(hidden)]
        #[allow(non_snake_case)]
        #[::raykit_device::__private::spirv(compute(threads(1), entry_point_name = #entry_name))]
        pub fn #function(
            #[spirv(push_constant)] element: &#name,
            #[spirv(descriptor_set = #table_set, binding = #table_binding, storage_buffer)]
            buffers: &mut ::raykit_device::BufferTable,
        ) {
            ::raykit_device::__private::record_element(element, buffers);
        }

        #test
    }
}

/// Whether `#[element(skip_layout_test)]` is on the struct.
fn skips_layout_test(input: &DeriveInput) -> syn::Result<bool> {
    let mut skip = false;
    for attr in input.attrs.iter().filter(|a| a.path().is_ident("element")) {
        attr.parse_nested_meta(|meta| {
            if meta.path.is_ident("skip_layout_test") {
                skip = true;
                Ok(())
            } else {
                Err(meta.error("unknown `element` option; the one option is `skip_layout_test`"))
            }
        })?;
    }
    Ok(skip)
}

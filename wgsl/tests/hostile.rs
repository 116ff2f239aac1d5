//! Hostile and runaway WGSL: refused with typed errors, never a crash or an
//! unbounded compile. Each test runs on the test harness's small thread stack.

use raykit_wgsl::{
    compile, WgslError, MAX_DECLARATIONS, MAX_EXPRESSION_DEPTH, MAX_FUNCTION_TOKENS, MAX_NESTING, MAX_TOKENS,
    MEMORY_BUDGET,
};

/// A raygen whose body is `body`; its first line is line 4 of the source.
fn raygen(globals: &str, body: &str) -> String {
    format!("enable wgpu_ray_tracing_pipeline;\n{globals}\n@ray_generation\nfn rg() {{\n{body}\n}}\n")
}

fn refused(source: &str) -> WgslError {
    match compile(source, "hostile.wgsl") {
        Ok(_) => panic!("compiled"),
        Err(e) => e,
    }
}

fn compiles(source: &str) {
    if let Err(e) = compile(source, "fine.wgsl") {
        panic!("{e}");
    }
}

/// Asserts a [`WgslError::Limit`] at `at_line` with `at_limit`, returning its message.
fn limit(source: &str, at_line: u32, at_limit: usize) -> String {
    let err = refused(source);
    let WgslError::Limit { line, limit, .. } = &err else { panic!("{err:?}") };
    assert_eq!((*line, *limit), (at_line, at_limit), "{err}");
    err.to_string()
}

fn chain(terms: usize) -> String {
    let mut s = String::from("y");
    for _ in 1..terms {
        s.push_str(" + y");
    }
    s
}

#[test]
fn a_chain_of_50000_additions_is_refused_naming_line_and_limit() {
    let source = raygen("", &format!("    var y: f32 = 2.0;\n    var x: f32 = {};", chain(50_000)));
    let message = limit(&source, 6, MAX_EXPRESSION_DEPTH);
    assert!(message.contains("hostile.wgsl:6:") && message.contains("split the expression"), "{message}");
    assert!(message.contains(&MAX_EXPRESSION_DEPTH.to_string()), "{message}");
}

#[test]
fn a_chain_within_the_limit_compiles_on_nagas_own_stack() {
    // About 7 KiB of stack per term in an unoptimised naga: more than the test
    // thread's 2 MiB, well within naga's thread's.
    compiles(&raygen("", &format!("    var y: f32 = 2.0;\n    var x: f32 = {};", chain(1000))));
}

#[test]
fn deep_parentheses_are_refused_and_shallow_ones_compile() {
    let deep = raygen("", &format!("    var x: f32 = {}1.0{};", "(".repeat(50_000), ")".repeat(50_000)));
    let message = limit(&deep, 5, MAX_NESTING);
    assert!(message.contains("nesting"), "{message}");
    compiles(&raygen("", &format!("    var x: f32 = {}1.0{};", "(".repeat(60), ")".repeat(60))));
}

#[test]
fn unary_and_postfix_chains_are_refused() {
    limit(&raygen("", &format!("    var x: bool = {}true;", "!".repeat(50_000))), 5, MAX_EXPRESSION_DEPTH);
    limit(&raygen("", &format!("    var x: bool = {}true;", "! ".repeat(50_000))), 5, MAX_EXPRESSION_DEPTH);
    let swizzles = format!("    var x: f32 = vec4<f32>(1.0){}.x;", ".xyzw".repeat(50_000));
    limit(&raygen("", &swizzles), 5, MAX_EXPRESSION_DEPTH);
    let indices = format!("    var a = array<f32, 1>(1.0);\n    var x: f32 = a{};", "[0]".repeat(50_000));
    limit(&raygen("", &indices), 6, MAX_EXPRESSION_DEPTH);
}

#[test]
fn else_if_chains_count_as_nesting() {
    let chain = |n: usize| {
        let mut s = String::from("\n    if y > 0.0 { y = 1.0; }");
        for i in 0..n {
            s.push_str(&format!(" else if y > {i}.0 {{ y = 1.0; }}"));
        }
        s.push_str("\n    if y > 1.0 { y = 0.0; }");
        s
    };
    let var = "    var y: f32 = 2.0;";
    limit(&raygen("", &format!("{var}{}", chain(50_000))), 6, MAX_NESTING);
    // Chains end with their `if` statement: two of 40 in a row are fine.
    compiles(&raygen("", &format!("{var}{}{}", chain(40), chain(40))));
}

#[test]
fn too_many_declarations_are_refused() {
    let mut globals = String::new();
    for i in 0..50_000 {
        globals.push_str(&format!("const c{i} = c{};\n", i + 1));
    }
    globals.push_str("const c50000 = 1.0;");
    let err = refused(&raygen(&globals, "    var y: f32 = c0;"));
    let WgslError::Limit { limit, line, .. } = &err else { panic!("{err:?}") };
    assert_eq!((*limit, *line), (MAX_DECLARATIONS, MAX_DECLARATIONS as u32 + 2), "{err}");
}

#[test]
fn brackets_and_operators_in_comments_are_ignored() {
    let comment =
        format!("    // {}\n    /* {} /* nested */ {} */", "(+".repeat(5000), "[-".repeat(5000), "{".repeat(100));
    compiles(&raygen("", &format!("{comment}\n    var x: f32 = 1.0e-3 + 0x1p-3 + .5;")));
}

/// Asserts a [`WgslError::Memory`] naming `name` of `bytes` bytes.
fn over_budget(source: &str, name: &str, bytes: u64) -> String {
    let err = refused(source);
    let WgslError::Memory { variable, size, budget, .. } = &err else { panic!("{err:?}") };
    assert_eq!((variable.as_str(), *size, *budget), (name, bytes, MEMORY_BUDGET), "{err}");
    let message = err.to_string();
    assert!(message.contains(name) && message.contains("Buffer<T>"), "{message}");
    message
}

#[test]
fn a_16_mib_private_array_is_refused_naming_it() {
    let source = raygen("var<private> big: array<f32, 4194304>;", "    big[7] = 1.0;");
    let message = over_budget(&source, "big", 16 << 20);
    assert!(message.contains("var<private>") && message.contains("`rg`"), "{message}");
}

#[test]
fn a_big_function_local_array_is_refused_also_in_a_callee() {
    let source = raygen("", "    var big: array<vec4<f32>, 8192>;\n    big[3].x = 1.0;");
    over_budget(&source, "rg::big", 128 << 10);
    let helper =
        "fn helper(i: u32) -> f32 {\n    var table: array<f32, 20000>;\n    table[i] = 1.0;\n    return table[0];\n}";
    let source = raygen(helper, "    var x = helper(1u);");
    over_budget(&source, "helper::table", 80_000);
}

#[test]
fn private_and_local_memory_add_up_per_entry_point() {
    // 32 KiB private + 32 KiB - 4 bytes local: just under the budget.
    let globals = "var<private> a: array<f32, 8192>;";
    let body = |n: usize| format!("    var b: array<f32, {n}>;\n    a[1] = 1.0;\n    b[1] = a[1];");
    let under = MEMORY_BUDGET as usize / 8 - 1;
    compiles(&raygen(globals, &body(under)));
    let err = refused(&raygen(globals, &body(under + 2)));
    let WgslError::Memory { total, variable, .. } = &err else { panic!("{err:?}") };
    assert_eq!((*total, variable.as_str()), (MEMORY_BUDGET + 4, "rg::b"), "{err}");
    // A private array another entry point uses does not count against this one.
    let other = "var<private> c: array<f32, 16000>;\nvar<incoming_ray_payload> p: f32;\n\
                 @miss @incoming_payload(p)\nfn ms() {\n    c[1] = 1.0;\n    p = c[1];\n}";
    compiles(&raygen(&format!("{globals}\n{other}"), &body(under)));
}

#[test]
fn huge_values_and_payloads_are_refused() {
    let source = raygen("", "    let zeros = array<f32, 4194304>();\n    var x = zeros[0];");
    let err = refused(&source);
    assert!(matches!(err, WgslError::Memory { .. }), "{err:?}");
    let source = raygen("const BIG = array<f32, 4194304>();", "    var i = 3u;\n    var x = BIG[i];");
    over_budget(&source, "BIG", 16 << 20);
    let source = raygen("var<ray_payload> payload: array<f32, 4194304>;", "    payload[0] = 1.0;");
    over_budget(&source, "payload", 16 << 20);
}

#[test]
fn the_deepest_source_the_limits_allow_compiles() {
    let chain = chain(MAX_EXPRESSION_DEPTH - 24);
    let opened = "    {\n".repeat(MAX_NESTING - 4);
    let closed = "    }\n".repeat(MAX_NESTING - 4);
    compiles(&raygen("", &format!("    var y: f32 = 1.0;\n{opened}    y = {chain};\n{closed}")));
    let mut globals = String::new();
    for i in 0..MAX_DECLARATIONS - 8 {
        globals.push_str(&format!("const c{i} = c{};\n", i + 1));
    }
    globals.push_str(&format!("const c{} = 1.0;", MAX_DECLARATIONS - 8));
    compiles(&raygen(&globals, "    var y: f32 = c0;"));
}

#[test]
fn long_functions_and_sources_are_refused() {
    // `b = b + 1.0;` is 6 tokens; naga's front end is quadratic in a function's length.
    let statements = |n: usize| "    b = b + 1.0;\n".repeat(n);
    let long = raygen("", &format!("    var b = 1.0;\n{}", statements(MAX_FUNCTION_TOKENS / 6 + 1)));
    let message = limit(&long, 5 + (MAX_FUNCTION_TOKENS / 6) as u32, MAX_FUNCTION_TOKENS);
    assert!(message.contains("split the function"), "{message}");
    let function = |i: usize| format!("fn f{i}() {{\n    var b = 1.0;\n{}}}\n", statements(1000));
    let many: String = (0..MAX_TOKENS / 6000 + 1).map(function).collect();
    let err = refused(&raygen(&many, ""));
    assert!(matches!(&err, WgslError::Limit { limit, .. } if *limit == MAX_TOKENS), "{err:?}");
}

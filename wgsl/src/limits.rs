//! Limits on hostile or runaway WGSL: a scan of the source for depth that would
//! exhaust naga's recursion and length that would make it slow, and a
//! per-invocation memory budget checked on the validated module.

use naga::{AddressSpace, Block, Handle, Statement};

use crate::WgslError;

/// The most operators, calls, indexing and brackets on one path through an
/// expression (a chain `a + b + … ` counts each `+`; `,` and `;` start afresh).
pub const MAX_EXPRESSION_DEPTH: usize = 1024;

/// The deepest nesting of `(`, `[`, `{` and `else if` together.
pub const MAX_NESTING: usize = 64;

/// The most module-scope declarations (`fn`, `const`, `var`, `override`, `struct`,
/// `alias`, `const_assert`) in one source.
pub const MAX_DECLARATIONS: usize = 4096;

/// The most tokens in one module-scope declaration's brackets and braces (a
/// function's parameters and body): naga's front end takes time quadratic in a
/// function's length.
pub const MAX_FUNCTION_TOKENS: usize = 16384;

/// The most tokens in one source: with [`MAX_FUNCTION_TOKENS`] this bounds
/// naga's time (seconds in an unoptimised build).
pub const MAX_TOKENS: usize = 1 << 18;

/// The most bytes one invocation of an entry point may hold in `var<private>`,
/// ray payload and `var<function>` variables (its own and its callees'); no
/// constant or value may exceed it alone.
pub const MEMORY_BUDGET: u64 = 64 * 1024;

/// The stack of the thread that runs naga.
pub const STACK_SIZE: usize = 64 << 20;

/// Two- and three-character operators, which WGSL's lexer reads as one token.
const LONG_OPERATORS: &[&str] = &[
    "<<=", ">>=", "==", "!=", "<=", ">=", "&&", "||", "->", "+=", "-=", "*=", "/=", "%=", "&=", "|=", "^=", "<<", ">>",
    "++", "--",
];

const DECLARATION_KEYWORDS: &[&str] = &["fn", "const", "var", "override", "struct", "alias", "const_assert"];

/// A bracket level of the scan.
#[derive(Default)]
struct Level {
    /// Operators and opened brackets counted in the current segment.
    ops: usize,
    /// `else if`s of the current `if` statement at this level.
    else_ifs: usize,
}

struct Scan<'a> {
    source: &'a str,
    path: &'a str,
    levels: Vec<Level>,
    /// The sum of `ops` over `levels`.
    depth: usize,
    /// Open brackets plus the sum of `else_ifs` over `levels`.
    nesting: usize,
    declarations: usize,
    /// Tokens inside the current module-scope declaration's brackets.
    tokens: usize,
    /// Tokens in the whole source.
    all_tokens: usize,
    line: u32,
    line_start: usize,
}

impl Scan<'_> {
    fn refuse(&self, at: usize, what: &'static str, limit: usize, fix: &'static str) -> WgslError {
        let column = self.source.get(self.line_start..at).map_or(0, |s| s.chars().count()) + 1;
        WgslError::Limit {
            path: self.path.to_owned(),
            line: self.line,
            column: u32::try_from(column).unwrap_or(u32::MAX),
            what,
            limit,
            fix,
        }
    }

    fn current(&mut self) -> &mut Level {
        if self.levels.is_empty() {
            self.levels.push(Level::default());
        }
        let last = self.levels.len() - 1;
        &mut self.levels[last]
    }

    fn operator(&mut self, at: usize) -> Result<(), WgslError> {
        self.current().ops += 1;
        self.depth += 1;
        if self.depth > MAX_EXPRESSION_DEPTH {
            return Err(self.refuse(
                at,
                "an expression with more operators, calls and brackets on one path than",
                MAX_EXPRESSION_DEPTH,
                "split the expression into `let` bindings",
            ));
        }
        Ok(())
    }

    fn end_segment(&mut self) {
        let ops = std::mem::take(&mut self.current().ops);
        self.depth = self.depth.saturating_sub(ops);
    }

    fn end_if_chain(&mut self) {
        let else_ifs = std::mem::take(&mut self.current().else_ifs);
        self.nesting = self.nesting.saturating_sub(else_ifs);
    }

    fn nest(&mut self, at: usize) -> Result<(), WgslError> {
        self.nesting += 1;
        if self.nesting > MAX_NESTING {
            return Err(self.refuse(
                at,
                "nesting of brackets, braces and `else if` deeper than",
                MAX_NESTING,
                "move inner blocks into functions or split the expression into `let` bindings",
            ));
        }
        Ok(())
    }

    fn open(&mut self, at: usize) -> Result<(), WgslError> {
        self.nest(at)?;
        self.levels.push(Level::default());
        Ok(())
    }

    fn close(&mut self) {
        // The root level stays; unbalanced brackets are naga's to report.
        if self.levels.len() > 1 {
            if let Some(level) = self.levels.pop() {
                self.depth = self.depth.saturating_sub(level.ops);
                self.nesting = self.nesting.saturating_sub(1 + level.else_ifs);
            }
        }
    }
}

/// Refuses source whose expressions, nesting or declarations exceed the limits
/// above, before naga recurses over it. Conservative: it counts tokens, not
/// naga's tree, so it may refuse what naga would take, never the reverse.
pub(crate) fn scan(source: &str, path: &str) -> Result<(), WgslError> {
    let mut s = Scan {
        source,
        path,
        levels: vec![Level::default()],
        depth: 0,
        nesting: 0,
        declarations: 0,
        tokens: 0,
        all_tokens: 0,
        line: 1,
        line_start: 0,
    };
    let bytes = source.as_bytes();
    let mut i = 0;
    let mut previous_else = false;
    let mut previous_close_brace = false;
    while let Some(&c) = bytes.get(i) {
        let start = i;
        if c == b'\n' {
            s.line += 1;
            i += 1;
            s.line_start = i;
            continue;
        }
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        if bytes[i..].starts_with(b"//") {
            while bytes.get(i).is_some_and(|&b| b != b'\n') {
                i += 1;
            }
            continue;
        }
        if bytes[i..].starts_with(b"/*") {
            // Block comments nest in WGSL.
            let mut open = 0usize;
            while i < bytes.len() {
                if bytes[i..].starts_with(b"/*") {
                    open += 1;
                    i += 2;
                } else if bytes[i..].starts_with(b"*/") {
                    open = open.saturating_sub(1);
                    i += 2;
                    if open == 0 {
                        break;
                    }
                } else {
                    if bytes[i] == b'\n' {
                        s.line += 1;
                        s.line_start = i + 1;
                    }
                    i += 1;
                }
            }
            continue;
        }
        // A `}` ends an `if … else if …` chain unless `else` follows.
        let is_else = bytes[i..].starts_with(b"else") && !bytes.get(i + 4).is_some_and(|&b| is_word(b));
        if previous_close_brace && !is_else {
            s.end_if_chain();
        }
        previous_close_brace = false;
        let was_else = std::mem::take(&mut previous_else);
        s.all_tokens += 1;
        if s.all_tokens > MAX_TOKENS {
            return Err(s.refuse(start, "a source with more tokens than", MAX_TOKENS, "split the module"));
        }
        if s.levels.len() == 1 {
            s.tokens = 0;
        } else {
            s.tokens += 1;
            if s.tokens > MAX_FUNCTION_TOKENS {
                return Err(s.refuse(
                    start,
                    "a function with more tokens than",
                    MAX_FUNCTION_TOKENS,
                    "split the function into smaller ones",
                ));
            }
        }
        if is_word(c) && !c.is_ascii_digit() {
            while bytes.get(i).is_some_and(|&b| is_word(b)) {
                i += 1;
            }
            let word = source.get(start..i).unwrap_or_default();
            match word {
                "else" => previous_else = true,
                "if" if was_else => {
                    s.current().else_ifs += 1;
                    s.nest(start)?;
                }
                "if" => s.end_if_chain(),
                _ if s.levels.len() == 1 && DECLARATION_KEYWORDS.contains(&word) => {
                    s.declarations += 1;
                    if s.declarations > MAX_DECLARATIONS {
                        return Err(s.refuse(
                            start,
                            "more module-scope declarations than",
                            MAX_DECLARATIONS,
                            "merge constants into arrays or split the module",
                        ));
                    }
                }
                _ => {}
            }
            continue;
        }
        if c.is_ascii_digit() || (c == b'.' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            i = number_end(bytes, i);
            continue;
        }
        i += 1;
        match c {
            b'(' | b'[' => {
                s.operator(start)?;
                s.open(start)?;
            }
            b'{' => {
                s.end_segment();
                s.open(start)?;
            }
            b')' | b']' => s.close(),
            b'}' => {
                s.close();
                s.end_segment();
                previous_close_brace = true;
            }
            b',' => s.end_segment(),
            b';' => {
                s.end_segment();
                s.end_if_chain();
            }
            b'+' | b'-' | b'*' | b'/' | b'%' | b'&' | b'|' | b'^' | b'!' | b'~' | b'<' | b'>' | b'=' | b'.' => {
                if let Some(long) = LONG_OPERATORS.iter().find(|op| bytes[start..].starts_with(op.as_bytes())) {
                    i = start + long.len();
                }
                s.operator(start)?;
            }
            _ => {}
        }
    }
    Ok(())
}

/// Identifier characters (any non-ASCII byte counts: WGSL identifiers may be Unicode).
fn is_word(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_' || !b.is_ascii()
}

/// The end of a numeric literal starting at `i` (decimal or hex, with exponent).
fn number_end(bytes: &[u8], mut i: usize) -> usize {
    let hex = bytes.get(i) == Some(&b'0') && matches!(bytes.get(i + 1), Some(b'x' | b'X'));
    while let Some(&b) = bytes.get(i) {
        let exponent_sign = matches!(b, b'+' | b'-')
            && i > 0
            && if hex { matches!(bytes[i - 1], b'p' | b'P') } else { matches!(bytes[i - 1], b'e' | b'E') };
        if b.is_ascii_alphanumeric() || b == b'_' || b == b'.' || exponent_sign {
            i += 1;
        } else {
            break;
        }
    }
    i
}

/// A variable or value counted against [`MEMORY_BUDGET`].
#[derive(Clone)]
struct Item {
    name: String,
    space: &'static str,
    size: u64,
}

/// A function's per-invocation memory with its deepest callees, and its largest item.
#[derive(Clone, Default)]
struct Cost {
    total: u64,
    largest: Option<Item>,
}

impl Cost {
    fn add(&mut self, item: Item) {
        self.total = self.total.saturating_add(item.size);
        if self.largest.as_ref().is_none_or(|l| item.size > l.size) {
            self.largest = Some(item);
        }
    }

    fn add_callee(&mut self, callee: &Cost) {
        self.total = self.total.saturating_add(callee.total);
        if let Some(item) = &callee.largest {
            if self.largest.as_ref().is_none_or(|l| item.size > l.size) {
                self.largest = Some(item.clone());
            }
        }
    }
}

/// Refuses a validated module whose entry points need more than [`MEMORY_BUDGET`]
/// bytes per invocation: private and ray payload variables the entry point uses,
/// plus function-local variables along its heaviest call path; and any constant or
/// value larger than the budget.
pub(crate) fn check_memory(module: &naga::Module, info: &naga::valid::ModuleInfo, path: &str) -> Result<(), WgslError> {
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .map_err(|e| WgslError::Internal { path: path.to_owned(), reason: format!("type layout: {e}") })?;
    let size = |ty: Handle<naga::Type>| u64::from(layouter[ty].size);
    let refuse = |item: Item, entry_point: Option<&str>| WgslError::Memory {
        path: path.to_owned(),
        entry_point: entry_point.map(str::to_owned),
        variable: item.name,
        space: item.space,
        size: item.size,
        total: item.size,
        budget: MEMORY_BUDGET,
    };
    for (_, constant) in module.constants.iter() {
        let bytes = size(constant.ty);
        if bytes > MEMORY_BUDGET {
            let name = constant.name.clone().unwrap_or_else(|| "(unnamed)".to_owned());
            return Err(refuse(Item { name, space: "const", size: bytes }, None));
        }
    }
    // naga's validator orders callees before their callers, so each call finds
    // its callee's cost already computed.
    let mut costs: Vec<Cost> = Vec::with_capacity(module.functions.len());
    for (handle, function) in module.functions.iter() {
        let cost = function_cost(module, function, &info[handle], &costs, &size).map_err(|item| refuse(item, None))?;
        costs.push(cost);
    }
    for (index, entry) in module.entry_points.iter().enumerate() {
        let entry_info = info.get_entry_point(index);
        let mut cost = function_cost(module, &entry.function, entry_info, &costs, &size)
            .map_err(|item| refuse(item, Some(&entry.name)))?;
        for (handle, var) in module.global_variables.iter() {
            let space = match var.space {
                AddressSpace::Private => "var<private>",
                AddressSpace::RayPayload => "var<ray_payload>",
                AddressSpace::IncomingRayPayload => "var<incoming_ray_payload>",
                _ => continue,
            };
            if entry_info[handle].is_empty() {
                continue;
            }
            let name = var.name.clone().unwrap_or_else(|| "(unnamed)".to_owned());
            cost.add(Item { name, space, size: size(var.ty) });
        }
        if cost.total > MEMORY_BUDGET {
            let Some(largest) = cost.largest else { continue };
            return Err(WgslError::Memory {
                path: path.to_owned(),
                entry_point: Some(entry.name.clone()),
                variable: largest.name,
                space: largest.space,
                size: largest.size,
                total: cost.total,
                budget: MEMORY_BUDGET,
            });
        }
    }
    Ok(())
}

/// A function's locals plus its heaviest callee; `Err` names a value over the budget.
fn function_cost(
    module: &naga::Module,
    function: &naga::Function,
    info: &naga::valid::FunctionInfo,
    costs: &[Cost],
    size: &dyn Fn(Handle<naga::Type>) -> u64,
) -> Result<Cost, Item> {
    let function_name = function.name.as_deref().unwrap_or("(unnamed)");
    let mut cost = Cost::default();
    for (_, local) in function.local_variables.iter() {
        let name = format!("{function_name}::{}", local.name.as_deref().unwrap_or("(unnamed)"));
        cost.add(Item { name, space: "var<function>", size: size(local.ty) });
    }
    for (handle, _) in function.expressions.iter() {
        let bytes = match &info[handle].ty {
            naga::proc::TypeResolution::Handle(ty) => size(*ty),
            naga::proc::TypeResolution::Value(inner) => u64::from(inner.try_size(module.to_ctx()).unwrap_or(0)),
        };
        if bytes > MEMORY_BUDGET {
            let name = match function.named_expressions.get(&handle) {
                Some(name) => format!("{function_name}::{name}"),
                None => format!("a value in {function_name}"),
            };
            return Err(Item { name, space: "value", size: bytes });
        }
    }
    let mut heaviest: Option<&Cost> = None;
    calls(&function.body, &mut |callee| {
        if let Some(c) = costs.get(callee.index()) {
            if heaviest.is_none_or(|h| c.total > h.total) {
                heaviest = Some(c);
            }
        }
    });
    if let Some(callee) = heaviest {
        cost.add_callee(callee);
    }
    Ok(cost)
}

/// Calls `f` with each function called in `block` (nesting is bounded by [`MAX_NESTING`]).
fn calls(block: &Block, f: &mut dyn FnMut(Handle<naga::Function>)) {
    for statement in block.iter() {
        match statement {
            Statement::Call { function, .. } => f(*function),
            Statement::Block(inner) => calls(inner, f),
            Statement::If { accept, reject, .. } => {
                calls(accept, f);
                calls(reject, f);
            }
            Statement::Switch { cases, .. } => cases.iter().for_each(|case| calls(&case.body, f)),
            Statement::Loop { body, continuing, .. } => {
                calls(body, f);
                calls(continuing, f);
            }
            _ => {}
        }
    }
}

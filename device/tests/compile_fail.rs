//! Misuse of raykit's device macros is a compile error with a message that says
//! what to do instead (trybuild compares the messages with `ui/*.stderr`).

#[test]
fn macro_misuse_is_a_compile_error() {
    let cases = trybuild::TestCases::new();
    cases.compile_fail("tests/ui/*.rs");
}

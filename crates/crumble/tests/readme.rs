//! The quick start in the crate's README.md is the front page's doctest
//! (`src/lib.rs`, run by `cargo test --doc`): the two copies must match,
//! so that the README's example is one that compiles and passes.

/// The lines of the first fenced code block that opens with `fence`.
fn first_block<'a>(lines: impl Iterator<Item = &'a str>, fence: &str) -> Vec<&'a str> {
    let mut lines = lines.skip_while(|l| *l != fence);
    assert!(lines.next().is_some(), "no block opening with {fence:?}");
    lines.take_while(|l| *l != "```").collect()
}

#[test]
fn readme_quick_start_is_the_front_page_doctest() {
    let readme = include_str!("../README.md");
    let lib = include_str!("../src/lib.rs");
    let front_page = lib
        .lines()
        .take_while(|l| l.starts_with("//!"))
        .map(|l| l.strip_prefix("//! ").unwrap_or(l.trim_start_matches("//!")));
    let in_lib = first_block(front_page, "```");
    let in_readme = first_block(readme.lines(), "```rust");
    assert!(in_lib.len() > 10, "the front page's quick start is {} lines", in_lib.len());
    assert_eq!(in_readme, in_lib, "README.md's quick start differs from src/lib.rs's doctest");
}

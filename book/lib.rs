//! The book's Rust code blocks, compiled and run as doctests of this crate.
//! Each chapter is included here so `cargo test --doc -p hybrid-book` checks it.

//! The pod simulator (placeholder until the acquisition demo lands).
fn main() {}

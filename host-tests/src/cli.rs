//! The host commands' command lines.

/// The command line parsed into `A`. The cargo aliases (`cargo sim`, `cargo replay`, …) end in
/// `--`, so `cargo sim -- --seed 3` hands the binary a leading `--`: it is dropped, and both
/// spellings work.
pub fn parse<A: clap::Parser>() -> A {
    let mut raw: Vec<String> = std::env::args().collect();
    if raw.get(1).is_some_and(|a| a == "--") {
        raw.remove(1);
    }
    A::parse_from(raw)
}

//! The `modalflow` command line; all logic lives in the library and `cli`.

mod cli;

/// Counts the heap and enforces `--max-memory` as a bound on the run.
#[global_allocator]
static HEAP: modalflow::heap::Bounded = modalflow::heap::Bounded::new();

fn main() -> std::process::ExitCode {
    cli::main()
}

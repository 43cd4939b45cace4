//! The `frictionlab` command: a thin shell over the library.

fn main() -> std::process::ExitCode {
    frictionlab::cli::main()
}

//! `thermcomp`: build, inspect, run and evaluate thermal-error compensation
//! models for CNC machine tools (CONTRACT.md section 1). The whole command
//! line lives in the library's `cli` module.

fn main() -> std::process::ExitCode {
    host_tools::cli::main()
}

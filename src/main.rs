//! The `pathmix` command line. The engine knows no terminal: progress display,
//! messages and exit codes live here.

mod cli;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let process_start = std::time::Instant::now();
    // Rust ignores SIGPIPE, so printing into a closed pipe (`pathmix info | head
    // -1`) fails and `println!` panics. Every command's output is either
    // complete or not wanted any more once its reader has gone, and files are
    // written atomically: end quietly, as Unix tools do.
    #[cfg(unix)]
    // SAFETY: no other thread exists yet, and SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Mesa's device-select Vulkan layer probes for a Wayland display and prints
    // an error on headless machines; pathmix chooses the adapter itself.
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: no other thread exists yet.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
    let args = cli::Cli::parse();
    match cli::run(args, process_start) {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            eprintln!("pathmix: error: {}", failure.message);
            ExitCode::from(failure.code)
        }
    }
}

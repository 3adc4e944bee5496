//! `contact-skin`: command-line front end. See `contact-skin --help`.

mod cli;

fn main() {
    die_quietly_on_a_closed_pipe();
    let code = cli::run();
    std::process::exit(code);
}

/// Lets a write to a closed pipe end the process quietly (`contact-skin info x.glb | head -1`),
/// as other Unix tools do. Rust's runtime ignores `SIGPIPE`, so such a write fails and
/// `println!` panics instead (exit 101 and a panic message). The files a command writes are
/// committed before it prints its summary, so nothing is left half done by this.
#[cfg(unix)]
fn die_quietly_on_a_closed_pipe() {
    // SAFETY: restoring the default disposition of one signal, before any thread starts, with
    // no handler of ours involved.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

#[cfg(not(unix))]
fn die_quietly_on_a_closed_pipe() {}

//! `contact-skin`: command-line front end. See `contact-skin --help`.

mod cli;

fn main() {
    let code = cli::run();
    std::process::exit(code);
}

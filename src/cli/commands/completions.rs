//! `modalflow completions SHELL`: a completion script for bash, zsh or fish.

/// Print a shell completion script on stdout (clap_complete).
///
/// bash: `modalflow completions bash > ~/.local/share/bash-completion/completions/modalflow`;
/// zsh: `modalflow completions zsh > ~/.zfunc/_modalflow` (with `fpath+=~/.zfunc`);
/// fish: `modalflow completions fish > ~/.config/fish/completions/modalflow.fish`.
#[derive(clap::Args)]
pub struct Args {
    #[arg(value_enum)]
    shell: Shell,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Shell {
    Bash,
    Zsh,
    Fish,
}

pub fn exec(args: Args, cli: &mut clap::Command) -> anyhow::Result<u8> {
    use clap_complete::{generate, shells};
    let mut out = Vec::new();
    match args.shell {
        Shell::Bash => generate(shells::Bash, cli, "modalflow", &mut out),
        Shell::Zsh => generate(shells::Zsh, cli, "modalflow", &mut out),
        Shell::Fish => generate(shells::Fish, cli, "modalflow", &mut out),
    }
    crate::cli::output::print_text(&String::from_utf8_lossy(&out))?;
    Ok(crate::cli::exit::SUCCESS)
}

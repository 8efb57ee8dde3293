//! `mtwin completions SHELL` and `mtwin man --out-dir DIR`: shell completion
//! scripts and man pages generated from the same clap definition as the
//! parser, so they cannot disagree with it.

use std::path::PathBuf;

use anyhow::Context;
use clap::CommandFactory;
use serde_json::json;

use crate::output::{Format, print_json};

#[derive(Debug, clap::Args)]
pub struct CompletionsArgs {
    /// The shell to write the completion script for (printed on stdout).
    #[arg(value_enum)]
    shell: clap_complete::Shell,
}

#[derive(Debug, clap::Args)]
pub struct ManArgs {
    /// Folder for the man pages (created if absent): mtwin.1 and one page per subcommand.
    #[arg(long)]
    out_dir: PathBuf,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run_completions(a: CompletionsArgs) -> anyhow::Result<()> {
    let mut cmd = crate::Cli::command();
    // Rendered first: the generators panic on a failed write, and stdout may be a closed pipe.
    let mut buf = Vec::new();
    clap_complete::generate(a.shell, &mut cmd, "mtwin", &mut buf);
    crate::output::write_stdout(&buf);
    Ok(())
}

/// Every command of the tree (display names `mtwin`, `mtwin-ballbar`, … after `build`).
fn pages(cmd: &clap::Command, out: &mut Vec<clap::Command>) {
    for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
        pages(sub, out);
    }
    out.push(cmd.clone());
}

pub fn run_man(a: ManArgs) -> anyhow::Result<()> {
    let mut cmd = crate::Cli::command().disable_help_subcommand(true);
    cmd.build();
    let mut list = Vec::new();
    pages(&cmd, &mut list);
    let paths: Vec<PathBuf> = list
        .iter()
        .map(|c| {
            a.out_dir
                .join(clap_mangen::Man::new(c.clone()).get_filename())
        })
        .collect();
    let mut out = mtwin::io::Outputs::plan()
        .folder(&a.out_dir)
        .outputs(&paths)
        .begin()?;
    let mut written = Vec::new();
    for (c, path) in list.into_iter().zip(&paths) {
        let man = clap_mangen::Man::new(c);
        let mut buf = Vec::new();
        man.render(&mut buf)
            .with_context(|| format!("cannot render {}", man.get_filename()))?;
        out.write(path, &buf)
            .with_context(|| format!("cannot write {}", path.display()))?;
        written.push(path.display().to_string());
    }
    out.commit()?;
    match a.format {
        Format::Json => print_json(&json!({"pages": written.len(), "files": written})),
        Format::Human => {
            println!("{} man pages → {}", written.len(), a.out_dir.display());
            Ok(())
        }
    }
}

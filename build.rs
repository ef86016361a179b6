//! Embeds the git commit the binary is built from, so that experiment reports
//! name it even where the binary runs outside a checkout (the GPU machine).

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    let commit = git(&["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".into());
    // Tracked files changed since the commit: the build is not that commit.
    // Without optional locks `git status` does not rewrite the index it
    // refreshes, which would rerun this script (it watches the index) and
    // rebuild the crate on the next cargo command.
    let modified =
        git(&["--no-optional-locks", "status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
    let suffix = if modified { "-modified" } else { "" };
    println!("cargo:rustc-env=SHADESPACE_GIT_COMMIT={commit}{suffix}");
    for path in ["src", "Cargo.toml", "build.rs"] {
        println!("cargo:rerun-if-changed={path}");
    }
    // What moves HEAD's commit: HEAD itself, the branch it names (not every
    // branch: other worktrees commit to theirs) and packed refs. Only paths
    // that exist: cargo reruns the script on every build while a watched
    // path is missing (a repository often has no `packed-refs`).
    let mut watched = Vec::new();
    if let Some(dir) = git(&["rev-parse", "--git-dir"]) {
        watched.extend([format!("{dir}/HEAD"), format!("{dir}/index")]);
    }
    if let Some(dir) = git(&["rev-parse", "--git-common-dir"]) {
        if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
            watched.push(format!("{dir}/{branch}"));
        }
        watched.push(format!("{dir}/packed-refs"));
    }
    for path in watched.iter().filter(|p| std::path::Path::new(p).exists()) {
        println!("cargo:rerun-if-changed={path}");
    }
}

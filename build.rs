//! Names the code a plan's runs come from (`fitslam plan` writes it, `fitslam run` checks it):
//! the package version and the git commit it was built from, `-dirty` with uncommitted changes to
//! tracked files, `unknown` outside a git checkout.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    let commit = git(&["rev-parse", "--short=12", "HEAD"]).unwrap_or_else(|| "unknown".into());
    let dirty = git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
    let version = std::env::var("CARGO_PKG_VERSION").unwrap_or_default();
    println!("cargo:rustc-env=FITSLAM_CODE=fitslam {version} {commit}{}", if dirty { "-dirty" } else { "" });
    // Again when HEAD moves or the index changes (a commit, a checkout, a `git add`).
    if let Some(dir) = git(&["rev-parse", "--git-dir"]) {
        for f in ["HEAD", "index"] {
            println!("cargo:rerun-if-changed={dir}/{f}");
        }
        if let (Some(head_ref), Some(common)) = (git(&["symbolic-ref", "-q", "HEAD"]), git(&["rev-parse", "--git-common-dir"])) {
            println!("cargo:rerun-if-changed={common}/{head_ref}");
        }
    }
    // And when the code changes (for `-dirty`).
    for d in ["build.rs", "src", "core/src", "msgs/src", "Cargo.toml", "Cargo.lock"] {
        println!("cargo:rerun-if-changed={d}");
    }
}

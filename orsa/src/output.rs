//! What a command writes: lines on stdout that a reader may stop reading, and files in folders
//! that may not exist yet.

use anyhow::Context as _;

/// Creates the folder `path` will be written in, if it is missing; the error names it.
pub fn ensure_parent(path: &std::path::Path) -> anyhow::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the folder", dir.display()))?;
    }
    Ok(())
}

/// Prints a line to stdout; a reader that went away (`orsa run | head`) is not an error.
pub fn say(text: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stdout().lock(), "{text}");
}

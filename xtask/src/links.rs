//! The book's internal link check: every relative link and image in
//! `README.md` and `docs/src/**/*.md` names a file that exists, and every
//! `#anchor` a heading of its page, with the ids mdBook gives headings
//! (lower case, spaces as `-`, other punctuation dropped, `-1`, `-2` for a
//! repeated heading). Links out of the project (`https:` and the like) are
//! not followed.

use std::fs;
use std::path::{Path, PathBuf};

/// The Markdown files checked: the README and every page of the book.
pub fn pages(root: &Path) -> Result<Vec<PathBuf>, String> {
    let mut out = vec![root.join("README.md")];
    let mut dirs = vec![root.join("docs").join("src")];
    while let Some(dir) = dirs.pop() {
        let entries = fs::read_dir(&dir).map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
        for entry in entries {
            let path = entry.map_err(|e| format!("cannot read {}: {e}", dir.display()))?.path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|x| x == "md") {
                out.push(path);
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Every broken link of `pages`, one line each naming the page and line.
pub fn check(pages: &[PathBuf]) -> Result<Vec<String>, String> {
    let mut broken = Vec::new();
    for page in pages {
        let text = read(page)?;
        for (line, target) in links(&text) {
            if let Err(why) = resolve(page, &text, &target) {
                broken.push(format!("{}:{line}: ({target}) {why}", page.display()));
            }
        }
    }
    Ok(broken)
}

fn read(path: &Path) -> Result<String, String> {
    fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))
}

/// Whether a link points out of the project.
fn is_external(target: &str) -> bool {
    let scheme = target.split_once(':').map(|(s, _)| s);
    scheme.is_some_and(|s| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c)))
}

fn resolve(page: &Path, text: &str, target: &str) -> Result<(), String> {
    if is_external(target) {
        return Ok(());
    }
    let (path, anchor) = match target.split_once('#') {
        Some((path, anchor)) => (path, Some(anchor)),
        None => (target, None),
    };
    let file = if path.is_empty() { page.to_owned() } else { page.parent().unwrap_or(Path::new(".")).join(path) };
    if !file.exists() {
        return Err(format!("{} does not exist", file.display()));
    }
    let Some(anchor) = anchor else { return Ok(()) };
    if file.extension().is_none_or(|x| x != "md") {
        return Err("an anchor into a file that is not a page".into());
    }
    let ids = if path.is_empty() { heading_ids(text) } else { heading_ids(&read(&file)?) };
    if ids.iter().any(|id| id == anchor) {
        Ok(())
    } else {
        Err(format!("no heading with the id `{anchor}` in {}", file.display()))
    }
}

/// The lines of `text` outside fenced code blocks, with their numbers.
fn prose(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut fence: Option<&str> = None;
    text.lines().enumerate().filter_map(move |(i, line)| {
        let trimmed = line.trim_start();
        let marker = ["```", "~~~"].into_iter().find(|m| trimmed.starts_with(m));
        match (fence, marker) {
            (None, Some(m)) => {
                fence = Some(m);
                None
            }
            (Some(open), Some(m)) if open == m => {
                fence = None;
                None
            }
            (Some(_), _) => None,
            (None, None) => Some((i + 1, line)),
        }
    })
}

/// A line with its inline code spans blanked out.
fn without_code(line: &str) -> String {
    let mut in_code = false;
    line.chars()
        .map(|c| {
            if c == '`' {
                in_code = !in_code;
                ' '
            } else if in_code {
                ' '
            } else {
                c
            }
        })
        .collect()
}

/// The targets of inline links and images (`[text](target)`), by line.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (number, line) in prose(text) {
        let line = without_code(line);
        let mut rest = line.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(end) = after.find(')') else { break };
            // A title after the target (`(file "title")`) is not part of it.
            let target = after[..end].split_whitespace().next().unwrap_or("");
            let target = target.trim_start_matches('<').trim_end_matches('>');
            if !target.is_empty() {
                out.push((number, target.to_owned()));
            }
            rest = &after[end..];
        }
    }
    out
}

/// The ids mdBook gives the headings of a page, in order.
fn heading_ids(text: &str) -> Vec<String> {
    let mut ids: Vec<String> = Vec::new();
    for (_, line) in prose(text) {
        let hashes = line.chars().take_while(|&c| c == '#').count();
        if !(1..=6).contains(&hashes) || !line[hashes..].starts_with(' ') {
            continue;
        }
        let id = id_from_heading(&line[hashes..]);
        let mut unique = id.clone();
        let mut n = 0;
        while ids.contains(&unique) {
            n += 1;
            unique = format!("{id}-{n}");
        }
        ids.push(unique);
    }
    ids
}

/// mdBook's id of a heading: its text (links and code reduced to their
/// words) in lower case, whitespace as `-`, and only letters, digits, `_`
/// and `-` kept.
fn id_from_heading(heading: &str) -> String {
    let mut text = String::new();
    let mut rest = heading.trim();
    // A link keeps its text, not its target.
    while let Some(open) = rest.find("](") {
        text.push_str(&rest[..open]);
        rest = rest[open..].find(')').map_or("", |close| &rest[open + close + 1..]);
    }
    text.push_str(rest);
    text.trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            c if c.is_alphanumeric() || c == '_' || c == '-' => Some(c),
            c if c.is_whitespace() => Some('-'),
            _ => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heading_ids_follow_mdbook() {
        let page = "# The skin\n\n## `skin run`: a real robot\n\n```sh\n# not a heading\n```\n\n## The skin\n\
                    ### [Calibration](calibration.md) (section 4)\n#no-space\n";
        assert_eq!(heading_ids(page), ["the-skin", "skin-run-a-real-robot", "the-skin-1", "calibration-section-4"]);
    }

    #[test]
    fn links_outside_code_are_found_with_their_lines() {
        let page = "See [a](a.md#x) and `[b](not.md)`.\n```\n[c](fenced.md)\n```\n![fig](img/f.svg \"title\")\n\
                    [web](https://example.org)\n";
        let found = links(page);
        assert_eq!(
            found,
            [(1, "a.md#x".to_owned()), (5, "img/f.svg".to_owned()), (6, "https://example.org".to_owned())]
        );
        assert!(is_external("https://example.org") && !is_external("a.md#x") && !is_external("#top"));
    }

    #[test]
    fn broken_files_and_anchors_are_named_and_good_links_pass() {
        let dir = std::env::temp_dir().join(format!("xtask-links-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let a = dir.join("a.md");
        fs::write(&a, "# Top\n\n[ok](b.md#second) [self](#top) [gone](c.md) [bad](b.md#third)\n").unwrap();
        fs::write(dir.join("b.md"), "# First\n## Second\n").unwrap();
        let broken = check(&[a]).unwrap();
        fs::remove_dir_all(&dir).unwrap();
        assert_eq!(broken.len(), 2, "{broken:?}");
        assert!(broken[0].contains(":3: (c.md) ") && broken[0].ends_with("does not exist"), "{broken:?}");
        assert!(broken[1].contains("no heading with the id `third`"), "{broken:?}");
    }
}

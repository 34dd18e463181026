//! An error message cut to what a terminal shows: a parser quoting the
//! offending line of a file with 200,000 characters on it, or a document
//! nested past reason, would otherwise print all of it.

/// The longest line printed, characters.
const MAX_LINE_CHARS: usize = 1000;
/// The most lines printed.
const MAX_LINES: usize = 24;

/// `message` with each line past [`MAX_LINE_CHARS`] cut and saying how
/// much was cut, and lines past [`MAX_LINES`] counted instead of printed.
pub fn cut(message: &str) -> String {
    let lines: Vec<&str> = message.lines().collect();
    let mut out: Vec<String> = lines.iter().take(MAX_LINES).map(|line| cut_line(line)).collect();
    if lines.len() > MAX_LINES {
        out.push(format!("... ({} more lines)", lines.len() - MAX_LINES));
    }
    out.join("\n")
}

fn cut_line(line: &str) -> String {
    let chars = line.chars().count();
    if chars <= MAX_LINE_CHARS {
        return line.to_owned();
    }
    let kept: String = line.chars().take(MAX_LINE_CHARS).collect();
    format!("{kept}... ({} more characters)", chars - MAX_LINE_CHARS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_lines_and_many_lines_are_cut_saying_how_much() {
        assert_eq!(cut("short\nlines"), "short\nlines");
        let long = format!("x = {}", "9".repeat(200_000));
        let cut_long = cut(&long);
        assert_eq!(cut_long.chars().count(), MAX_LINE_CHARS + " (199004 more characters)".len() + 3);
        assert!(cut_long.ends_with("... (199004 more characters)"), "{cut_long}");
        let many = "é\n".repeat(100);
        let cut_many = cut(&many);
        assert_eq!(cut_many.lines().count(), MAX_LINES + 1);
        assert!(cut_many.ends_with("... (76 more lines)"));
    }
}

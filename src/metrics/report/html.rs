//! `report.html` (`eval --html`): `report.md` rendered to HTML, its figures inline as `data:`
//! URIs, and each worst episode linked to its own page in `episodes/` (made by
//! [`crate::record::html`]). The HTML is rendered from the Markdown the report writer makes,
//! so the two never differ and no figure is computed twice; the renderer reads the subset that
//! writer emits (headings, paragraphs, lists, pipe tables, code, emphasis, links, images).

use std::fmt::Write as _;
use std::path::Path;

use base64::Engine as _;

use super::Failure;
use crate::metrics::error::MetricsError;

/// The report's HTML file.
pub const REPORT_HTML: &str = "report.html";

/// The directory of the episode pages beside it.
pub const EPISODES_DIR: &str = "episodes";

/// The episode pages `eval --html` writes into [`EPISODES_DIR`], one per listed episode, each
/// named by [`Failure::page_name`].
#[derive(Clone, Debug, Default)]
pub struct EpisodePages {
    /// Each page's file name and its text.
    pub pages: Vec<(String, String)>,
}

impl EpisodePages {
    /// Whether a page of that name is among them.
    pub fn has(&self, name: &str) -> bool {
        self.pages.iter().any(|(n, _)| n == name)
    }
}

impl Failure {
    /// The name this episode's files share (`<checkpoint>-<level>-seed<seed>`; the level as
    /// `S<size>-N<objects>` on the paper's), safe as a file name and in a link (a character
    /// other than a letter, digit, `-` or `_` becomes `_`, as in a MiniGrid class's
    /// arguments): the whole checkpoint name, so that two checkpoints called `model` in
    /// different runs do not share names.
    pub fn file_stem(&self) -> String {
        let safe = |s: &str| -> String {
            s.chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect()
        };
        let short = safe(
            self.checkpoint
                .trim_start_matches("bundled:")
                .trim_start_matches("./"),
        );
        let on = match &self.level {
            Some(id) => safe(id),
            None => format!("S{}-N{}", self.size, self.objects),
        };
        format!("{short}-{on}-seed{}", self.seed)
    }

    /// The episode's page in [`EPISODES_DIR`] (one per episode, whatever it is listed for).
    pub fn page_name(&self) -> String {
        format!("{}.html", self.file_stem())
    }
}

/// `s` with `&`, `<`, `>`, `"` and `'` escaped, for HTML text and attribute values.
pub fn escape_html(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// `report.html` from `markdown` (the report's `report.md`): every image that names one of the
/// report's figures by file name is inlined from `figure` (its PNG bytes); nothing else is read.
pub fn report_html(markdown: &str, figure: &dyn Fn(&str) -> Option<Vec<u8>>) -> String {
    let body = markdown_to_html(markdown, &|src| {
        let own = Path::new(src).file_name().is_some_and(|n| n == src)
            && Path::new(src).extension().is_some_and(|e| e == "png");
        own.then(|| figure(src)).flatten().map(|bytes| {
            format!(
                "data:image/png;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(bytes)
            )
        })
    });
    format!(
        "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta name=\"generator\" content=\"groundscope\">\n\
         <title>groundscope evaluation</title>\n<style>\n{REPORT_STYLE}</style>\n</head>\n\
         <body>\n{body}</body>\n</html>\n"
    )
}

/// The report page's style: readable tables that scroll sideways when wide.
const REPORT_STYLE: &str = "body { font: 15px/1.45 system-ui, sans-serif; margin: 0 auto; padding: 12px 20px; max-width: 1400px; color: #1d1d1d; }
table { border-collapse: collapse; margin: 8px 0 14px; font-size: 13px; font-variant-numeric: tabular-nums; display: block; overflow-x: auto; }
th, td { border: 1px solid #ccc; padding: 3px 7px; text-align: left; vertical-align: top; }
th { background: #f0f0f0; }
tr:nth-child(even) td { background: #fafafa; }
code { font-size: 12px; background: #f3f3f3; padding: 0 3px; border-radius: 3px; }
img { max-width: 100%; height: auto; display: block; margin: 6px 0; }
h1, h2, h3 { margin: 18px 0 6px; }
";

/// Block-level Markdown to HTML: headings, pipe tables, `- ` lists and paragraphs; images are
/// resolved by `image` (a `data:` URI), an image it does not resolve shown as its text.
pub(crate) fn markdown_to_html(md: &str, image: &dyn Fn(&str) -> Option<String>) -> String {
    let lines: Vec<&str> = md.lines().collect();
    let mut out = String::new();
    let mut i = 0;
    let starts_block = |l: &str, next: Option<&&str>| {
        let t = l.trim_start();
        t.starts_with('#')
            || t.starts_with("- ")
            || (t.starts_with('|') && next.copied().is_some_and(is_rule))
    };
    while i < lines.len() {
        let line = lines[i].trim_end();
        if line.trim().is_empty() {
            i += 1;
            continue;
        }
        let hashes = line.chars().take_while(|&c| c == '#').count();
        if (1..=6).contains(&hashes) && line[hashes..].starts_with(' ') {
            let text = line[hashes..].trim();
            let _ = writeln!(
                out,
                "<h{hashes} id=\"{}\">{}</h{hashes}>",
                slug(text),
                inline(text, image)
            );
            i += 1;
        } else if line.starts_with('|') && lines.get(i + 1).copied().is_some_and(is_rule) {
            out.push_str("<table>\n<thead><tr>");
            for c in row_cells(line) {
                let _ = write!(out, "<th>{}</th>", inline(&c, image));
            }
            out.push_str("</tr></thead>\n<tbody>\n");
            i += 2;
            while i < lines.len() && lines[i].trim_start().starts_with('|') {
                out.push_str("<tr>");
                for c in row_cells(lines[i]) {
                    let _ = write!(out, "<td>{}</td>", inline(&c, image));
                }
                out.push_str("</tr>\n");
                i += 1;
            }
            out.push_str("</tbody>\n</table>\n");
        } else if line.starts_with("- ") {
            out.push_str("<ul>\n");
            while i < lines.len() && lines[i].starts_with("- ") {
                let mut item = lines[i]
                    .strip_prefix("- ")
                    .unwrap_or_default()
                    .trim()
                    .to_owned();
                i += 1;
                // An indented line continues the item.
                while i < lines.len() && lines[i].starts_with("  ") && !lines[i].trim().is_empty() {
                    item.push(' ');
                    item.push_str(lines[i].trim());
                    i += 1;
                }
                let _ = writeln!(out, "<li>{}</li>", inline(&item, image));
            }
            out.push_str("</ul>\n");
        } else {
            let mut para = vec![line.trim()];
            i += 1;
            while i < lines.len()
                && !lines[i].trim().is_empty()
                && !starts_block(lines[i], lines.get(i + 1))
            {
                para.push(lines[i].trim());
                i += 1;
            }
            let _ = writeln!(out, "<p>{}</p>", inline(&para.join("\n"), image));
        }
    }
    out
}

/// Whether `line` is a table's separator row (`|---|:---:|`).
fn is_rule(line: &str) -> bool {
    let t = line.trim();
    t.starts_with('|') && t.contains('-') && t.chars().all(|c| matches!(c, '|' | '-' | ':' | ' '))
}

/// The cells of a table row: split on `|` outside code spans, the outer bars dropped.
fn row_cells(line: &str) -> Vec<String> {
    let t = line.trim();
    let t = t.strip_prefix('|').unwrap_or(t);
    let t = t.strip_suffix('|').unwrap_or(t);
    let mut cells = Vec::new();
    let mut cur = String::new();
    let mut code = false;
    for c in t.chars() {
        match c {
            '`' => {
                code = !code;
                cur.push(c);
            }
            '|' if !code => cells.push(std::mem::take(&mut cur).trim().to_owned()),
            c => cur.push(c),
        }
    }
    cells.push(cur.trim().to_owned());
    cells
}

/// An anchor for a heading: lowercase letters and digits, words joined by `-`, as GitHub
/// names them (so a link to `report.md#worst-episodes` names the same place here).
fn slug(text: &str) -> String {
    let mut s = String::new();
    for c in text.chars().flat_map(char::to_lowercase) {
        if c.is_alphanumeric() || c == '-' || c == '_' {
            s.push(c);
        } else if c == ' ' {
            s.push('-');
        }
    }
    s
}

/// Inline Markdown: code spans, images, links, `**strong**`, `*emphasis*`, `~~struck~~`;
/// everything else escaped as text.
fn inline(s: &str, image: &dyn Fn(&str) -> Option<String>) -> String {
    let mut out = String::new();
    let mut rest = s;
    while let Some(c) = rest.chars().next() {
        if c == '`'
            && let Some(end) = rest[1..].find('`')
        {
            let _ = write!(out, "<code>{}</code>", escape_html(&rest[1..=end]));
            rest = &rest[end + 2..];
            continue;
        }
        if let Some((text, target, len)) = bracketed(rest) {
            if rest.starts_with('!') {
                match image(target) {
                    Some(uri) => {
                        let _ = write!(
                            out,
                            "<img alt=\"{}\" src=\"{}\">",
                            escape_html(text),
                            escape_html(&uri)
                        );
                    }
                    None => {
                        let _ = write!(out, "<em>[{}]</em>", escape_html(text));
                    }
                }
            } else {
                let _ = write!(
                    out,
                    "<a href=\"{}\">{}</a>",
                    escape_html(target),
                    inline(text, image)
                );
            }
            rest = &rest[len..];
            continue;
        }
        if let Some((tag, mark)) = [("strong", "**"), ("del", "~~"), ("em", "*")]
            .into_iter()
            .find(|(_, m)| rest.starts_with(m))
            && let Some(end) = closing(&rest[mark.len()..], mark)
        {
            let inner = &rest[mark.len()..mark.len() + end];
            let _ = write!(out, "<{tag}>{}</{tag}>", inline(inner, image));
            rest = &rest[2 * mark.len() + end..];
            continue;
        }
        out.push_str(&escape_html(&rest[..c.len_utf8()]));
        rest = &rest[c.len_utf8()..];
    }
    out
}

/// `[text](target)` or `![text](target)` at the start of `s`: the text, the target and the
/// length of the whole.
fn bracketed(s: &str) -> Option<(&str, &str, usize)> {
    let open = usize::from(s.starts_with('!'));
    if !s[open..].starts_with('[') {
        return None;
    }
    let mid = s[open..].find("](")? + open;
    let end = s[mid + 2..].find(')')? + mid + 2;
    let text = &s[open + 1..mid];
    // A `]` inside would belong to something else: not a link.
    if text.contains(']') {
        return None;
    }
    Some((text, &s[mid + 2..end], end + 1))
}

/// Where `mark` closes an emphasis opened just before `s`: the inside must not start or end
/// with a space (so `2 * 3` stays text) and must not be empty.
fn closing(s: &str, mark: &str) -> Option<usize> {
    if s.starts_with(' ') || s.starts_with(mark) {
        return None;
    }
    let end = s.find(mark)?;
    (end > 0 && !s[..end].ends_with(' ')).then_some(end)
}

/// Writes `report.html` (from `markdown`, the figures `staged` holds inline) and the episode
/// pages into `staged`, the pages in its [`EPISODES_DIR`]; errors name their place in `dir`.
pub(super) fn stage_pages(
    staged: &crate::files::StagedDir,
    dir: &Path,
    markdown: &str,
    pages: &EpisodePages,
) -> Result<(), MetricsError> {
    let io = |p: &Path, e: &dyn std::fmt::Display| MetricsError::Io {
        path: p.to_path_buf(),
        reason: e.to_string(),
    };
    let page = report_html(markdown, &|name| std::fs::read(staged.path(name)).ok());
    staged
        .write(REPORT_HTML, page.as_bytes())
        .map_err(|e| io(&e.path, &e.reason))?;
    let into = staged.path(EPISODES_DIR);
    std::fs::create_dir(&into).map_err(|e| io(&dir.join(EPISODES_DIR), &e))?;
    for (name, text) in &pages.pages {
        std::fs::write(into.join(name), text)
            .map_err(|e| io(&dir.join(EPISODES_DIR).join(name), &e))?;
    }
    Ok(())
}

/// Puts this run's episode pages (the directory `staged`, when there are pages) in place of an
/// earlier run's at `dir`: the earlier `*.html` removed, then the directory renamed into place,
/// or, where `dir` keeps files of the user's own, each page moved in beside them. Without
/// pages, only the earlier ones are removed (and `dir` with them when nothing else is in it).
pub(super) fn put_pages_in_place(staged: Option<&Path>, dir: &Path) -> Result<(), MetricsError> {
    let io = |p: &Path, e: std::io::Error| MetricsError::Io {
        path: p.to_path_buf(),
        reason: e.to_string(),
    };
    if let Ok(entries) = std::fs::read_dir(dir) {
        for entry in entries.flatten() {
            let path = entry.path();
            if entry.file_type().is_ok_and(|t| t.is_file())
                && path.extension().is_some_and(|e| e == "html")
            {
                std::fs::remove_file(&path).map_err(|e| io(&path, e))?;
            }
        }
        // Only an empty directory is removed; one with the user's files stays.
        let _ = std::fs::remove_dir(dir);
    }
    let Some(staged) = staged else {
        return Ok(());
    };
    if !dir.exists() {
        return std::fs::rename(staged, dir).map_err(|e| io(dir, e));
    }
    for entry in std::fs::read_dir(staged).map_err(|e| io(dir, e))? {
        let entry = entry.map_err(|e| io(dir, e))?;
        let dest = dir.join(entry.file_name());
        std::fs::rename(entry.path(), &dest).map_err(|e| io(&dest, e))?;
    }
    std::fs::remove_dir(staged).map_err(|e| io(staged, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_images(_: &str) -> Option<String> {
        None
    }

    #[test]
    fn the_report_markdown_subset_renders() {
        let md = "# groundscope evaluation\n\nα = 0.5, `greedy` **bold** *it* [link](docs/x.md#a).\nnext line\n\n- `a`: one\n- b <c>\n\n| k | v |\n|---|---|\n| `x \\| y` | 2 |\n| **z** | [p](episodes/a.html) |\n\n![Fig](fig6_reward.png)\n![Gone](missing.png)\n";
        let html = markdown_to_html(md, &|src| {
            (src == "fig6_reward.png").then(|| "data:image/png;base64,AAAA".to_owned())
        });
        assert!(
            html.contains("<h1 id=\"groundscope-evaluation\">groundscope evaluation</h1>"),
            "{html}"
        );
        assert!(html.contains("<p>α = 0.5, <code>greedy</code> <strong>bold</strong> <em>it</em> <a href=\"docs/x.md#a\">link</a>.\nnext line</p>"), "{html}");
        assert!(
            html.contains("<li><code>a</code>: one</li>\n<li>b &lt;c&gt;</li>"),
            "{html}"
        );
        assert!(
            html.contains("<thead><tr><th>k</th><th>v</th></tr></thead>"),
            "{html}"
        );
        assert!(
            html.contains("<td><strong>z</strong></td><td><a href=\"episodes/a.html\">p</a></td>"),
            "{html}"
        );
        assert!(
            html.contains("<img alt=\"Fig\" src=\"data:image/png;base64,AAAA\">"),
            "{html}"
        );
        assert!(
            html.contains("<em>[Gone]</em>") && !html.contains("missing.png"),
            "{html}"
        );
        // A lone star or a product stays text.
        assert_eq!(
            markdown_to_html("2 * 3 and a*", &no_images),
            "<p>2 * 3 and a*</p>\n"
        );
    }

    #[test]
    fn a_figure_outside_the_report_is_never_read() {
        let asked = std::cell::RefCell::new(Vec::new());
        let html = report_html("![a](../secret.png) ![b](fig.png) ![c](fig.svg)", &|n| {
            asked.borrow_mut().push(n.to_owned());
            Some(vec![1, 2, 3])
        });
        assert_eq!(*asked.borrow(), ["fig.png"]);
        assert!(
            html.contains("src=\"data:image/png;base64,AQID\""),
            "{html}"
        );
        assert!(!html.contains("http"), "{html}");
    }
}

//! Every link in the repository's documents stays alive: README.md, docs/ (studies included),
//! experiments/, recordings/ and vendor/README.md. A relative link must name a file or folder
//! that exists inside the repository, and an `#anchor` (in the same file or `file.md#anchor`)
//! must match a heading of the target as GitHub slugs it. Absolute paths, `file:` links and
//! links that climb above the repository's root are errors, and so are web links into the
//! project's shared reference (`…/shared/…`), which readers of the repository cannot follow;
//! other web links are allowed. Links inside code blocks and code spans are not links.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Component, Path, PathBuf};

/// The documents checked: single files and folders searched for `*.md`, relative to the root.
const DOCUMENTS: &[&str] = &[
    "README.md",
    "docs",
    "experiments",
    "recordings",
    "vendor/README.md",
];

/// What the checker needs from a repository: whether a path exists, and a Markdown file's text.
trait Repo {
    /// Whether `rel` (relative to the root, normalised) is a file or folder.
    fn exists(&self, rel: &Path) -> bool;
    /// The text of the Markdown file `rel`, if it is one.
    fn text(&self, rel: &Path) -> Option<String>;
}

/// The repository on disk.
struct Disk(PathBuf);

impl Repo for Disk {
    fn exists(&self, rel: &Path) -> bool {
        self.0.join(rel).exists()
    }

    fn text(&self, rel: &Path) -> Option<String> {
        std::fs::read_to_string(self.0.join(rel)).ok()
    }
}

/// A made-up repository: files and their texts (folders are implied by the files' paths).
struct Memory(BTreeMap<PathBuf, String>);

impl Repo for Memory {
    fn exists(&self, rel: &Path) -> bool {
        rel.as_os_str().is_empty() || self.0.keys().any(|p| p.starts_with(rel))
    }

    fn text(&self, rel: &Path) -> Option<String> {
        self.0.get(rel).cloned()
    }
}

/// A link as written: its target and the line it starts on (1-based).
#[derive(Debug)]
struct Link {
    target: String,
    line: usize,
}

/// The text with fenced code blocks and inline code spans blanked out (newlines kept, so line
/// numbers stay right).
fn without_code(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut fence: Option<String> = None;
    for line in text.split_inclusive('\n') {
        let trimmed = line.trim_start();
        let marker: String = trimmed
            .chars()
            .take_while(|&c| c == '`' || c == '~')
            .collect();
        if let Some(open) = &fence {
            if marker.len() >= open.len() && marker.starts_with(&open[..1]) {
                fence = None;
            }
            out.extend(line.chars().map(|c| if c == '\n' { '\n' } else { ' ' }));
            continue;
        }
        if marker.len() >= 3 && (marker.starts_with("```") || marker.starts_with("~~~")) {
            fence = Some(marker);
            out.extend(line.chars().map(|c| if c == '\n' { '\n' } else { ' ' }));
            continue;
        }
        out.push_str(line);
    }
    blank_code_spans(&out)
}

/// Blanks inline code spans: a run of backticks up to the next run of the same length.
fn blank_code_spans(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = chars.clone();
    let mut i = 0;
    while i < chars.len() {
        if chars[i] != '`' {
            i += 1;
            continue;
        }
        let run = chars[i..].iter().take_while(|&&c| c == '`').count();
        let mut j = i + run;
        let mut close = None;
        while j < chars.len() {
            if paragraph_ends(&chars, j) {
                break;
            }
            if chars[j] == '`' {
                let r = chars[j..].iter().take_while(|&&c| c == '`').count();
                if r == run {
                    close = Some(j);
                    break;
                }
                j += r;
            } else {
                j += 1;
            }
        }
        match close {
            Some(end) => {
                for c in &mut out[i..end + run] {
                    if *c != '\n' {
                        *c = ' ';
                    }
                }
                i = end + run;
            }
            None => i += run,
        }
    }
    out.into_iter().collect()
}

/// Whether a blank line starts at `j` (a paragraph ends there): spans and links stop at it.
fn paragraph_ends(chars: &[char], j: usize) -> bool {
    chars[j] == '\n'
        && chars[j + 1..]
            .iter()
            .take_while(|&&c| c != '\n')
            .all(|c| c.is_whitespace())
        && j + 1 < chars.len()
}

/// The inline links `[text](target)` and images `![alt](target)` of a Markdown text.
fn links(text: &str) -> Vec<Link> {
    let chars: Vec<char> = without_code(text).chars().collect();
    let mut found = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        if chars[i] != '[' || (i > 0 && chars[i - 1] == '\\') {
            i += 1;
            continue;
        }
        // The matching `]`, allowing nested brackets in the text.
        let mut depth = 0usize;
        let mut close = None;
        for (j, &c) in chars.iter().enumerate().skip(i) {
            if paragraph_ends(&chars, j) {
                break;
            }
            match c {
                '[' => depth += 1,
                ']' => {
                    depth -= 1;
                    if depth == 0 {
                        close = Some(j);
                        break;
                    }
                }
                _ => {}
            }
        }
        let Some(close) = close else {
            i += 1;
            continue;
        };
        if chars.get(close + 1) != Some(&'(') {
            i += 1;
            continue;
        }
        // The matching `)`, allowing balanced parentheses in the target.
        let mut depth = 0usize;
        let mut end = None;
        for (j, &c) in chars.iter().enumerate().skip(close + 1) {
            if paragraph_ends(&chars, j) {
                break;
            }
            match c {
                '(' => depth += 1,
                ')' => {
                    depth -= 1;
                    if depth == 0 {
                        end = Some(j);
                        break;
                    }
                }
                _ => {}
            }
        }
        let Some(end) = end else {
            i = close + 1;
            continue;
        };
        let inside: String = chars[close + 2..end].iter().collect();
        let inside = inside.trim();
        // `<target>` or `target "title"`.
        let target = if let Some(rest) = inside.strip_prefix('<') {
            rest.split('>').next().unwrap_or_default().to_owned()
        } else {
            inside
                .split_whitespace()
                .next()
                .unwrap_or_default()
                .to_owned()
        };
        let line = chars[..i].iter().filter(|&&c| c == '\n').count() + 1;
        found.push(Link { target, line });
        // The text of a link may itself hold an image (`[![alt](img)](target)`): look inside.
        i += 1;
    }
    found
}

/// GitHub's anchor for a heading's text: lowercase, every character that is not a letter, a
/// digit, `-`, `_` or a space dropped (letters and digits of any script are kept), and each
/// space turned into `-`.
fn slug(heading: &str) -> String {
    heading
        .to_lowercase()
        .chars()
        .filter(|&c| c.is_alphanumeric() || c == '-' || c == '_' || c == ' ')
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// A heading's text as GitHub renders it: links reduced to their text, code spans, emphasis
/// markers and images' syntax gone.
fn heading_text(raw: &str) -> String {
    let mut text = String::new();
    let chars: Vec<char> = raw.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == ']' && chars.get(i + 1) == Some(&'(') {
            // Skip the link target.
            let mut depth = 0usize;
            let mut j = i + 1;
            while j < chars.len() {
                match chars[j] {
                    '(' => depth += 1,
                    ')' => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    _ => {}
                }
                j += 1;
            }
            i = j + 1;
            continue;
        }
        if !matches!(c, '`' | '*' | '[' | ']' | '!') {
            text.push(c);
        }
        i += 1;
    }
    text.trim().to_owned()
}

/// Every anchor a Markdown text defines: its headings' slugs (a repeated slug gets `-1`, `-2`,
/// … as on GitHub) and explicit `id="…"` / `name="…"` attributes.
fn anchors(text: &str) -> HashSet<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = HashSet::new();
    let plain = without_code_blocks(text);
    for line in plain.lines() {
        let trimmed = line.trim_start();
        if line.len() - trimmed.len() > 3 {
            continue;
        }
        let hashes = trimmed.chars().take_while(|&c| c == '#').count();
        if (1..=6).contains(&hashes) {
            let rest = &trimmed[hashes..];
            if rest.is_empty() || rest.starts_with(' ') || rest.starts_with('\t') {
                let rest = rest.trim().trim_end_matches('#').trim_end();
                let base = slug(&heading_text(rest));
                let n = seen.entry(base.clone()).or_insert(0);
                let anchor = if *n == 0 {
                    base.clone()
                } else {
                    format!("{base}-{n}")
                };
                *n += 1;
                out.insert(anchor);
            }
        }
        for attr in ["id=\"", "name=\""] {
            let mut from = 0;
            while let Some(k) = line[from..].find(attr) {
                let start = from + k + attr.len();
                if let Some(len) = line[start..].find('"') {
                    out.insert(line[start..start + len].to_owned());
                    from = start + len;
                } else {
                    break;
                }
            }
        }
    }
    out
}

/// The text with fenced code blocks blanked out (headings inside them are not headings).
fn without_code_blocks(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut in_fence = false;
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with("```") || t.starts_with("~~~") {
            in_fence = !in_fence;
            out.push('\n');
            continue;
        }
        if !in_fence {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

/// `rel` with `.` and `..` resolved; `None` when it climbs above the root.
fn normalise(rel: &Path) -> Option<PathBuf> {
    let mut parts: Vec<&std::ffi::OsStr> = Vec::new();
    for c in rel.components() {
        match c {
            Component::Normal(p) => parts.push(p),
            Component::CurDir => {}
            Component::ParentDir => {
                parts.pop()?;
            }
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    Some(parts.iter().collect())
}

/// `%20` and friends decoded, as a browser does before asking for the file.
fn percent_decoded(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    let hex = |b: u8| char::from(b).to_digit(16);
    while i < bytes.len() {
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(hi), Some(lo)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((hi * 16 + lo) as u8);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn is_markdown(p: &Path) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case("md"))
}

/// The problems with the links of the document `doc` (relative to the root), one line each.
fn check(doc: &Path, repo: &dyn Repo) -> Vec<String> {
    let Some(text) = repo.text(doc) else {
        return vec![format!("{}: cannot be read", doc.display())];
    };
    let here = doc.parent().unwrap_or_else(|| Path::new(""));
    let own = anchors(&text);
    let mut problems = Vec::new();
    let mut targets: HashMap<PathBuf, HashSet<String>> = HashMap::new();
    for link in links(&text) {
        let at = format!("{}:{}: ({})", doc.display(), link.line, link.target);
        let t = link.target.as_str();
        let lower = t.to_ascii_lowercase();
        if lower.starts_with("http://") || lower.starts_with("https://") {
            if lower.contains("/shared/") {
                problems.push(format!(
                    "{at} points into the shared reference, outside the repository"
                ));
            }
            continue;
        }
        if lower.starts_with("mailto:") {
            continue;
        }
        if t.is_empty() {
            problems.push(format!("{at} has no target"));
            continue;
        }
        let (path, anchor) = match t.split_once('#') {
            Some((p, a)) => (p, Some(a)),
            None => (t, None),
        };
        if path.contains(':') {
            problems.push(format!("{at} is not a relative link into the repository"));
            continue;
        }
        if path.starts_with('/') {
            problems.push(format!("{at} is an absolute path; links must be relative"));
            continue;
        }
        let file = if path.is_empty() {
            doc.to_path_buf()
        } else {
            let Some(file) = normalise(&here.join(percent_decoded(path))) else {
                problems.push(format!("{at} leaves the repository"));
                continue;
            };
            if !repo.exists(&file) {
                problems.push(format!("{at}: no such file or folder {}", file.display()));
                continue;
            }
            file
        };
        let Some(anchor) = anchor else { continue };
        if !is_markdown(&file) {
            // GitHub's line anchors in source files (`#L10`) are not headings.
            continue;
        }
        let known = if file == doc {
            &own
        } else {
            targets
                .entry(file.clone())
                .or_insert_with(|| repo.text(&file).map(|t| anchors(&t)).unwrap_or_default())
        };
        let anchor = percent_decoded(anchor);
        if !known.contains(&anchor) {
            problems.push(format!(
                "{at}: {} has no heading with the anchor #{anchor}",
                file.display()
            ));
        }
    }
    problems
}

/// The Markdown documents under `rel` (a file or a folder), relative to `root`, sorted.
fn documents(root: &Path, rel: &Path, out: &mut Vec<PathBuf>) {
    let full = root.join(rel);
    if full.is_file() {
        if is_markdown(rel) {
            out.push(rel.to_path_buf());
        }
        return;
    }
    let Ok(entries) = std::fs::read_dir(&full) else {
        return;
    };
    let mut names: Vec<_> = entries
        .filter_map(Result::ok)
        .map(|e| e.file_name())
        .collect();
    names.sort();
    for name in names {
        if name.to_string_lossy().starts_with('.') {
            continue;
        }
        documents(root, &rel.join(name), out);
    }
}

#[test]
fn every_link_in_the_documents_resolves() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut docs = Vec::new();
    for d in DOCUMENTS {
        documents(root, Path::new(d), &mut docs);
    }
    assert!(
        docs.iter().any(|d| d == Path::new("README.md")) && docs.len() >= 10,
        "too few documents found: {docs:?}"
    );
    let repo = Disk(root.to_path_buf());
    let mut problems = Vec::new();
    let mut checked = 0;
    for doc in &docs {
        checked += repo.text(doc).map_or(0, |t| links(&t).len());
        problems.extend(check(doc, &repo));
    }
    assert!(checked >= 100, "only {checked} links found in {docs:?}");
    assert!(
        problems.is_empty(),
        "{} broken links:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

#[test]
fn checker_reports_broken_links_and_anchors() {
    let doc = "# Guide\n\n\
        ## Quick start\n\n\
        [ok](#quick-start) [ok file](docs/a.md) [ok anchor](docs/a.md#the-wt-seeds-result)\n\
        [ok folder](docs/) [ok second](docs/a.md#usage-1) ![ok image](docs/pic.png)\n\
        [web](https://rerun.io) [`code` text](docs/a.md#usage)\n\
        [missing file](docs/b.md) [missing anchor](#quick-stop)\n\
        [missing anchor there](docs/a.md#nowhere) [outside](../shared/DESIGN.md)\n\
        [absolute](/etc/passwd) [shared web](https://example.org/x/shared/tools/a.py)\n\
        [split\nacross lines](docs/gone.md)\n\n\
        ```\n[in a code block](docs/nothing.md)\n```\n\
        and `[in a code span](docs/nothing.md)`.\n";
    let a = "# A\n\n## The `wt` seeds' result\n\n## Usage\n\n## Usage\n";
    let repo = Memory(BTreeMap::from([
        (PathBuf::from("README.md"), doc.to_owned()),
        (PathBuf::from("docs/a.md"), a.to_owned()),
        (PathBuf::from("docs/pic.png"), String::new()),
    ]));
    let problems = check(Path::new("README.md"), &repo);
    let expected = [
        "(docs/b.md): no such file",
        "(#quick-stop): README.md has no heading with the anchor #quick-stop",
        "(docs/a.md#nowhere): docs/a.md has no heading with the anchor #nowhere",
        "(../shared/DESIGN.md) leaves the repository",
        "(/etc/passwd) is an absolute path",
        "(https://example.org/x/shared/tools/a.py) points into the shared reference",
        "README.md:11: (docs/gone.md): no such file",
    ];
    for e in expected {
        assert!(
            problems.iter().any(|p| p.contains(e)),
            "{e:?} not reported in {problems:#?}"
        );
    }
    assert_eq!(problems.len(), expected.len(), "{problems:#?}");
    // The same document with every broken link removed passes.
    let fixed: Vec<&str> = doc
        .lines()
        .filter(|l| !l.contains("missing") && !l.contains("absolute") && !l.contains("across"))
        .filter(|l| !l.starts_with("[split"))
        .collect();
    let fixed = fixed.join("\n");
    let repo = Memory(BTreeMap::from([
        (PathBuf::from("README.md"), fixed),
        (PathBuf::from("docs/a.md"), a.to_owned()),
        (PathBuf::from("docs/pic.png"), String::new()),
    ]));
    assert_eq!(check(Path::new("README.md"), &repo), Vec::<String>::new());
}

#[test]
fn anchors_are_github_slugs() {
    assert_eq!(slug("The `paper` seeds' result"), "the-paper-seeds-result");
    assert_eq!(
        slug("Fifth part: the 1×1 encoder (--conv-kernel 1)"),
        "fifth-part-the-11-encoder---conv-kernel-1"
    );
    assert_eq!(
        slug("Throughput against PyTorch (issue #16)"),
        "throughput-against-pytorch-issue-16"
    );
    assert_eq!(slug("eval_log.csv"), "eval_logcsv");
    assert_eq!(slug("Über Größe — ok"), "über-größe--ok");
    let a = anchors(
        "# T\n## Usage\n## Usage\n### `log.csv`\n## [Linked](x.md) *heading*\n```\n# not one\n```\n<a id=\"here\"></a>\n",
    );
    for want in ["t", "usage", "usage-1", "logcsv", "linked-heading", "here"] {
        assert!(a.contains(want), "{want} missing from {a:?}");
    }
    assert!(!a.contains("not-one"), "{a:?}");
}

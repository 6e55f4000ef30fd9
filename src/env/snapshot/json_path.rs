//! The field a JSON reading error is about, named by its path (`steps[1].action`).
//!
//! serde_json says where in the text a typed read failed (line and column) and what failed
//! (`missing field `action``, `invalid type: string "x", expected f64`), but not in which
//! field. The path is recovered by walking the text up to that position.

/// One step of a path: an object's key or an array's index.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Frame {
    /// Inside an object; the key last read (the value it names is being read or was read).
    Object(Option<String>),
    /// Inside an array, at this element.
    Array(usize),
}

/// The field and reason of a serde_json error on `text`: a syntax error keeps its line and
/// column; a data error (a missing field, a wrong type, an unknown field) names the field's
/// path, e.g. (`steps[1].action`, `missing`).
pub(super) fn field_of(text: &str, e: &serde_json::Error) -> (String, String) {
    let message = e.to_string();
    // A key or string from the file may be any length: the line stays short.
    let reason = cut(
        message
            .rsplit_once(" at line ")
            .map_or(message.as_str(), |(m, _)| m),
        200,
    );
    if !e.is_data() || e.line() == 0 {
        return (format!("line {} column {}", e.line(), e.column()), reason);
    }
    let path = path_at(text, offset_of(text, e.line(), e.column()));
    // serde_json reports a missing field once the object's closing brace is read: the walk
    // is then back in the object's parent, at the object itself.
    if let Some(name) = reason
        .strip_prefix("missing field `")
        .and_then(|r| r.strip_suffix('`'))
    {
        let field = if path.is_empty() {
            name.to_owned()
        } else {
            format!("{path}.{name}")
        };
        return (field, "missing (a required field)".into());
    }
    let field = if path.is_empty() {
        "the dump".to_owned()
    } else {
        path
    };
    (field, reason)
}

/// `text` cut after `max` characters, saying so.
fn cut(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        Some((i, _)) => format!("{}… ({} characters)", &text[..i], text.chars().count()),
        None => text.to_owned(),
    }
}

/// The byte offset of serde_json's (1-based line, column = bytes read on that line).
fn offset_of(text: &str, line: usize, column: usize) -> usize {
    let start = if line <= 1 {
        0
    } else {
        text.match_indices('\n')
            .nth(line - 2)
            .map_or(text.len(), |(i, _)| i + 1)
    };
    (start + column).min(text.len())
}

/// The path of the value being read at byte `end` of the JSON `text` (`""` at the top).
fn path_at(text: &str, end: usize) -> String {
    let bytes = &text.as_bytes()[..end];
    let mut stack: Vec<Frame> = Vec::new();
    // Whether the next string in an object is a key (after `{` or `,`).
    let mut expect_key = false;
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'"' => {
                let start = i + 1;
                i += 1;
                while i < bytes.len() && bytes[i] != b'"' {
                    i += if bytes[i] == b'\\' { 2 } else { 1 };
                }
                if expect_key && let Some(Frame::Object(key)) = stack.last_mut() {
                    let raw = &bytes[start..i.min(bytes.len())];
                    *key = Some(cut(&String::from_utf8_lossy(raw), 40));
                    expect_key = false;
                }
            }
            b'{' => {
                stack.push(Frame::Object(None));
                expect_key = true;
            }
            b'[' => {
                stack.push(Frame::Array(0));
                expect_key = false;
            }
            b'}' | b']' => {
                stack.pop();
                expect_key = false;
            }
            b',' => match stack.last_mut() {
                Some(Frame::Array(n)) => *n += 1,
                Some(Frame::Object(_)) => expect_key = true,
                None => {}
            },
            _ => {}
        }
        i += 1;
    }
    let mut path = String::new();
    for frame in &stack {
        match frame {
            Frame::Object(Some(key)) => {
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(key);
            }
            Frame::Object(None) => {}
            Frame::Array(n) => {
                path.push('[');
                path.push_str(&n.to_string());
                path.push(']');
            }
        }
    }
    path
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[expect(dead_code, reason = "read only to fail")]
    struct Step {
        action: i64,
        reward: f64,
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[expect(dead_code, reason = "read only to fail")]
    struct Dump {
        seed: u64,
        grid: Vec<Vec<i64>>,
        steps: Vec<Step>,
    }

    fn field(text: &str) -> (String, String) {
        let e = serde_json::from_str::<Dump>(text).unwrap_err();
        field_of(text, &e)
    }

    #[test]
    fn errors_name_the_field_by_its_path() {
        let ok_steps = r#"[{"action": 1, "reward": 0.5}, {"action": 2, "reward": 0}]"#;
        let (f, r) = field(&format!(r#"{{"seed": 1, "steps": {ok_steps}}}"#));
        assert_eq!(
            (f.as_str(), r.as_str()),
            ("grid", "missing (a required field)")
        );
        let (f, _) = field(
            r#"{"seed": 1, "grid": [], "steps": [{"action": 1, "reward": 0}, {"reward": 1}]}"#,
        );
        assert_eq!(f, "steps[1].action");
        let (f, r) = field("{\n \"seed\": 1,\n \"grid\": [[1, 2], [3, \"x\"]],\n \"steps\": []\n}");
        assert_eq!(f, "grid[1][1]");
        assert!(r.starts_with("invalid type: string \"x\""), "{r}");
        let (f, r) =
            field(r#"{"seed": 1, "grid": [], "steps": [{"action": 1, "reward": 0, "kind": 3}]}"#);
        assert_eq!(f, "steps[0].kind");
        assert!(r.starts_with("unknown field `kind`"), "{r}");
        let (f, _) = field(r#"{"seed": "one", "grid": [], "steps": []}"#);
        assert_eq!(f, "seed");
        let (f, _) = field(r#"{"seed": 1, "grid": {}, "steps": []}"#);
        assert_eq!(f, "grid");
        let (f, _) = field(r#"{"s\"eed": 1}"#);
        assert_eq!(f, "s\\\"eed");
        let long = "k".repeat(100_000);
        let (f, r) = field(&format!(r#"{{"seed": 1, "{long}": 2}}"#));
        assert!(f.len() < 80 && r.len() < 300, "{f}: {r}");
        let (f, _) = field("[1]");
        assert_eq!(f, "the dump");
        let (f, r) = field(r#"{"seed": 1, "grid": ["#);
        assert!(f.starts_with("line 1 column"), "{f}");
        assert!(r.starts_with("EOF while parsing"), "{r}");
    }
}

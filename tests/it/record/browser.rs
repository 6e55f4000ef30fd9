//! The HTML episode page and report in a real browser: a headless Chromium driven through
//! chromedriver over the W3C WebDriver protocol (plain HTTP and JSON). The page is opened from
//! its file, stepped with the keys a person uses, read back and photographed. Without
//! Chromium and its driver these tests fail, saying what to install: a skipped browser test
//! would pass a page no browser can show.

use std::path::Path;
use std::process::{Child, Command, Stdio};

use serde_json::{Value, json};

use super::html::{attr_values, base64_decode, page_data};
use crate::common::{self, FAILING_SWEEP, GUARD, gs, stderr};

const CHROMIUM: &str = "/usr/bin/chromium";
const CHROMEDRIVER: &str = "/usr/bin/chromedriver";

/// WebDriver's key codes.
const ARROW_RIGHT: &str = "\u{E014}";
const HOME: &str = "\u{E011}";
const END: &str = "\u{E010}";

/// A chromedriver on a free port of this machine, killed when dropped.
struct Driver {
    child: Child,
    base: String,
    http: ureq::Agent,
}

impl Driver {
    fn start() -> Self {
        for path in [CHROMIUM, CHROMEDRIVER] {
            assert!(
                Path::new(path).exists(),
                "{path} is missing: this test drives a real headless Chromium through \
                 chromedriver; install both with `apt-get install chromium chromium-driver` \
                 (.ci/run does)"
            );
        }
        // A port the system just handed out and took back: free for chromedriver to take.
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let child = Command::new(CHROMEDRIVER)
            .arg(format!("--port={port}"))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver starts");
        // WebDriver answers errors with 4xx/5xx and a JSON body: read the body either way. A
        // proxy from the environment must not see requests to this machine.
        let config = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .proxy(None)
            .timeout_global(Some(GUARD))
            .build();
        let driver = Self {
            child,
            base: format!("http://127.0.0.1:{port}"),
            http: ureq::Agent::new_with_config(config),
        };
        common::wait_until("chromedriver to be ready", || {
            driver
                .request("GET", "/status", None)
                .is_ok_and(|v| v["value"]["ready"] == json!(true))
        });
        driver
    }

    /// One WebDriver command; its JSON answer.
    fn request(
        &self,
        method: &str,
        path: &str,
        body: Option<&Value>,
    ) -> Result<Value, ureq::Error> {
        let url = format!("{}{path}", self.base);
        let mut resp = match method {
            "GET" => self.http.get(url.as_str()).call()?,
            "DELETE" => self.http.delete(url.as_str()).call()?,
            _ => self
                .http
                .post(url.as_str())
                .header("Content-Type", "application/json")
                .send(body.map_or_else(|| "{}".to_owned(), Value::to_string))?,
        };
        let text = resp.body_mut().read_to_string()?;
        Ok(serde_json::from_str(&text).unwrap_or(Value::Null))
    }

    /// A headless Chromium session.
    fn session(&self) -> Session<'_> {
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {
                "binary": CHROMIUM,
                "args": ["--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1400,1000"],
            },
        }}});
        let v = self.request("POST", "/session", Some(&caps)).unwrap();
        let id = v["value"]["sessionId"]
            .as_str()
            .unwrap_or_else(|| panic!("no session: {v}"))
            .to_owned();
        Session { driver: self, id }
    }
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A browser session, deleted (the browser closed) when dropped.
struct Session<'a> {
    driver: &'a Driver,
    id: String,
}

impl Session<'_> {
    /// A command of this session; its `value`, failing on a WebDriver error.
    fn call(&self, method: &str, path: &str, body: Option<&Value>) -> Value {
        let path = format!("/session/{}{path}", self.id);
        let v = self.driver.request(method, &path, body).unwrap();
        assert!(
            v["value"].get("error").is_none(),
            "{method} {path}: {}",
            v["value"]
        );
        v["value"].clone()
    }

    fn open(&self, file: &Path) {
        let url = format!("file://{}", file.canonicalize().unwrap().display());
        self.call("POST", "/url", Some(&json!({ "url": url })));
    }

    /// The value of a script's `return`.
    fn script(&self, script: &str) -> Value {
        self.call(
            "POST",
            "/execute/sync",
            Some(&json!({"script": script, "args": []})),
        )
    }

    /// Presses and releases `key`, as a person's keyboard does, on the focused page.
    fn key(&self, key: &str) {
        let actions = json!({"actions": [{"type": "key", "id": "keyboard", "actions": [
            {"type": "keyDown", "value": key},
            {"type": "keyUp", "value": key},
        ]}]});
        self.call("POST", "/actions", Some(&actions));
    }

    /// The text the page shows in the element `css` selects.
    fn text(&self, css: &str) -> String {
        let found = self.call(
            "POST",
            "/element",
            Some(&json!({"using": "css selector", "value": css})),
        );
        let id = found
            .as_object()
            .and_then(|o| o.values().next())
            .and_then(Value::as_str)
            .unwrap_or_else(|| panic!("no element {css}: {found}"))
            .to_owned();
        self.call("GET", &format!("/element/{id}/text"), None)
            .as_str()
            .unwrap()
            .to_owned()
    }

    /// The page as the browser draws it, decoded.
    fn screenshot(&self) -> image::RgbImage {
        let png = self.call("GET", "/screenshot", None);
        image::load_from_memory(&base64_decode(png.as_str().unwrap()))
            .expect("the screenshot is a PNG")
            .to_rgb8()
    }

    /// Waits until the episode page has drawn its first step.
    fn wait_for_page(&self) {
        common::wait_until("the page to draw", || {
            !self
                .script("return document.body.dataset.step ?? null")
                .is_null()
        });
    }
}

impl Drop for Session<'_> {
    fn drop(&mut self) {
        let _ = self
            .driver
            .request("DELETE", &format!("/session/{}", self.id), None);
    }
}

/// The leading number of a shown probability (`"0.912"`, `"0.051 < expert"`).
fn shown_number(text: &str) -> f64 {
    text.split_whitespace()
        .next()
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("not a number: {text:?}"))
}

#[test]
fn an_episode_page_steps_with_the_keys_and_shows_the_traces_numbers() {
    let tmp = tempfile::tempdir().unwrap();
    let page = tmp.path().join("ep.html");
    let trace = tmp.path().join("t.json");
    let o = gs(&[
        "replay",
        "--seed",
        "3",
        "--html",
        page.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
        "--compare",
        "bundled:baseline",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let t: Value = serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    let data = page_data(&std::fs::read_to_string(&page).unwrap());
    let steps = data["panels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["steps"].as_array().unwrap().len())
        .max()
        .unwrap();
    assert!(steps > 2, "{steps} steps");

    let driver = Driver::start();
    let s = driver.session();
    s.open(&page);
    s.wait_for_page();
    assert_eq!(s.text("#step"), "0");
    assert_eq!(s.script("return window.groundscope.steps"), json!(steps));
    s.key(ARROW_RIGHT);
    assert_eq!(s.text("#step"), "1");
    assert_eq!(s.script("return window.groundscope.step"), json!(1));
    // Step 1's probabilities as the page shows them and as it holds them: the trace's.
    let probs: Vec<f64> = t["steps"][1]["probs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let held = s.script("return window.groundscope.action_probs()");
    for (a, want) in probs.iter().enumerate() {
        assert_eq!(held[a].as_f64(), Some(*want), "action {a}");
        let shown = shown_number(&s.text(&format!("#prob-0-{a}")));
        assert!(
            (shown - want).abs() <= 0.0005 + 1e-9,
            "action {a}: {shown} shown, {want}"
        );
    }
    let weights = s.script("return window.groundscope.weights()");
    let words = t["steps"][1]["attention"]["words"].as_array().unwrap();
    assert_eq!(weights.as_array().unwrap().len(), words.len());
    for (w, word) in weights.as_array().unwrap().iter().zip(words) {
        assert_eq!(w.as_f64(), word["weight"].as_f64());
    }
    // The baseline beside it, on the same step axis, without maps.
    assert_eq!(s.script("return window.groundscope.weights(1)"), json!([]));
    assert_eq!(
        s.script("return window.groundscope.action_probs(1).length"),
        json!(7)
    );
    s.key(ARROW_RIGHT);
    assert_eq!(s.text("#step"), "2");
    s.key(END);
    assert_eq!(s.text("#step"), (steps - 1).to_string());
    s.key(HOME);
    assert_eq!(s.text("#step"), "0");
    s.key(" ");
    assert_eq!(s.script("return window.groundscope.playing()"), json!(true));
    s.key(" ");
    assert_eq!(
        s.script("return window.groundscope.playing()"),
        json!(false)
    );
    // Something is drawn: a blank page has a colour or two, the world, maps and bars many.
    let shot = s.screenshot();
    assert!(
        shot.width() >= 400 && shot.height() >= 300,
        "{:?}",
        shot.dimensions()
    );
    let colours: std::collections::HashSet<[u8; 3]> = shot.pixels().map(|p| p.0).collect();
    assert!(
        colours.len() > 64,
        "{} colours: a blank page",
        colours.len()
    );
}

#[test]
fn the_report_page_loads_its_figures_and_links_pages_that_open_at_their_step() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("r");
    let mut args = vec![
        "eval",
        "--checkpoint",
        "bundled:attention",
        "--out",
        out.to_str().unwrap(),
        "--top-k",
        "1",
        "--html",
        "--quiet",
    ];
    args.extend(FAILING_SWEEP);
    let o = gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let link = attr_values(&html, "href")
        .into_iter()
        .find(|h| h.starts_with("episodes/"))
        .expect("an episode linked")
        .to_owned();

    let driver = Driver::start();
    let s = driver.session();
    s.open(&out.join("report.html"));
    common::wait_until("the report's images", || {
        s.script("return document.readyState") == json!("complete")
    });
    // Every figure decoded by the browser itself.
    let images =
        s.script("return Array.from(document.images).map((i) => [i.complete, i.naturalWidth])");
    let images = images.as_array().unwrap();
    assert!(!images.is_empty(), "no figure");
    for i in images {
        assert_eq!(i[0], json!(true), "{i}");
        assert!(
            i[1].as_u64().unwrap() > 0,
            "a figure the browser cannot decode"
        );
    }
    // The link opens its page at the step it names.
    let (file, step) = link.split_once("#step=").expect("the link names a step");
    let step: u64 = step.parse().unwrap();
    let url = format!(
        "file://{}#step={step}",
        out.join(file).canonicalize().unwrap().display()
    );
    s.call("POST", "/url", Some(&json!({ "url": url })));
    s.wait_for_page();
    assert_eq!(s.text("#step"), step.to_string());
    drop(s);
    drop(driver);
}

//! `groundscope study` when things go wrong (#81), continued: a training stopped by a signal
//! sent to its exec alone, values that every run refuses, paths that the plan's scripts must
//! quote or refuse, and an exec stopped or killed during its evaluation and run again at once.

use crate::common::{self, assert_bad_input, gs, stderr, stdout};
use crate::study::{plan, read, spec};

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// Sends `SIG<signal>` to process `pid` with kill(1); says whether kill did.
fn kill(pid: u32, signal: &str) -> bool {
    Command::new("kill")
        .args([format!("-{signal}"), pid.to_string()])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Whether process `pid` runs `groundscope CMD …` (its command line holds the word `cmd`).
fn runs(pid: u32, cmd: &str) -> bool {
    std::fs::read(format!("/proc/{pid}/cmdline"))
        .is_ok_and(|line| line.split(|&b| b == 0).any(|w| w == cmd.as_bytes()))
}

/// The pid of the `study exec` that holds the run's lock (the run directory's own,
/// `.train-lock`, which names its holder), once it names one that runs: the process in which
/// the run's steps run.
fn exec_pid(run: &Path) -> u32 {
    let mut pid = None;
    common::wait_until("an exec holding the run's lock", || {
        pid = std::fs::read_to_string(run.join(".train-lock"))
            .ok()
            .and_then(|t| t.trim().parse::<u32>().ok())
            .filter(|&p| runs(p, "exec"));
        pid.is_some()
    });
    pid.unwrap()
}

/// `study exec STUDY NAME` started, its output piped.
fn spawn_exec(study: &str, name: &str) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(["study", "exec", study, name])
        .env("RAYON_NUM_THREADS", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Whether `run`'s log.csv holds a row (its first update is logged).
fn logged(run: &Path) -> bool {
    std::fs::read_to_string(run.join("log.csv")).is_ok_and(|t| t.lines().count() >= 2)
}

#[test]
fn a_training_stopped_by_a_signal_to_it_alone_is_a_stopped_run_not_a_finished_one() {
    let dir = tempfile::tempdir().unwrap();
    // 200 updates of 64 frames each.
    let o = plan(
        dir.path(),
        &spec("[1]", false).replace("frames = 128", "frames = 12800"),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    let run = study.join("runs/tiny-small-s1");
    // SIGTERM to the exec alone (the training runs inside it), once its first update is
    // logged: a training so stopped used to save, exit 0, and be evaluated and marked done at
    // a fraction of its frames.
    let exec = spawn_exec(s, "tiny-small-s1");
    assert_eq!(exec_pid(&run), exec.id());
    common::wait_until("the training's first update", || logged(&run));
    assert!(kill(exec.id(), "TERM"));
    let o = common::output_after_exit(exec, "the exec of a stopped training");
    assert_eq!(o.status.code(), Some(130), "{}{}", stdout(&o), stderr(&o));
    assert!(
        stderr(&o).contains("train was stopped by a signal before it ended"),
        "{}",
        stderr(&o)
    );
    for file in ["study-done.json", "study-failed.json", "eval"] {
        assert!(!run.join(file).exists(), "{file}");
    }
    let log = read(&run.join("study.log"));
    assert!(
        log.contains("interrupted; saved") && log.contains("not finished (exit 130)"),
        "{log}"
    );
    assert!(!log.contains("== groundscope eval"), "{log}");
    // The line run again resumes the training from its checkpoint and finishes the run.
    let o = gs(&["study", "exec", s, "tiny-small-s1"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(run.join("study-done.json").is_file());
    let log = read(&run.join("study.log"));
    let last_train = log
        .lines()
        .rfind(|l| l.starts_with("== groundscope train"))
        .unwrap();
    assert!(last_train.ends_with("--resume"), "{log}");
    assert_eq!(read(&run.join("log.csv")).lines().count(), 1 + 200);
    // Under the runner: a run whose exec alone is stopped is named as stopped, neither done
    // nor failed, and the runner ends with 130; run again, it finishes.
    let other = study.join("runs/other-small-s1");
    let runner = Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(["study", "run", s, "--jobs", "1", "--quiet"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let exec = exec_pid(&other);
    common::wait_until("the other run's first update", || logged(&other));
    assert!(kill(exec, "TERM"));
    let o = common::output_after_exit(runner, "the runner");
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(130), "{out}{}", stderr(&o));
    assert!(
        out.contains("other-small-s1: stopped by a signal before it finished"),
        "{out}"
    );
    assert!(
        out.contains("1 of 2 runs done, 0 failed, 1 stopped"),
        "{out}"
    );
    assert!(!other.join("study-done.json").exists());
    let o = gs(&["study", "run", s, "--quiet"]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(other.join("study-done.json").is_file());
}

/// A spec of one tiny recipe without level flags, on `levels` (the `[levels]` table's lines).
fn spec_on(levels: &str) -> String {
    format!(
        r#"seeds = [1]
frames = 128
eval = ["--seeds", "1", "--episodes", "4"]

[recipes]
tiny = ["--procs", "4", "--frames-per-proc", "16", "--batch-size", "32", "--hidden", "16",
        "--eval-interval", "0"]

[levels]
{levels}
"#
    )
}

#[test]
fn a_plan_refuses_values_that_every_run_refuses_naming_the_run_and_the_flag() {
    let base = spec("[1]", false);
    let top = r#"eval = ["--seeds", "1", "--episodes", "4"]"#;
    let set = r#"eval = ["--sizes", "5", "--objects", "1"]"#;
    assert!(base.contains(top) && base.contains(set));
    let top_eval = |more: &str| {
        base.replace(
            top,
            &format!(r#"eval = ["--seeds", "1", "--episodes", "4", {more}]"#),
        )
    };
    let faithfulness =
        |flags: &str| base.replacen(top, &format!("faithfulness = [{flags}]\n{top}"), 1);
    let cases: [(String, &[&str]); 8] = [
        // Level ids minigrid has not: a BabyAI-style id, and one of a training mix.
        (
            spec_on(r#"nope = "BabyAI-Nope-v0""#),
            &["recipe tiny, level set nope: train: ", "BabyAI-Nope-v0"],
        ),
        (
            spec_on(r#"mix = { train = ["--levels", "BabyAI-GoToLocal-v0,BabyAI-Nope-v0:2"] }"#),
            &["level set mix: train: ", "BabyAI-Nope-v0"],
        ),
        // A PPO value every training refuses.
        (
            base.replace(
                r#""--hidden", "16","#,
                r#""--hidden", "16", "--epochs", "0","#,
            ),
            &["recipe tiny, level set small: train: ", "--epochs"],
        ),
        // Evaluation flags that failed only after each training.
        (
            top_eval(r#""--alpha", "1.5""#),
            &["recipe other, level set small: eval: ", "--alpha 1.5"],
        ),
        (top_eval(r#""--jobs", "0""#), &[": eval: ", "--jobs 0"]),
        (
            faithfulness(r#""--jobs", "0""#),
            &["level set small: faithfulness: ", "--jobs 0"],
        ),
        (
            base.replace(set, r#"eval = ["--levels", "BabyAI-Nope-v0"]"#),
            &["level set small: eval: ", "--levels", "BabyAI-Nope-v0"],
        ),
        (
            base.replace(set, r#"eval = ["--sizes", "5", "--objects", "12"]"#),
            &["level set small: eval: ", "--sizes 5 --objects 12"],
        ),
    ];
    for (text, says) in cases {
        let dir = tempfile::tempdir().unwrap();
        let o = plan(dir.path(), &text);
        assert_bad_input(&o, "study.toml");
        for s in says {
            assert!(stderr(&o).contains(*s), "{s:?} in {}", stderr(&o));
        }
        assert!(!dir.path().join("study").exists(), "{}", stderr(&o));
    }
    // The same flags with values a run takes are planned.
    let dir = tempfile::tempdir().unwrap();
    let o = plan(dir.path(), &top_eval(r#""--alpha", "1", "--jobs", "1""#));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// The groundscope binary at a path of its own, `dir/NAME/groundscope` (a hard link, or a
/// copy where the file system has none): what a plan run from there writes as the binary.
fn binary_in(dir: &Path, name: &str) -> PathBuf {
    let bin_dir = dir.join(name);
    std::fs::create_dir_all(&bin_dir).unwrap();
    let bin = bin_dir.join("groundscope");
    let exe = env!("CARGO_BIN_EXE_groundscope");
    if std::fs::hard_link(exe, &bin).is_err() {
        std::fs::copy(exe, &bin).unwrap();
    }
    bin
}

/// Runs `cmd`, again while its executable is still held open for writing by a process forked
/// meanwhile (ETXTBSY, a copy's short-lived race with parallel tests).
fn output_of(cmd: &mut Command) -> Output {
    for _ in 0..100 {
        match cmd.output() {
            Err(e) if e.raw_os_error() == Some(libc::ETXTBSY) => {
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
            other => return other.unwrap(),
        }
    }
    panic!("{cmd:?}: its executable stayed busy")
}

/// `BIN study plan SPEC --out OUT`, the spec being `text` (written into `dir`).
fn plan_with(bin: &Path, dir: &Path, text: &str, out: &Path) -> Output {
    let spec = dir.join("study.toml");
    std::fs::write(&spec, text).unwrap();
    output_of(
        Command::new(bin)
            .args(["study", "plan"])
            .arg(&spec)
            .arg("--out")
            .arg(out)
            .env("RAYON_NUM_THREADS", "1"),
    )
}

/// The words sh makes of `line` (as it would run it), one per line of its output.
fn sh_words(line: &str) -> Vec<String> {
    let o = Command::new("sh")
        .arg("-c")
        .arg(format!("for w in {line}; do printf '%s\\n' \"$w\"; done"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{line}: {}", stderr(&o));
    stdout(&o).lines().map(str::to_owned).collect()
}

/// The first argument of an `#SBATCH` line as sbatch parses it (Slurm's `_get_argument`): an
/// unquoted space ends it, a backslash keeps the next character, quotes group (`legacy`,
/// Slurm before its single quotes: only `"`, and a `#` ends the line even inside quotes), and
/// an unquoted `#` ends the line.
fn sbatch_argument(line: &str, legacy: bool) -> String {
    let rest = line.strip_prefix("#SBATCH").unwrap().trim_start();
    let (mut out, mut quote, mut escaped) = (String::new(), None, false);
    for c in rest.chars() {
        if quote.is_none() && c.is_whitespace() {
            break;
        }
        if escaped {
            escaped = false;
            out.push(c);
        } else if c == '\\' {
            escaped = true;
        } else if c == '#' && (quote.is_none() || legacy) {
            break;
        } else if quote == Some(c) {
            quote = None;
        } else if quote.is_none() && (c == '"' || (c == '\'' && !legacy)) {
            quote = Some(c);
        } else {
            out.push(c);
        }
    }
    assert!(quote.is_none(), "an unmatched quote in {line}");
    out
}

#[test]
fn paths_with_spaces_and_quotes_run_as_planned_and_a_newline_is_refused() {
    let base = tempfile::Builder::new()
        .tempdir_in(env!("CARGO_TARGET_TMPDIR"))
        .unwrap();
    let bin = binary_in(base.path(), "bin dir");
    let out = base.path().join(r#"a "b" c's #1 $x 100%"#);
    let o = plan_with(&bin, base.path(), &spec("[1]", false), &out);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = std::fs::canonicalize(&out).unwrap();
    let study_text = study.to_str().unwrap().to_owned();
    let bin_text = std::fs::canonicalize(&bin)
        .unwrap()
        .to_str()
        .unwrap()
        .to_owned();
    // commands.txt: each line is the words it means, as sh reads them.
    let commands = read(&study.join("commands.txt"));
    let lines: Vec<&str> = commands.lines().collect();
    for (line, name) in lines.iter().zip(["other-small-s1", "tiny-small-s1"]) {
        let words = Vec::from(
            [
                bin_text.as_str(),
                "study",
                "exec",
                study_text.as_str(),
                name,
            ]
            .map(str::to_owned),
        );
        assert_eq!(sh_words(line), words, "{line}");
    }
    // A line runs under sh: the run trains, evaluates and is done.
    let o = output_of(Command::new("sh").args(["-c", lines[1]]));
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(study.join("runs/tiny-small-s1/study-done.json").is_file());
    // slurm.sbatch: its #SBATCH lines read back as sbatch reads them (old and new parsers),
    // and its body, run by bash as a task, runs the task's line.
    let sbatch = read(&study.join("slurm.sbatch"));
    let output = sbatch
        .lines()
        .find(|l| l.starts_with("#SBATCH --output="))
        .unwrap();
    let logs = format!(
        "--output={}/slurm-logs/%A_%a.txt",
        study_text.replace('%', "%%")
    );
    for legacy in [false, true] {
        assert_eq!(sbatch_argument(output, legacy), logs, "{output}");
    }
    let job = sbatch
        .lines()
        .find(|l| l.starts_with("#SBATCH --job-name="))
        .unwrap();
    assert_eq!(
        sbatch_argument(job, false),
        &job["#SBATCH ".len()..],
        "{job}"
    );
    let o = Command::new("bash")
        .arg(study.join("slurm.sbatch"))
        .env("SLURM_ARRAY_TASK_ID", "0")
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(study.join("runs/other-small-s1/study-done.json").is_file());
    // ray_driver.py: the path is a Python string literal that reads back as itself.
    let script = "import ast, sys\n\
                  tree = ast.parse(open(sys.argv[1], encoding='utf-8').read())\n\
                  print(next(ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign) \
                  and n.targets[0].id == 'STUDY'), end='')";
    if let Ok(o) = Command::new("python3")
        .args(["-c", script])
        .arg(study.join("ray_driver.py"))
        .output()
    {
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(stdout(&o), study_text);
    }
    // What no file can carry is refused in one line naming the path, and nothing is made: a
    // control character in the study's path or in the binary's, a backslash in the study's.
    let text = spec("[1]", false);
    for (name, says) in [
        ("new\nline", "control character"),
        ("a\ttab", "control character"),
        (r"back\slash", "backslash"),
    ] {
        let out = base.path().join(name);
        let o = plan_with(&bin, base.path(), &text, &out);
        assert_bad_input(&o, says);
        assert!(stderr(&o).contains("--out"), "{}", stderr(&o));
        assert!(!out.exists(), "{name:?}");
    }
    let bad_bin = binary_in(base.path(), "bin\nnewline");
    let out = base.path().join("fine");
    let o = plan_with(&bad_bin, base.path(), &text, &out);
    assert_bad_input(&o, "this binary's path");
    assert!(stderr(&o).contains("control character"), "{}", stderr(&o));
    assert!(!out.exists());
}

/// A process killed (SIGKILL) when the test ends, however it ends: an exec left evaluating
/// forever is not left running.
struct KillOnDrop(u32);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        kill(self.0, "KILL");
    }
}

impl KillOnDrop {
    /// The process has ended and been waited for: its pid is no longer its own to signal.
    fn disarm(self) {
        std::mem::forget(self);
    }
}

/// How many steps named `cmd` the run's `study.log` says have started.
fn started(run: &Path, cmd: &str) -> usize {
    std::fs::read_to_string(run.join("study.log"))
        .unwrap_or_default()
        .matches(&format!("== groundscope {cmd}"))
        .count()
}

#[test]
fn an_exec_evaluating_holds_the_run_and_a_stop_or_a_kill_leaves_it_to_evaluate_again() {
    let dir = tempfile::tempdir().unwrap();
    // An evaluation that runs until it is stopped (999,999 episodes).
    let text = spec("[1]", false).replace(
        r#"eval = ["--seeds", "1", "--episodes", "4"]"#,
        r#"eval = ["--seeds", "1", "--episodes", "999999"]"#,
    );
    let o = plan(dir.path(), &text);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    let run = study.join("runs/tiny-small-s1");
    let exec = spawn_exec(s, "tiny-small-s1");
    let guard = KillOnDrop(exec.id());
    common::wait_until("the evaluation's start", || started(&run, "eval") == 1);
    // The line run again at once is left alone while that evaluation runs, naming the holder
    // (it used to start a second evaluation beside the first when the exec was killed): the
    // evaluation runs inside the exec, under the run directory's lock.
    let o = common::gs_guarded(&["study", "exec", s, "tiny-small-s1"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let said = stdout(&o);
    assert!(
        said.contains(&format!(
            "running elsewhere (its lock is held by pid {})",
            exec.id()
        )) && said.contains("left alone"),
        "{said}"
    );
    assert_eq!(started(&run, "eval"), 1);
    // A stop of the exec stops its evaluation, which writes nothing: a stopped run, not a
    // failed one.
    assert!(kill(exec.id(), "INT"));
    let o = common::output_after_exit(exec, "the stopped exec");
    guard.disarm();
    assert_eq!(o.status.code(), Some(130), "{}{}", stdout(&o), stderr(&o));
    assert!(
        stderr(&o).contains("eval was stopped by a signal before it ended"),
        "{}",
        stderr(&o)
    );
    for file in ["study-done.json", "study-failed.json", "eval/report.json"] {
        assert!(!run.join(file).exists(), "{file}");
    }
    // Run again, its training has nothing left to do and it evaluates again; killed (SIGKILL)
    // meanwhile, it takes its evaluation with it, and the system frees the run's lock.
    let mut exec = spawn_exec(s, "tiny-small-s1");
    let guard = KillOnDrop(exec.id());
    common::wait_until("the second evaluation's start", || {
        started(&run, "eval") == 2
    });
    exec.kill().unwrap();
    exec.wait().unwrap();
    guard.disarm();
    assert!(
        std::fs::File::open(run.join(".train-lock")).is_ok_and(|f| f.try_lock().is_ok()),
        "the run's lock outlived its exec"
    );
    let log = read(&run.join("study.log"));
    assert_eq!(log.matches("== groundscope train").count(), 2, "{log}");
    assert!(log.contains("== groundscope train --resume"), "{log}");
}

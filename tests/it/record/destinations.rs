//! Recordings (`.rrd`, MCAP) against hostile destinations and interruptions: devices, FIFOs,
//! symlinks, file-size limits, missing or wrong viewers, Ctrl-C; and one-line messages for
//! mistyped numbers.

use crate::common::{self, assert_bad_input, entries, gs};

use std::os::unix::fs::FileTypeExt as _;
use std::process::{Command, Stdio};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_groundscope"));
    c.env("RAYON_NUM_THREADS", "1");
    c
}

#[test]
fn recordings_write_into_devices_fifos_and_through_symlinks() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    // A full device behind a link: the OS's reason, exit 2, the link untouched.
    for (name, flag) in [("full.rrd", "--save"), ("full.mcap", "--mcap")] {
        let link = dir.join(name);
        std::os::unix::fs::symlink("/dev/full", &link).unwrap();
        let o = gs(&["replay", "--seed", "1", flag, link.to_str().unwrap()]);
        assert_bad_input(&o, "No space left on device");
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
    }
    // A FIFO receives a whole MCAP file and stays a FIFO.
    let fifo = dir.join("pipe.mcap");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(fifo).unwrap())
    };
    let o = gs(&["replay", "--seed", "1", "--mcap", fifo.to_str().unwrap()]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let bytes = reader.join().unwrap();
    assert!(bytes.starts_with(b"\x89MCAP0\r\n"), "MCAP magic");
    assert!(bytes.ends_with(b"\x89MCAP0\r\n"), "MCAP footer magic");
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo()
    );
    // A link to a regular file: the target gets the recording, the link stays.
    let target = dir.join("real.rrd");
    std::fs::write(&target, b"old").unwrap();
    let link = dir.join("link.rrd");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let o = gs(&["replay", "--seed", "1", "--save", link.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0));
    assert!(std::fs::metadata(&target).unwrap().len() > 1000);
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(
        entries(dir),
        ["full.mcap", "full.rrd", "link.rrd", "pipe.mcap", "real.rrd"]
    );
}

#[test]
fn a_file_size_limit_is_a_clean_error_with_nothing_left() {
    let tmp = tempfile::tempdir().unwrap();
    for (name, flag) in [("x.rrd", "--save"), ("x.mcap", "--mcap")] {
        let out = tmp.path().join(name);
        // 64 blocks of 512 bytes: less than 20 recorded episodes take.
        let o = Command::new("sh")
            .args(["-c", "ulimit -f 64; exec \"$0\" \"$@\""])
            .arg(env!("CARGO_BIN_EXE_groundscope"))
            .args(["replay", "--seed", "0", "--episodes", "20", flag])
            .arg(&out)
            .env("RAYON_NUM_THREADS", "1")
            .output()
            .unwrap();
        assert_bad_input(&o, "File too large");
        assert!(entries(tmp.path()).is_empty(), "{:?}", entries(tmp.path()));
    }
}

#[test]
fn viewer_problems_are_one_line() {
    // No `rerun` on PATH.
    let empty = tempfile::tempdir().unwrap();
    let o = bin()
        .args(["replay", "--seed", "1", "--spawn"])
        .env("PATH", empty.path())
        .output()
        .unwrap();
    assert_bad_input(&o, "no `rerun` viewer on PATH");
    // Something listens but is not a Rerun viewer: it takes connections and closes them.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            drop(stream);
        }
    });
    let url = format!("rerun+http://127.0.0.1:{port}/proxy");
    let child = bin()
        .args(["replay", "--seed", "1", "--connect", &url])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let o = common::output_after_exit(child, "replay --connect to something else");
    assert_bad_input(&o, &format!("no Rerun viewer at {url}"));
}

#[test]
fn negative_numbers_get_the_range_message() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("e");
    let o = gs(&[
        "eval",
        "--sizes",
        "8",
        "--objects",
        "4",
        "--seeds",
        "1",
        "--episodes",
        "1",
        "--min-acc-ng",
        "-0.5",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_bad_input(&o, "--min-acc-ng -0.5 is outside [0, 1]");
    let run = tmp.path().join("run");
    let o = gs(&["train", "--out", run.to_str().unwrap(), "--procs", "-1"]);
    assert_bad_input(&o, "invalid value '-1' for '--procs");
    assert!(entries(tmp.path()).is_empty());
}

#[test]
fn ctrl_c_during_replay_says_so_and_leaves_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let rrd = tmp.path().join("long.rrd");
    let mcap = tmp.path().join("long.mcap");
    let mut child = bin()
        .args(["replay", "--seed", "0", "--episodes", "100000", "--save"])
        .arg(&rrd)
        .arg("--mcap")
        .arg(&mcap)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Interrupt it while it records: once its first episode is printed and its (temporary)
    // outputs exist.
    let stdout = common::lines(child.stdout.take().unwrap());
    let first = common::next_line(&stdout, "first episode of the replay");
    assert!(first.contains("seed 0:"), "{first}");
    common::wait_until("the recordings' temporary files", || {
        !entries(tmp.path()).is_empty()
    });
    common::send_signal(&child, "INT");
    let o = common::output_after_exit(child, "replay after Ctrl-C");
    assert_bad_input(&o, "interrupted");
    assert!(entries(tmp.path()).is_empty(), "{:?}", entries(tmp.path()));
}

#[test]
fn replay_streams_any_number_of_episodes() {
    // Once capped at 1,000 because every episode was held until the end.
    let o = gs(&["replay", "--seed", "0", "--episodes", "1200"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 1200);
    assert_bad_input(&gs(&["replay", "--episodes", "0"]), "--episodes 0");
}

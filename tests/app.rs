//! The debugger as a user starts it: a real frame rendered under Xvfb, and its errors.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::format_collect,
    reason = "tests fail loudly"
)]

use std::process::{Command, Output};

fn gs(args: &[&str], display: Option<&str>) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_groundscope"));
    cmd.args(args)
        .env("RAYON_NUM_THREADS", "1")
        .env_remove("WAYLAND_DISPLAY");
    match display {
        Some(d) => cmd.env("DISPLAY", d),
        None => cmd.env_remove("DISPLAY"),
    };
    cmd.output().expect("the binary runs")
}

/// The screenshot under `xvfb-run` (CI installs it: `apt-get install xvfb xauth`).
fn xvfb_screenshot(args: &[&str]) -> Output {
    let mut cmd = Command::new("xvfb-run");
    cmd.args(["-a", "-s", "-screen 0 1600x1000x24"])
        .arg(env!("CARGO_BIN_EXE_groundscope"))
        .args(args)
        .env("RAYON_NUM_THREADS", "1")
        .env("LIBGL_ALWAYS_SOFTWARE", "1");
    cmd.output()
        .expect("xvfb-run is needed for this test: apt-get install xvfb xauth")
}

#[test]
fn screenshot_renders_the_real_panels() {
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot.png");
    let o = xvfb_screenshot(&[
        "view",
        "--screenshot",
        shot.to_str().unwrap(),
        "--seed",
        "3",
        "--step",
        "2",
        "--size",
        "1200x800",
    ]);
    assert!(
        o.status.success(),
        "stdout: {}\nstderr: {}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let img = image::open(&shot).unwrap().to_rgb8();
    // The window's size (logical = physical pixels under Xvfb).
    assert_eq!(img.dimensions(), (1200, 800));
    // A real picture: many distinct colours (tiles, viridis maps, text), not a blank frame.
    let colours: std::collections::BTreeSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    assert!(colours.len() > 200, "only {} colours", colours.len());
    // Viridis' dark purple end (the maps' low values) appears somewhere in the central panel.
    let purple = img
        .pixels()
        .filter(|p| p.0[2] > 60 && p.0[0] < 80 && p.0[1] < 40)
        .count();
    assert!(purple > 500, "no heat map pixels ({purple})");
    // The agent (MiniGrid red, lightened where its view is highlighted) is in the left panel.
    let red = img
        .enumerate_pixels()
        .filter(|(x, _, p)| *x < 450 && p.0[0] > 200 && p.0[1] < 100 && p.0[2] < 100)
        .count();
    assert!(red > 20, "no agent in the world panel ({red})");
}

#[test]
fn no_display_is_a_clear_error_that_suggests_a_recording() {
    let o = gs(&["view", "--seed", "1"], None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("no display") && err.contains("replay"),
        "{err}"
    );
    // Without a subcommand the debugger is what starts.
    let o = gs(&[], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no display"));
}

#[test]
fn bad_view_arguments_are_one_line_errors() {
    for (args, what) in [
        (vec!["view", "--size", "big"], "--size"),
        (vec!["view", "--checkpoint", "nope/missing"], "nope/missing"),
        (vec!["view", "--mission", "go to the pink key"], "pink"),
        (vec!["view", "--screenshot", "out.jpg"], ".png"),
        (vec!["view", "--room-size", "3"], "3"),
    ] {
        let o = gs(&args, Some(":99999"));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(what), "{args:?}: expected {what:?} in {err}");
    }
}

#[test]
fn the_faithfulness_view_adds_the_occlusion_map() {
    let dir = tempfile::tempdir().unwrap();
    let purple = |with: bool| {
        let shot = dir.path().join(format!("f{with}.png"));
        let mut args = vec![
            "view",
            "--screenshot",
            shot.to_str().unwrap(),
            "--seed",
            "3",
            "--step",
            "1",
            "--size",
            "1400x1100",
        ];
        if with {
            args.push("--faithfulness");
        }
        let o = xvfb_screenshot(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let img = image::open(&shot).unwrap().to_rgb8();
        // Viridis' dark end, in the central panel.
        img.enumerate_pixels()
            .filter(|(x, _, p)| *x > 450 && p.0[2] > 60 && p.0[0] < 80 && p.0[1] < 40)
            .count()
    };
    let (without, with) = (purple(false), purple(true));
    assert!(
        with > without + 2000,
        "one more 7×7 map: {without} → {with} dark viridis pixels"
    );
}

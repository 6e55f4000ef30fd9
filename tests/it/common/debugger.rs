//! The debugger in egui's test harness, as `groundscope view` opens it.

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable as _;
use groundscope::app::{Debugger, Launch};

/// The debugger at the default window size, 1400×900.
pub fn build(opts: &Launch) -> Harness<'static, Debugger> {
    build_sized(opts, [1400.0, 900.0])
}

/// The debugger in a window of `size` points.
pub fn build_sized(opts: &Launch, size: [f32; 2]) -> Harness<'static, Debugger> {
    Harness::builder()
        .with_size(size)
        // The harness would also fail on the inputs without an accessible name (the
        // controls' combo boxes, drag values and text fields): not what these tests are about.
        .with_accessibility_check(false)
        .build_ui_state(
            |ui, d: &mut Debugger| d.frame(ui),
            Debugger::new(opts, None),
        )
}

/// Runs frames until a label containing `text` shows and the episode, if one is shown, is
/// all in (it runs in the background and shows its first steps while the rest come).
pub fn show_until(h: &mut Harness<'_, Debugger>, text: &str) {
    super::wait_until(&format!("a label with {text:?}"), || {
        h.step();
        // Compare mode shows a second policy panel: any match will do.
        h.query_all_by_label_contains(text).next().is_some()
            && h.state()
                .episode_progress()
                .is_none_or(|(_, all_in)| all_in)
    });
}

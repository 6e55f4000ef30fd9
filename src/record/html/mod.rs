//! One self-contained HTML page per episode (`replay --html`, and `eval --html`'s worst
//! episodes): the world with `M` tinted on it, the agent's view, every word map with its weight
//! and entropy on the step's shared scale, the action probabilities, the instruction tree and
//! minigrid's bot, for every step, under one step slider; two episodes side by side on one step
//! axis for a compare. The page needs no network and nothing beside it: its script, style,
//! tiles and data are all inside (docs/sharing.md).
//!
//! Like every sink, it only reads [`EpisodeTrace`]s and their [`StepScene`](super::StepScene)s;
//! nothing here runs the policy. Pictures are not embedded a step at a time: the tiles the
//! episode shows are drawn once by the renderer into an atlas ([`atlas`]), and each step stores
//! tile indices and its maps as small numbers ([`data`]); the page's script lays them out with
//! the same colours, scale and marks as the debugger.

mod atlas;
mod data;

use std::path::Path;

use base64::Engine as _;
use serde::Serialize;

use super::scene::{NEGLIGIBLE_WEIGHT, OVERLAY_ALPHA, TILE_PX, action_names};
use super::{PendingFile, RecordError, StopFlag};
use crate::episode::EpisodeTrace;
use crate::metrics::report::escape_html;
use crate::render::overlay::{TRAIL_ALPHA, ring_px, target_arm_px, trail_half_px};
use crate::render::palette::{self, Rgb};

/// Pixels per cell of the page's world and view pictures: twice a recording's
/// ([`TILE_PX`]), as the atlas holds each tile once and the browser shows the world at about
/// the debugger's size.
pub const PAGE_TILE_PX: u32 = 2 * TILE_PX;

/// The page: markup and style, with `{{TITLE}}`, `{{STYLE}}`, `{{SCRIPT}}` and `{{DATA}}`
/// filled in by [`episode_page`].
const TEMPLATE: &str = include_str!("page.html");
/// The page's style.
const STYLE: &str = include_str!("page.css");
/// The page's script: it draws every panel from the data at the step the slider shows.
const SCRIPT: &str = include_str!("page.js");

/// `#rrggbb`.
pub(crate) fn hex([r, g, b]: Rgb) -> String {
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// Everything the page draws with that is not an episode's: the colours, sizes and names
/// every display shares, taken from where they are defined, so the page cannot drift from
/// the debugger and the recordings.
#[derive(Debug, Serialize)]
struct LookJson {
    tile: u32,
    ring: u32,
    arm: u32,
    trail_half: u32,
    trail_alpha: f32,
    overlay_alpha: f32,
    trail: String,
    target: String,
    chosen_bar: String,
    bar: String,
    negligible: f32,
    viridis: Vec<String>,
    action_names: Vec<&'static str>,
}

impl LookJson {
    fn new() -> Self {
        Self {
            tile: PAGE_TILE_PX,
            ring: ring_px(PAGE_TILE_PX),
            arm: target_arm_px(PAGE_TILE_PX),
            trail_half: trail_half_px(PAGE_TILE_PX),
            trail_alpha: TRAIL_ALPHA,
            overlay_alpha: OVERLAY_ALPHA,
            trail: hex(palette::TRAIL),
            target: hex(palette::TARGET),
            chosen_bar: hex(palette::CHOSEN_BAR),
            bar: hex(palette::BAR),
            negligible: NEGLIGIBLE_WEIGHT,
            viridis: palette::VIRIDIS.iter().map(|&c| hex(c)).collect(),
            action_names: action_names().to_vec(),
        }
    }
}

/// The atlas as the page reads it.
#[derive(Debug, Serialize)]
struct AtlasJson {
    /// The PNG as a `data:` URI.
    png: String,
    /// Tiles per row.
    cols: usize,
    /// What the maps outline at a view cell showing each tile.
    landmarks: Vec<String>,
}

/// The page's data.
#[derive(Debug, Serialize)]
struct PageJson {
    look: LookJson,
    atlas: AtlasJson,
    panels: Vec<data::PanelJson>,
}

/// The page's title: the level and seed, and who acted (both, for a compare).
fn page_title(episodes: &[&EpisodeTrace]) -> String {
    let who: Vec<String> = episodes.iter().map(|t| data::title(t)).collect();
    match episodes.first() {
        Some(t) => format!(
            "groundscope · {} seed {} · {}",
            t.level,
            t.seed,
            who.join(" vs ")
        ),
        None => "groundscope".to_owned(),
    }
}

/// `template` with each `{{NAME}}` replaced by its value in `values`, in one pass: a value is
/// never searched for placeholders itself (a mission or a checkpoint's name stays as given).
fn fill(template: &str, values: &[(&str, &str)]) -> String {
    let mut out =
        String::with_capacity(template.len() + values.iter().map(|v| v.1.len()).sum::<usize>());
    let mut rest = template;
    while let Some(at) = rest.find("{{") {
        out.push_str(&rest[..at]);
        let after = &rest[at + 2..];
        let found = after.find("}}").and_then(|end| {
            let name = &after[..end];
            values
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| (end, *v))
        });
        if let Some((end, value)) = found {
            out.push_str(value);
            rest = &after[end + 2..];
        } else {
            out.push_str("{{");
            rest = after;
        }
    }
    out.push_str(rest);
    out
}

/// The page of one episode, or of several side by side on one step axis (a compare: the same
/// episode spec run by each checkpoint; a shorter episode holds its last step). Maps are
/// graded on threshold fraction `alpha`, as in a recording. Polls `stop` between blocks of
/// steps.
pub fn episode_page(
    episodes: &[&EpisodeTrace],
    alpha: f64,
    stop: Option<&StopFlag>,
) -> Result<String, RecordError> {
    if episodes.is_empty() {
        return Err(RecordError::Empty);
    }
    let mut tiles = atlas::Atlas::default();
    let panels = episodes
        .iter()
        .map(|t| data::panel(t, alpha, &mut tiles, stop))
        .collect::<Result<Vec<_>, _>>()?;
    let png = tiles.png(PAGE_TILE_PX)?;
    let page = PageJson {
        look: LookJson::new(),
        atlas: AtlasJson {
            png: format!(
                "data:image/png;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(png)
            ),
            cols: atlas::ATLAS_COLUMNS,
            landmarks: tiles.landmarks(),
        },
        panels,
    };
    // Plain data with string keys and finite floats cannot fail to serialise. Inside a
    // <script> element only `</script` could end it early, and `<` occurs only within JSON
    // strings, where `\u003c` means the same.
    let json = serde_json::to_string(&page)
        .unwrap_or_default()
        .replace('<', "\\u003c");
    let title = escape_html(&page_title(episodes));
    Ok(fill(
        TEMPLATE,
        &[
            ("TITLE", title.as_str()),
            ("STYLE", STYLE),
            ("SCRIPT", SCRIPT),
            ("DATA", json.as_str()),
        ],
    ))
}

/// Writes [`episode_page`] to `dest` through a [`PendingFile`]: complete, or not at all.
pub fn write_episode_page(
    dest: &Path,
    episodes: &[&EpisodeTrace],
    alpha: f64,
    stop: Option<&StopFlag>,
) -> Result<(), RecordError> {
    let file = PendingFile::new(dest)?;
    let page = episode_page(episodes, alpha, stop)?;
    file.write_all(page.as_bytes())?;
    file.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders_are_filled_once_and_values_are_not_searched() {
        let out = fill(
            "<t>{{TITLE}}</t>{{DATA}}{{NONE}}{{",
            &[("TITLE", "{{DATA}}"), ("DATA", "x")],
        );
        assert_eq!(out, "<t>{{DATA}}</t>x{{NONE}}{{");
    }

    #[test]
    fn the_template_has_every_placeholder_and_no_remote_reference() {
        for name in ["{{TITLE}}", "{{STYLE}}", "{{SCRIPT}}", "{{DATA}}"] {
            assert!(TEMPLATE.contains(name), "{name}");
        }
        for text in [TEMPLATE, STYLE, SCRIPT] {
            for remote in ["http://", "https://", "//cdn", "@import", "url("] {
                assert!(!text.contains(remote), "{remote}");
            }
        }
        assert_eq!(hex([255, 0, 16]), "#ff0010");
    }
}

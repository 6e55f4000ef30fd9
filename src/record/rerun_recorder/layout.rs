//! The recording's default layout (blueprint): which views, where, under which names, and the
//! settings Rerun 0.36's Rust blueprint API has no call for (a plot's legend corner), logged
//! into the blueprint store beside the views.

use rerun::blueprint::components::PanelState;
use rerun::blueprint::{
    Blueprint, BlueprintActivation, BlueprintPanel, ContainerLike, Grid, Horizontal,
    SelectionPanel, Spatial2DView, TextDocumentView, TextLogView, TimePanel, TimeSeriesView,
    Vertical,
};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    PlotLegend, TextLogColumns, VisualBounds2D,
};
use rerun::external::re_sdk_types::blueprint::datatypes::{
    TextLogColumn, TextLogColumnKind, TimelineColumn,
};
use rerun::external::re_sdk_types::datatypes::{Range1D, Range2D};
use rerun::log::LogMsg;
use rerun::{RecordingStream, RecordingStreamBuilder};

use super::{RecordError, marks, sdk};

/// The longest title a word map gets, in characters: what a map of a long mission's grid
/// shows uncut ("go (word 0)" read "go (wo…" in the 0.36.3 viewer at 1600×1000).
const MAX_MAP_TITLE: usize = 9;

/// The title of word map `path` (`attention/words/<i>_<word>`, or a folded word's under
/// `attention/function_words/`): the word, with its position first (`"3:the"`) when the
/// recording holds the same word at several positions, cut to [`MAX_MAP_TITLE`] characters
/// with "…" where it is longer ("12:match…"), so that the viewer never cuts it elsewhere.
fn word_title(path: &str, all: &[String]) -> String {
    fit_title(full_word_title(path, all))
}

/// `title`, cut to [`MAX_MAP_TITLE`] characters, its last one "…" where it was longer.
fn fit_title(title: String) -> String {
    if title.chars().count() <= MAX_MAP_TITLE {
        return title;
    }
    let kept: String = title.chars().take(MAX_MAP_TITLE - 1).collect();
    format!("{kept}…")
}

/// [`word_title`] before it is cut.
fn full_word_title(path: &str, all: &[String]) -> String {
    let name = path.rsplit('/').next().unwrap_or(path);
    let (i, word) = name.split_once('_').unwrap_or(("", name));
    let same = all
        .iter()
        .filter(|p| {
            p.rsplit('/')
                .next()
                .and_then(|n| n.split_once('_'))
                .map(|(_, w)| w)
                == Some(word)
        })
        .count();
    if same > 1 {
        format!("{i}:{word}")
    } else {
        word.to_owned()
    }
}

/// Columns of the grid of maps: as many as rows (the maps' area of the default layout is
/// about square), so that each square map fills its cell instead of sitting in a black
/// margin, as two rows of four did (read in the 0.36.3 viewer at 1600×1000).
fn map_columns(n_maps: usize) -> u32 {
    (1..=n_maps.max(1)).find(|c| c * c >= n_maps).unwrap_or(1) as u32
}

/// The default layout: world and view on the left; the word maps, `M` (and Δ) with the
/// colour bar they share in the middle, with the named w, H and action bars under them;
/// the policy's status, value and reward, the words table, grounding and faithfulness (as
/// text: a plot's legend would cover its points) on the right. Every map
/// view also shows the landmarks (walls, objects, unseen cells, the agent).
fn layout(
    word_paths: &[String],
    attention: bool,
    faithfulness: bool,
    world_cells: (usize, usize),
    actions: usize,
) -> (Blueprint, Settings) {
    let mut settings = Settings::default();
    // Its legend would sit on the curves (at the start the value is high, at the end the
    // reward spikes): it is hidden, and the title names each series by its colour.
    let plot: ContainerLike = TimeSeriesView::new(VALUE_PLOT)
        .with_origin("/policy")
        .with_contents(["/policy/value", "/policy/reward"])
        .into();
    settings.hidden_legends.extend(view_path(&plot));
    // The whole world in view, however big: Rerun's own fit cut a 22×22 world at 1600×1000.
    let world: ContainerLike = Spatial2DView::new("world").with_origin("/world").into();
    if let Some(path) = view_path(&world) {
        let tile = f64::from(crate::record::scene::TILE_PX);
        let range = Range2D {
            x_range: Range1D([0.0, world_cells.0 as f64 * tile]),
            y_range: Range1D([0.0, world_cells.1 as f64 * tile]),
        };
        settings.bounds.push((path, range));
    }
    let left = Vertical::new([
        world,
        TextDocumentView::new("world legend")
            .with_origin(format!("/{}", super::entities::WORLD_LEGEND))
            .into(),
        Spatial2DView::new("agent view").with_origin("/view").into(),
    ])
    .with_row_shares([3.0, 0.5, 1.0]);
    let mut right = vec![
        TextDocumentView::new("status")
            .with_origin("/policy/status")
            .into(),
        TextDocumentView::new("instruction (bold: waited on)")
            .with_origin("/mission/tree")
            .into(),
        plot,
        text_log("actions", "/policy/action", &mut settings),
        text_log(
            "expert (minigrid's bot): its action and plan",
            "/policy/expert",
            &mut settings,
        ),
    ];
    // As many rows as actions the policy scores (3 for a 3-action agent).
    let probs = bar_view(
        "action probabilities",
        "/policy/probs",
        actions,
        &mut settings,
    );
    if !attention {
        right.insert(1, probs);
        let bp = panels(Blueprint::new(Horizontal::new([
            left.into(),
            Vertical::new(right).into(),
        ])));
        return (bp, settings);
    }
    right.push(
        TextDocumentView::new("words: w and H")
            .with_origin("/attention/legend")
            .into(),
    );
    right.push(
        TextDocumentView::new("grounding (this step)")
            .with_origin("/metrics/grounding")
            .into(),
    );
    let with_landmarks =
        |origin: String| [format!("{origin}/**"), format!("/{}/**", marks::LANDMARKS)];
    let folded = |p: &str| p.starts_with(super::FUNCTION_WORD_MAPS);
    let mut maps: Vec<ContainerLike> = word_paths
        .iter()
        .map(|p| {
            let origin = format!("/{p}");
            let view = Spatial2DView::new(word_title(p, word_paths))
                .with_origin(origin.as_str())
                .with_contents(with_landmarks(origin.clone()));
            // Folded as the debugger folds it: in the grid, in mission order, but hidden
            // (its eye in the blueprint panel shows it again), so the content words' maps
            // get the room.
            if folded(p.as_str()) {
                view.with_visible(false).into()
            } else {
                view.into()
            }
        })
        .collect();
    let hidden = word_paths.iter().filter(|p| folded(p.as_str())).count();
    maps.push(
        Spatial2DView::new("combined M")
            .with_origin("/attention/combined")
            .with_contents(with_landmarks("/attention/combined".to_owned()))
            .into(),
    );
    if faithfulness {
        maps.push(
            Spatial2DView::new("occlusion Δ (own scale 0–1)")
                .with_origin("/faithfulness/occlusion")
                .with_contents(with_landmarks("/faithfulness/occlusion".to_owned()))
                .into(),
        );
        right.push(
            TextDocumentView::new("faithfulness: ρ(M, Δ), peaks, flips")
                .with_origin("/faithfulness/summary")
                .into(),
        );
    }
    // Hidden views take no cell of the grid.
    let n_maps = maps.len() - hidden;
    let middle = Vertical::new([
        Horizontal::new([
            Grid::new(maps)
                .with_grid_columns(map_columns(n_maps))
                .into(),
            Spatial2DView::new("scale")
                .with_origin("/attention/colorbar")
                .into(),
        ])
        .with_column_shares([12.0, 1.0])
        .into(),
        Horizontal::new([
            bar_view(
                "weights w",
                "/attention/weights",
                n_words(word_paths),
                &mut settings,
            ),
            bar_view(
                "entropies H (nats)",
                "/attention/entropy",
                n_words(word_paths),
                &mut settings,
            ),
            probs,
        ])
        .into(),
    ])
    .with_row_shares([3.0, 1.0]);
    // A big world (BabyAI's 3×3 rooms: 22×22 cells) gets a wider column.
    let left_share = if world_cells.0.max(world_cells.1) > 12 {
        1.6
    } else {
        1.2
    };
    let bp = panels(Blueprint::new(
        Horizontal::new([left.into(), middle.into(), Vertical::new(right).into()])
            .with_column_shares([left_share, 2.0, 1.0]),
    ));
    (bp, settings)
}

/// A text log view showing only the `step` and each line's text: the entity-path and level
/// columns Rerun shows by default took half its width and say the same on every row.
fn text_log(title: &str, origin: &str, settings: &mut Settings) -> ContainerLike {
    let view: ContainerLike = TextLogView::new(title).with_origin(origin).into();
    settings.text_logs.extend(view_path(&view));
    view
}

/// What the layout sets that the Rust blueprint API has no call for: plots whose legend is
/// hidden, and views' first visible bounds; each by its view's blueprint path.
#[derive(Default)]
struct Settings {
    hidden_legends: Vec<String>,
    bounds: Vec<(String, Range2D)>,
    text_logs: Vec<String>,
}

fn view_path(view: &ContainerLike) -> Option<String> {
    match view {
        ContainerLike::View(v) => Some(v.blueprint_path().to_string()),
        _ => None,
    }
}

/// Rows of the w and H charts: the longest mission's words.
fn n_words(word_paths: &[String]) -> usize {
    word_paths
        .iter()
        .filter_map(|p| {
            p.rsplit('/')
                .next()?
                .split_once('_')?
                .0
                .parse::<usize>()
                .ok()
        })
        .max()
        .map_or(0, |i| i + 1)
}

/// A bar chart's view of `rows` rows, showing the first [`marks::BAR_ROWS_SHOWN`] at a
/// size their labels can be read at; a longer chart scrolls (drag it), and its title says
/// how many rows it shows of how many.
fn bar_view(title: &str, origin: &str, rows: usize, settings: &mut Settings) -> ContainerLike {
    let shown = rows.clamp(1, marks::BAR_ROWS_SHOWN);
    let title = if rows > shown {
        // Short: the viewer cut "weights w (first 8 of 11: drag to scroll)" after "(first".
        format!("{title}, {shown} of {rows}")
    } else {
        title.to_owned()
    };
    let view: ContainerLike = Spatial2DView::new(title).with_origin(origin).into();
    if let Some(path) = view_path(&view) {
        let margin = f64::from(marks::BAR_GAP);
        let range = Range2D {
            x_range: Range1D([-margin, f64::from(marks::BAR_LENGTH) + margin]),
            y_range: Range1D([-margin, shown as f64 * f64::from(marks::BAR_PITCH) + margin]),
        };
        settings.bounds.push((path, range));
    }
    view
}

/// The title of the value-and-reward plot, whose series it names by colour (the colours
/// `entities` gives them).
pub const VALUE_PLOT: &str = "value (blue) and reward (green)";

/// Sends the default layout ([`layout`]) through `rec`, activated at once, with the
/// value-and-reward plot's legend hidden. Rerun 0.36's Rust blueprint API has no legend
/// setting (Python's `PlotLegend`), so the blueprint is built as messages, its `PlotLegend` is
/// logged for the plot's view under the blueprint store's own id, and the whole is sent as
/// `with_blueprint` would send it.
pub(super) fn send_layout(
    rec: &RecordingStream,
    word_paths: &[String],
    attention: bool,
    faithfulness: bool,
    world_cells: (usize, usize),
    actions: usize,
) -> Result<(), RecordError> {
    let (bp, settings) = layout(word_paths, attention, faithfulness, world_cells, actions);
    let (carrier, storage) = RecordingStreamBuilder::new(super::APP_ID)
        .memory()
        .map_err(sdk)?;
    bp.send(
        &carrier,
        BlueprintActivation {
            make_active: true,
            make_default: true,
        },
    )
    .map_err(sdk)?;
    // The carrier's own store and any repeated announcement of the blueprint's are dropped:
    // the recording gets one blueprint store.
    let mut announced = false;
    let mut msgs: Vec<LogMsg> = storage
        .take()
        .into_iter()
        .filter(|m| m.store_id().kind() == rerun::StoreKind::Blueprint)
        .filter(|m| {
            !matches!(m, LogMsg::SetStoreInfo(_)) || !std::mem::replace(&mut announced, true)
        })
        .collect();
    let Some(at) = msgs
        .iter()
        .position(|m| matches!(m, LogMsg::BlueprintActivationCommand(_)))
    else {
        return Err(RecordError::Rerun("the blueprint has no activation".into()));
    };
    let Some(LogMsg::BlueprintActivationCommand(activate)) = msgs.get(at).cloned() else {
        return Err(RecordError::Rerun("the blueprint has no activation".into()));
    };
    msgs.truncate(at);
    let (settings_rec, logged) = RecordingStreamBuilder::new(super::APP_ID)
        .blueprint()
        .memory()
        .map_err(sdk)?;
    settings_rec.set_time_sequence("blueprint", 0);
    for plot in &settings.hidden_legends {
        settings_rec
            .log(
                format!("{plot}/PlotLegend"),
                &PlotLegend::new().with_visible(false),
            )
            .map_err(sdk)?;
    }
    for view in &settings.text_logs {
        let column = |kind, visible: bool| TextLogColumn {
            visible: visible.into(),
            kind,
        };
        let columns = TextLogColumns::new()
            .with_timeline_columns([TimelineColumn {
                visible: true.into(),
                timeline: "step".into(),
            }])
            .with_text_log_columns([
                column(TextLogColumnKind::EntityPath, false),
                column(TextLogColumnKind::LogLevel, false),
                column(TextLogColumnKind::Body, true),
            ]);
        settings_rec
            .log(format!("{view}/TextLogColumns"), &columns)
            .map_err(sdk)?;
    }
    for (view, range) in &settings.bounds {
        settings_rec
            .log(
                format!("{view}/VisualBounds2D"),
                &VisualBounds2D::new(*range),
            )
            .map_err(sdk)?;
    }
    msgs.extend(
        logged
            .take()
            .into_iter()
            .filter(|m| matches!(m, LogMsg::ArrowMsg(..)))
            .map(|mut m| {
                m.set_store_id(activate.blueprint_id.clone());
                m
            }),
    );
    rec.send_blueprint(msgs, activate);
    Ok(())
}

/// The viewer's own panels: the blueprint tree and the selection collapsed and the time
/// panel folded to its scrub bar on the `step` timeline, so the views get the window.
fn panels(bp: Blueprint) -> Blueprint {
    bp.with_blueprint_panel(BlueprintPanel::new().with_state(PanelState::Collapsed))
        .with_selection_panel(SelectionPanel::new().with_state(PanelState::Collapsed))
        .with_time_panel(
            TimePanel::new()
                .with_timeline("step")
                .with_state(PanelState::Collapsed),
        )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_are_laid_out_about_square_and_titled_by_their_word() {
        let cols: Vec<u32> = [1, 2, 4, 5, 7, 9, 10].map(map_columns).to_vec();
        assert_eq!(cols, [1, 2, 2, 3, 3, 3, 4]);
        let paths = [
            "attention/words/2_the".to_owned(),
            "attention/words/5_the".to_owned(),
            "attention/words/3_yellow".to_owned(),
        ];
        assert_eq!(word_title(&paths[0], &paths), "2:the");
        assert_eq!(word_title(&paths[2], &paths), "yellow");
        // A folded word is titled as any other; a long title is cut to fit, never elsewhere.
        let long = [
            "attention/function_words/12_matching".to_owned(),
            "attention/words/14_matching".to_owned(),
        ];
        assert_eq!(word_title(&long[0], &long), "12:match…");
        assert_eq!(word_title(&long[0], &long).chars().count(), MAX_MAP_TITLE);
        assert_eq!(word_title(&long[1], &long[1..]), "matching");
    }
}

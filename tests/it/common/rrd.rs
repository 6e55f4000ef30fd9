//! Recordings read back: what a `.rrd` file holds, entity by entity.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use rerun::external::re_log_encoding::DecoderApp;
use rerun::log::{Chunk, LogMsg};

/// What a decoded recording holds: rows per (entity, component), the store version, and the
/// values of every `Scalars` entity in row order.
#[derive(Debug, Default, PartialEq)]
pub struct Decoded {
    pub rows: BTreeMap<(String, String), usize>,
    pub static_entities: BTreeSet<String>,
    pub versions: BTreeSet<String>,
    pub scalars: BTreeMap<String, Vec<Vec<f64>>>,
    /// The `Boxes2D` or `Points2D` labels of every entity, one list per row, in step order.
    pub labels: BTreeMap<String, Vec<Vec<String>>>,
    /// The `Points2D` positions of every entity, one list per row, in step order.
    pub points: BTreeMap<String, Vec<Vec<[f32; 2]>>>,
    /// The `Boxes2D` of every entity as `[min x, min y, max x, max y]`, one list per row.
    pub boxes: BTreeMap<String, Vec<Vec<[f32; 4]>>>,
    /// The visual bounds the blueprint gives a view, by the view's name: `[x0, x1, y0, y1]`.
    pub view_bounds: BTreeMap<String, [f64; 4]>,
    /// The text log columns the blueprint hides in a view (`EntityPath`, `LogLevel`), by the
    /// view's name.
    pub hidden_log_columns: BTreeMap<String, Vec<String>>,
    /// The text of every `TextDocument` entity, one per row, in step order.
    pub texts: BTreeMap<String, Vec<String>>,
    /// The points of every `LineStrips2D` entity's strips, one list per row, in step order.
    pub strips: BTreeMap<String, Vec<Vec<Vec<[f32; 2]>>>>,
    /// The names of the views whose plot legend is hidden.
    pub hidden_legends: BTreeSet<String>,
    /// The names of the blueprint's views.
    pub view_names: BTreeSet<String>,
    /// The names of the views the blueprint hides (`ViewBlueprint:visible` false).
    pub hidden_views: BTreeSet<String>,
    pub blueprints: usize,
}

pub fn decode(path: &Path) -> Decoded {
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut out = Decoded::default();
    let scalar = rerun::Scalars::descriptor_scalars().component;
    let label = rerun::Boxes2D::descriptor_labels().component;
    let point_label = rerun::Points2D::descriptor_labels().component;
    let position = rerun::Points2D::descriptor_positions().component;
    let centers = rerun::Boxes2D::descriptor_centers().component;
    let half_sizes = rerun::Boxes2D::descriptor_half_sizes().component;
    let bounds: rerun::ComponentIdentifier = "VisualBounds2D:range".into();
    let mut view_bounds = Vec::new();
    let log_columns: rerun::ComponentIdentifier = "TextLogColumns:text_log_columns".into();
    let mut hidden_columns = Vec::new();
    let text = rerun::TextDocument::descriptor_text().component;
    let strip = rerun::LineStrips2D::descriptor_strips().component;
    let legend_visible: rerun::ComponentIdentifier = "PlotLegend:visible".into();
    // View paths hold random ids: the legends are recorded by their views' names.
    let (mut view_paths, mut hidden) = (BTreeMap::new(), Vec::new());
    let view_name: rerun::ComponentIdentifier = "ViewBlueprint:display_name".into();
    let view_visible: rerun::ComponentIdentifier = "ViewBlueprint:visible".into();
    let mut hidden_views = Vec::new();
    for msg in DecoderApp::decode_lazy(file) {
        match msg.unwrap() {
            LogMsg::SetStoreInfo(info) => {
                if info.info.store_id.kind() == rerun::StoreKind::Blueprint {
                    out.blueprints += 1;
                }
                if let Some(v) = info.info.store_version {
                    out.versions.insert(v.to_string());
                }
            }
            LogMsg::ArrowMsg(store, arrow) if store.kind() == rerun::StoreKind::Blueprint => {
                let chunk = Chunk::from_arrow_msg(&arrow).unwrap();
                let entity = chunk.entity_path().to_string();
                for names in chunk.iter_component::<rerun::components::Name>(view_name) {
                    for n in names.as_slice() {
                        out.view_names.insert(n.as_str().to_owned());
                        view_paths.insert(entity.clone(), n.as_str().to_owned());
                    }
                }
                for b in chunk
                    .iter_component::<rerun::external::re_sdk_types::blueprint::components::VisualBounds2D>(bounds)
                {
                    if let (Some(r), Some(view)) =
                        (b.as_slice().first(), entity.strip_suffix("/VisualBounds2D"))
                    {
                        let (x, y) = (r.x_range.0, r.y_range.0);
                        view_bounds.push((view.to_owned(), [x[0], x[1], y[0], y[1]]));
                    }
                }
                for c in chunk
                    .iter_component::<rerun::external::re_sdk_types::blueprint::components::TextLogColumn>(log_columns)
                {
                    if let Some(view) = entity.strip_suffix("/TextLogColumns") {
                        let hidden = c
                            .as_slice()
                            .iter()
                            .filter(|c| !c.0.visible.0)
                            .map(|c| format!("{:?}", c.0.kind))
                            .collect();
                        hidden_columns.push((view.to_owned(), hidden));
                    }
                }
                for v in chunk.iter_component::<rerun::components::Visible>(view_visible) {
                    if v.as_slice().iter().any(|v| !v.0.0) {
                        hidden_views.push(entity.clone());
                    }
                }
                for v in chunk.iter_component::<rerun::components::Visible>(legend_visible) {
                    if v.as_slice().iter().any(|v| !v.0.0)
                        && let Some(view) = entity.strip_suffix("/PlotLegend")
                    {
                        hidden.push(view.to_owned());
                    }
                }
            }
            LogMsg::ArrowMsg(store, arrow) if store.kind() == rerun::StoreKind::Recording => {
                let chunk = Chunk::from_arrow_msg(&arrow).unwrap();
                let entity = chunk.entity_path().to_string();
                if chunk.is_static() {
                    out.static_entities.insert(entity.clone());
                }
                for desc in chunk.component_descriptors() {
                    *out.rows
                        .entry((entity.clone(), desc.component.to_string()))
                        .or_default() += chunk.num_rows();
                }
                // Sort rows by the step timeline so values compare in step order.
                let chunk = chunk.sorted_by_timeline_if_unsorted(&"step".into());
                for s in chunk.iter_component::<rerun::components::Scalar>(scalar) {
                    out.scalars
                        .entry(entity.clone())
                        .or_default()
                        .push(s.as_slice().iter().map(|v| v.0.0).collect());
                }
                for strips in chunk.iter_component::<rerun::components::LineStrip2D>(strip) {
                    out.strips.entry(entity.clone()).or_default().push(
                        strips
                            .as_slice()
                            .iter()
                            .map(|s| s.0.iter().map(|p| [p.x(), p.y()]).collect())
                            .collect(),
                    );
                }
                for t in chunk.iter_component::<rerun::components::Text>(text) {
                    out.texts
                        .entry(entity.clone())
                        .or_default()
                        .extend(t.as_slice().iter().map(|t| t.as_str().to_owned()));
                }
                for component in [label, point_label] {
                    for l in chunk.iter_component::<rerun::components::Text>(component) {
                        out.labels
                            .entry(entity.clone())
                            .or_default()
                            .push(l.as_slice().iter().map(|t| t.as_str().to_owned()).collect());
                    }
                }
                for p in chunk.iter_component::<rerun::components::Position2D>(position) {
                    out.points
                        .entry(entity.clone())
                        .or_default()
                        .push(p.as_slice().iter().map(|p| [p.x(), p.y()]).collect());
                }
                let sizes: Vec<Vec<[f32; 2]>> = chunk
                    .iter_component::<rerun::components::HalfSize2D>(half_sizes)
                    .map(|h| h.as_slice().iter().map(|h| [h.0.x(), h.0.y()]).collect())
                    .collect();
                let mids: Vec<Vec<[f32; 2]>> = chunk
                    .iter_component::<rerun::components::Position2D>(centers)
                    .map(|c| c.as_slice().iter().map(|c| [c.x(), c.y()]).collect())
                    .collect();
                for (m, h) in mids.iter().zip(&sizes) {
                    out.boxes.entry(entity.clone()).or_default().push(
                        m.iter()
                            .zip(h)
                            .map(|(m, h)| [m[0] - h[0], m[1] - h[1], m[0] + h[0], m[1] + h[1]])
                            .collect(),
                    );
                }
            }
            _ => {}
        }
    }
    out.hidden_log_columns = hidden_columns
        .into_iter()
        .filter_map(|(p, h)| Some((view_paths.get(&p)?.clone(), h)))
        .collect();
    out.view_bounds = view_bounds
        .into_iter()
        .filter_map(|(p, b)| Some((view_paths.get(&p)?.clone(), b)))
        .collect();
    out.hidden_views = hidden_views
        .iter()
        .filter_map(|p| view_paths.get(p).cloned())
        .collect();
    out.hidden_legends = hidden
        .iter()
        .filter_map(|p| view_paths.get(p).cloned())
        .collect();
    out
}

pub fn rows(d: &Decoded, entity: &str, component: &str) -> usize {
    d.rows
        .get(&(entity.to_owned(), component.to_owned()))
        .copied()
        .unwrap_or(0)
}

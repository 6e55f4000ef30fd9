//! Episodes to MCAP, for Foxglove and Lichtblick without plugins: pictures as
//! `foxglove.RawImage` (JSON encoding, `rgb8`, pixels base64), everything else as JSON messages
//! with a JSON Schema. Topics:
//!
//! | topic | schema | what |
//! |---|---|---|
//! | `/world/image` | foxglove.RawImage | the world, visible cells highlighted |
//! | `/world/attention` | foxglove.RawImage | the world with `M` blended over the view |
//! | `/view/image` | foxglove.RawImage | the agent's view, agent-up |
//! | `/attention/words/<i>_<word>` | foxglove.RawImage | word i's map (viridis), related objects framed |
//! | `/attention/combined` | foxglove.RawImage | `M`, target objects framed |
//! | `/attention/weights` | groundscope.Weights | words, w, H |
//! | `/policy` | groundscope.Policy | episode, step, action, probabilities, value, reward; the expert's (minigrid's bot's) action and plan, and whether the agent left it |
//! | `/metrics/grounding` | groundscope.Grounding | per evaluated map: accuracies and hits |
//! | `/mission` | groundscope.Mission | mission text, seed, episode (first step of each) |
//! | `/instruction` | groundscope.Instruction | the instruction tree: each sequence and clause with its stage (done, waiting, later), each clause's targets and cells, the doors and their states |
//! | `/faithfulness/occlusion` | foxglove.RawImage | occlusion Δ (viridis on [0, 1]), with `replay --faithfulness` |
//! | `/faithfulness` | groundscope.Faithfulness | Δ, ρ(M, Δ), one-step interventions, with `replay --faithfulness` |
//!
//! Frames are frame markers: green = hit on the object's cell (`acc`), yellow = only next to
//! it, red = miss. Message times are synthetic, 100 ms per step from 0, so a file is a pure
//! function of its episodes.

use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::Path;

use base64::Engine as _;
use image::RgbImage;
use serde_json::{Value, json};

use super::scene::{
    StepScene, action_rows, for_each_block, hit_color, trail, with_scene_blocks, world_with_overlay,
};
use super::{PendingFile, RecordError, StopFlag, io_err, stopped};
use crate::env::Action;
use crate::episode::EpisodeTrace;
use crate::metrics::grounding::EvaluatedMap;
use crate::policy::ViewMap;
use crate::render::render_heatmap;

/// Nanoseconds between two recorded steps (10 steps per second of playback).
pub const STEP_NS: u64 = 100_000_000;

/// Pixels per view cell in the heat-map images.
const MAP_CELL_PX: u32 = 8;

const RAW_IMAGE_SCHEMA: &str = r#"{"title":"foxglove.RawImage","description":"A raw image","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}},"frame_id":{"type":"string"},"width":{"type":"integer","minimum":0},"height":{"type":"integer","minimum":0},"encoding":{"type":"string"},"step":{"type":"integer","minimum":0},"data":{"type":"string","contentEncoding":"base64"}}}"#;

const WEIGHTS_SCHEMA: &str = r#"{"title":"groundscope.Weights","type":"object","properties":{"episode":{"type":"integer"},"step":{"type":"integer"},"words":{"type":"array","items":{"type":"string"}},"weights":{"type":"array","items":{"type":"number"}},"entropies":{"type":"array","items":{"type":"number"}},"w":{"type":"object","additionalProperties":{"type":"number"}}}}"#;

const POLICY_SCHEMA: &str = r#"{"title":"groundscope.Policy","type":"object","properties":{"episode":{"type":"integer"},"step":{"type":"integer"},"action":{"type":"integer"},"action_name":{"type":"string"},"probs":{"type":"object","additionalProperties":{"type":"number"}},"value":{"type":"number"},"reward":{"type":"number"},"terminated":{"type":"boolean"},"truncated":{"type":"boolean"},"expert_action":{"type":["integer","null"]},"expert_action_name":{"type":["string","null"]},"expert_plan":{"type":"string"},"left_expert":{"type":"boolean"}}}"#;

const GROUNDING_SCHEMA: &str = r#"{"title":"groundscope.Grounding","type":"object","properties":{"episode":{"type":"integer"},"step":{"type":"integer"},"maps":{"type":"object","additionalProperties":{"type":"object","properties":{"word":{"type":["string","null"]},"acc":{"type":"number"},"acc_ng":{"type":"number"},"acc_bs":{"type":"number"},"acc_cmb":{"type":"number"},"hits":{"type":"array"}}}}}}"#;

const FAITHFULNESS_SCHEMA: &str = r#"{"title":"groundscope.Faithfulness","type":"object","properties":{"episode":{"type":"integer"},"step":{"type":"integer"},"occlusion":{"type":"array","items":{"type":"array","items":{"type":"number"}}},"rank_correlation":{"type":["number","null"]},"interventions":{"type":"object","additionalProperties":{"type":"object","properties":{"tv":{"type":"number"},"flip":{"type":"boolean"}}}}}}"#;

const INSTRUCTION_SCHEMA: &str = r#"{"title":"groundscope.Instruction","type":"object","properties":{"episode":{"type":"integer"},"step":{"type":"integer"},"nodes":{"type":"array","items":{"type":"object","properties":{"depth":{"type":"integer"},"text":{"type":"string"},"seq":{"type":["string","null"]},"clause":{"type":["integer","null"]},"stage":{"type":"string","enum":["done","waiting","later"]},"targets":{"type":"array","items":{"type":"object","properties":{"object":{"type":"string"},"pos":{"type":["array","null"],"items":{"type":"integer"}},"part":{"type":"string","enum":["desc","fixed"]},"pending":{"type":"boolean"}}}}}}},"doors":{"type":"array","items":{"type":"object","properties":{"pos":{"type":"array","items":{"type":"integer"}},"color":{"type":"string"},"state":{"type":"string"}}}}}}"#;

const MISSION_SCHEMA: &str = r#"{"title":"groundscope.Mission","type":"object","properties":{"episode":{"type":"integer"},"seed":{"type":"integer"},"text":{"type":"string"},"checkpoint":{"type":"string"},"level":{"type":"string"}}}"#;

/// What was written.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct McapStats {
    /// Steps written, over all episodes.
    pub steps: usize,
    /// Messages per topic.
    pub messages: BTreeMap<String, u64>,
}

struct Out<W: std::io::Write + std::io::Seek> {
    w: mcap::Writer<W>,
    schemas: BTreeMap<&'static str, u16>,
    channels: BTreeMap<String, u16>,
    stats: McapStats,
}

impl<W: std::io::Write + std::io::Seek> Out<W> {
    fn channel(&mut self, topic: &str, schema: &'static str) -> mcap::McapResult<u16> {
        if let Some(&id) = self.channels.get(topic) {
            return Ok(id);
        }
        let (name, data) = match schema {
            "image" => ("foxglove.RawImage", RAW_IMAGE_SCHEMA),
            "weights" => ("groundscope.Weights", WEIGHTS_SCHEMA),
            "policy" => ("groundscope.Policy", POLICY_SCHEMA),
            "grounding" => ("groundscope.Grounding", GROUNDING_SCHEMA),
            "faithfulness" => ("groundscope.Faithfulness", FAITHFULNESS_SCHEMA),
            "instruction" => ("groundscope.Instruction", INSTRUCTION_SCHEMA),
            _ => ("groundscope.Mission", MISSION_SCHEMA),
        };
        let sid = if let Some(&id) = self.schemas.get(schema) {
            id
        } else {
            let id = self.w.add_schema(name, "jsonschema", data.as_bytes())?;
            self.schemas.insert(schema, id);
            id
        };
        let id = self.w.add_channel(sid, topic, "json", &BTreeMap::new())?;
        self.channels.insert(topic.to_owned(), id);
        Ok(id)
    }

    fn put(&mut self, msg: &Msg) -> mcap::McapResult<()> {
        let channel_id = self.channel(&msg.topic, msg.schema)?;
        let count = self.stats.messages.entry(msg.topic.clone()).or_default();
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: *count as u32,
            log_time: msg.t,
            publish_time: msg.t,
        };
        *count += 1;
        self.w.write_to_known_channel(&header, &msg.bytes)
    }
}

/// One message, serialised: built on the worker thread, written on the writer's.
struct Msg {
    topic: String,
    schema: &'static str,
    t: u64,
    bytes: Vec<u8>,
}

/// The messages of one episode, in write order.
#[derive(Default)]
struct Msgs(Vec<Msg>);

impl Msgs {
    fn json(&mut self, topic: &str, schema: &'static str, t: u64, msg: &Value) {
        // `Value`s built here have string keys and finite numbers: serialising cannot fail.
        self.0.push(Msg {
            topic: topic.to_owned(),
            schema,
            t,
            bytes: serde_json::to_vec(msg).unwrap_or_default(),
        });
    }

    fn image(&mut self, topic: &str, t: u64, img: &RgbImage) {
        let (w, h) = img.dimensions();
        let msg = json!({
            "timestamp": {"sec": t / 1_000_000_000, "nsec": t % 1_000_000_000},
            "frame_id": topic.trim_start_matches('/'),
            "width": w,
            "height": h,
            "encoding": "rgb8",
            "step": w * 3,
            "data": base64::engine::general_purpose::STANDARD.encode(img.as_raw()),
        });
        self.json(topic, "image", t, &msg);
    }
}

/// Frames view cell `cell` of a heat-map image in `color`, two pixels thick.
fn frame_cell(img: &mut RgbImage, cell: (usize, usize), color: [u8; 3]) {
    let (x0, y0) = (cell.0 as u32 * MAP_CELL_PX, cell.1 as u32 * MAP_CELL_PX);
    for d in 0..MAP_CELL_PX {
        for k in 0..2 {
            for (x, y) in [
                (x0 + d, y0 + k),
                (x0 + d, y0 + MAP_CELL_PX - 1 - k),
                (x0 + k, y0 + d),
                (x0 + MAP_CELL_PX - 1 - k, y0 + d),
            ] {
                if x < img.width() && y < img.height() {
                    img.put_pixel(x, y, image::Rgb(color));
                }
            }
        }
    }
}

/// A map as a viridis picture on `[0, hi]` with the related objects framed.
fn map_picture(map: &ViewMap, hi: f32, g: Option<&EvaluatedMap>) -> RgbImage {
    let mut img = render_heatmap(map, MAP_CELL_PX, 0.0, hi);
    for h in g.map(|g| g.hits.as_slice()).unwrap_or_default() {
        frame_cell(&mut img, h.cell, hit_color(h));
    }
    img
}

fn grounding_json(g: &EvaluatedMap, words: &[String]) -> Value {
    let a = &g.accuracies;
    json!({
        "word": g.word.and_then(|i| words.get(i)),
        "acc": a.acc, "acc_ng": a.acc_ng, "acc_bs": a.acc_bs, "acc_cmb": a.acc_cmb,
        "hits": g.hits,
    })
}

fn step_messages(out: &mut Msgs, e: usize, ep: &EpisodeTrace, k: usize, scene: &StepScene, t: u64) {
    let Some(step) = ep.steps.get(k) else {
        return;
    };
    out.image("/world/image", t, &scene.world);
    out.image("/view/image", t, &scene.view);
    // The actions the policy scores only: three keys for an agent of 3 actions.
    let probs: serde_json::Map<String, Value> = action_rows(ep.action_probs(step))
        .into_iter()
        .map(|(n, p)| (n.to_owned(), json!(p)))
        .collect();
    out.json(
        "/policy",
        "policy",
        t,
        &json!({
            "episode": e, "step": step.t, "action": step.action as u8,
            "action_name": step.action.name(), "probs": probs, "value": step.value,
            "reward": step.reward, "terminated": step.terminated, "truncated": step.truncated,
            "expert_action": step.expert_action.map(|a| a as u8),
            "expert_action_name": step.expert_action.map(Action::name),
            "expert_plan": step.expert_plan,
            "left_expert": step.expert_action.is_some_and(|a| a != step.action),
        }),
    );
    let tree = &scene.tree;
    out.json(
        "/instruction",
        "instruction",
        t,
        &json!({"episode": e, "step": step.t, "nodes": tree.nodes, "doors": tree.doors}),
    );
    if let Some(f) = &step.faithfulness {
        out.image(
            "/faithfulness/occlusion",
            t,
            &map_picture(&f.occlusion, 1.0, None),
        );
        out.json(
            "/faithfulness",
            "faithfulness",
            t,
            &json!({"episode": e, "step": step.t, "occlusion": f.occlusion,
                    "rank_correlation": f.rank_correlation, "interventions": f.interventions}),
        );
    }
    let Some(att) = &step.attention else {
        return;
    };
    let hi = scene.scale_max;
    let words: Vec<String> = att.words.iter().map(|w| w.word.clone()).collect();
    for (i, wa) in att.words.iter().enumerate() {
        let pic = map_picture(&wa.map, hi, scene.hits_of(Some(i)));
        out.image(&format!("/attention/words/{i}_{}", wa.word), t, &pic);
    }
    out.image(
        "/attention/combined",
        t,
        &map_picture(&att.combined, hi, scene.hits_of(None)),
    );
    out.image(
        "/world/attention",
        t,
        &world_with_overlay(step, scene, &trail(ep, k)),
    );
    let w: serde_json::Map<String, Value> = att
        .words
        .iter()
        .enumerate()
        .map(|(i, a)| (format!("{i}_{}", a.word), json!(a.weight)))
        .collect();
    out.json(
        "/attention/weights",
        "weights",
        t,
        &json!({
            "episode": e, "step": step.t, "words": words,
            "weights": att.words.iter().map(|a| a.weight).collect::<Vec<_>>(),
            "entropies": att.words.iter().map(|a| a.entropy).collect::<Vec<_>>(),
            "w": w,
        }),
    );
    let maps: serde_json::Map<String, Value> = scene
        .grounding
        .iter()
        .map(|g| (g.kind.name().to_owned(), grounding_json(g, &words)))
        .collect();
    out.json(
        "/metrics/grounding",
        "grounding",
        t,
        &json!({"episode": e, "step": step.t, "maps": maps}),
    );
}

/// The cause of an MCAP error: for an I/O error the OS's message ("No space left on
/// device"), not mcap's generic one.
fn cause(e: &mcap::McapError) -> String {
    std::error::Error::source(e).map_or_else(|| e.to_string(), ToString::to_string)
}

/// The messages of steps `first..` of episode number `e` (`scenes` theirs), whose first
/// step is recording step `global`.
fn block_messages(
    e: usize,
    ep: &EpisodeTrace,
    first: usize,
    scenes: &[StepScene],
    global: u64,
) -> Msgs {
    let mut msgs = Msgs::default();
    for ((i, step), scene) in ep.steps.iter().enumerate().skip(first).zip(scenes) {
        let t = (global + i as u64) * STEP_NS;
        if step.t == 0 {
            msgs.json(
                "/mission",
                "mission",
                t,
                &json!({"episode": e, "seed": ep.seed, "text": ep.mission,
                        "checkpoint": ep.checkpoint, "level": ep.level.to_string()}),
            );
        }
        step_messages(&mut msgs, e, ep, i, scene, t);
    }
    msgs
}

/// Writes `episodes` to `path` as MCAP (zstd chunks, summary and indexes), atomically: the
/// file appears only when complete. `stop` aborts between blocks of steps and leaves no file.
/// Each block's scenes are computed on a second thread while this one builds, compresses and
/// writes the one before ([`McapRecorder::push_block`]).
pub fn write_mcap(
    episodes: &[EpisodeTrace],
    path: &Path,
    alpha: f64,
    stop: Option<&StopFlag>,
) -> Result<McapStats, RecordError> {
    if episodes.is_empty() {
        return Err(RecordError::Empty);
    }
    let mut recorder = McapRecorder::create(path)?;
    with_scene_blocks(episodes, alpha, |ep, first, scenes| {
        recorder.push_block(ep, first, scenes, stop)
    })?;
    recorder.finish()
}

/// An MCAP file being written episode by episode and block by block of steps
/// ([`SCENE_BLOCK`](super::scene::SCENE_BLOCK)): no more than one episode's trace and one
/// block's pictures and messages are held ([`write_mcap`] for episodes already in memory).
pub struct McapRecorder {
    pending: PendingFile,
    out: Out<BufWriter<std::fs::File>>,
    /// The destination is a device or FIFO: MCAP needs a seekable file, so the recording
    /// goes to this anonymous spool file and is copied into the destination at the end.
    spooled: bool,
    pushed: usize,
    steps: u64,
}

impl McapRecorder {
    /// Opens the destination (a temporary file beside it) and writes the MCAP header.
    pub fn create(path: &Path) -> Result<Self, RecordError> {
        let pending = PendingFile::new(path)?;
        let spooled = pending.in_place();
        let file = if spooled {
            tempfile::tempfile()
        } else {
            std::fs::File::create(pending.path())
        }
        .map_err(|e| io_err(path, &e))?;
        let w = mcap::WriteOptions::new()
            .profile("")
            .library(format!("groundscope {}", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::new(file))
            .map_err(|e| io_err(path, &cause(&e)))?;
        Ok(Self {
            pending,
            out: Out {
                w,
                schemas: BTreeMap::new(),
                channels: BTreeMap::new(),
                stats: McapStats::default(),
            },
            spooled,
            pushed: 0,
            steps: 0,
        })
    }

    /// Writes one episode, its scenes computed block by block ([`Self::push_block`]).
    pub fn push(
        &mut self,
        ep: &EpisodeTrace,
        alpha: f64,
        stop: Option<&StopFlag>,
    ) -> Result<(), RecordError> {
        for_each_block(ep, alpha, |first, scenes| {
            self.push_block(ep, first, scenes, stop)
        })
    }

    /// Writes steps `first..` of `ep` with their scenes ([`scene_block`]), blocks of an
    /// episode in order; fails with [`RecordError::Interrupted`] once `stop` is raised.
    pub fn push_block(
        &mut self,
        ep: &EpisodeTrace,
        first: usize,
        scenes: &[StepScene],
        stop: Option<&StopFlag>,
    ) -> Result<(), RecordError> {
        if stopped(stop) {
            return Err(RecordError::Interrupted);
        }
        let msgs = block_messages(self.pushed, ep, first, scenes, self.steps);
        let dest = self.pending.dest();
        for m in &msgs.0 {
            self.out.put(m).map_err(|e| io_err(dest, &cause(&e)))?;
        }
        if first + scenes.len() >= ep.steps.len() {
            self.pushed += 1;
            self.steps += ep.steps.len() as u64;
        }
        Ok(())
    }

    /// Writes the summary and indexes and puts the file in place (fsync + rename, or a copy
    /// into a device or FIFO).
    pub fn finish(self) -> Result<McapStats, RecordError> {
        let (stats, file) = self.finish_pending()?;
        file.commit()?;
        Ok(stats)
    }

    /// [`Self::finish`] but for the rename: the finished file is handed back under its
    /// temporary name (a device or FIFO has had its copy), for a caller that puts several
    /// outputs in place together once every one is complete ([`PendingFile::commit`];
    /// dropped, it removes itself).
    pub fn finish_pending(mut self) -> Result<(McapStats, PendingFile), RecordError> {
        let dest = self.pending.dest().to_path_buf();
        let err = |e: &dyn std::fmt::Display| io_err(&dest, e);
        self.out.w.finish().map_err(|e| err(&cause(&e)))?;
        let mut file = self
            .out
            .w
            .into_inner()
            .into_inner()
            .map_err(|e| err(&e.error()))?;
        if self.spooled {
            use std::io::Seek as _;
            file.rewind().map_err(|e| err(&e))?;
            let mut target = std::fs::OpenOptions::new()
                .write(true)
                .open(self.pending.path())
                .map_err(|e| err(&e))?;
            std::io::copy(&mut file, &mut target).map_err(|e| err(&e))?;
        }
        let stats = McapStats {
            steps: self.steps as usize,
            ..self.out.stats
        };
        Ok((stats, self.pending))
    }
}

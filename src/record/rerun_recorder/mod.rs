//! Episodes to Rerun 0.36.3: an `.rrd` file, a spawned viewer and/or a running one, all from
//! one recording stream. Entity paths (DESIGN.md §5):
//!
//! | path | archetype | what |
//! |---|---|---|
//! | `world/grid` | Image | the world, the agent's visible cells highlighted |
//! | `world/attention` | Image (RGBA, one pixel per cell, scaled by a static transform) | `M` on the view's empty floor |
//! | `world/attention/rings` | Boxes2D | `M`'s colour round occupied cells (their contents keep their colours) |
//! | `world/marks/targets`, `world/marks/trail` | Boxes2D, LineStrips2D | `M`'s targets (the clauses waited on); the agent's path |
//! | `world/legend` | TextDocument (static) | what the world's marks mean |
//! | `world/clauses` | Boxes2D | every clause's targets, framed by stage (waited on, done, later) |
//! | `world/clauses/numbers` | Points2D | their clause numbers, in a free cell beside each |
//! | `mission/tree` | TextDocument | the instruction tree: stages, targets and cells, doors and their states |
//! | `view/image` | Image | the agent's view, agent-up |
//! | `attention/words/<i>_<word>` | DepthImage (7×7, viridis; grey when w ≈ 0) | word i's map |
//! | `attention/words/<i>_<word>/label` | Boxes2D | weight w and entropy H (the word is the view's title) |
//! | `attention/words/<i>_<word>/grounding` | Points2D | hit / miss at each related object |
//! | `attention/function_words/<i>_<word>` (+ `/label`, `/grounding`) | as a word's | the map of a word the debugger folds ([`crate::record::fold`]): kept, its view hidden |
//! | `attention/combined` (+ `/label`, `/grounding`) | DepthImage, Boxes2D, Points2D | `M` |
//! | `attention/landmarks/*` | Boxes2D, LineStrips2D, Points2D | walls, objects, unseen cells, agent |
//! | `attention/colorbar` | DepthImage | the maps' shared scale |
//! | `attention/weights`, `attention/entropy` | Points2D (each row's label, above its bar) + Boxes2D (tracks) + LineStrips2D (solid bars) | w and H in word order |
//! | `attention/legend` | TextDocument | word, w and H as a table |
//! | `policy/probs` | Points2D (labels) + Boxes2D (tracks) + LineStrips2D (solid bars) | action probabilities |
//! | `policy/value`, `policy/reward` | Scalars | critic value, reward |
//! | `policy/status` | TextDocument | mission, step, action, probabilities |
//! | `policy/action` | TextLog | one line per step |
//! | `metrics/<object\|color\|combined>` | Scalars | acc, acc_ng, acc_bs, acc_cmb of the step |
//! | `metrics/grounding` | TextDocument | the same as a table, and why a kind is not scored |
//! | `faithfulness/occlusion` | DepthImage (7×7, viridis on [0, 1]) | occlusion Δ (`replay --faithfulness`) |
//! | `faithfulness/summary` | TextDocument | ρ, peaks' agreement, interventions and flips |
//! | `faithfulness/rank_correlation`, `faithfulness/interventions/<name>` | Scalars | ρ(M, Δ); TV distance of each one-step intervention |
//! | `mission`, `meta` | TextDocument | the mission; versions, checkpoint, level (static) |
//!
//! Timelines: `step` counts steps across the whole recording (so one scrub bar covers every
//! episode) and `episode` numbers the episodes.

mod entities;
mod layout;
mod marks;

use std::collections::BTreeSet;
use std::net::{TcpStream, ToSocketAddrs};
use std::path::PathBuf;
use std::time::Duration;

use rerun::external::re_uri;
use rerun::sink::{GrpcSink, LogSink};
use rerun::{RecordingStream, RecordingStreamBuilder};

use super::fold::folded_words;
use super::rrd_file::RrdWriter;
use super::scene::StepScene;
use super::{PendingFile, RERUN_SDK_VERSION, RecordError, StopFlag, stopped};
use crate::env::World;
use crate::env::roles::roles_of;
use crate::episode::EpisodeTrace;
use entities::{log_static, log_step};

/// Where a recording goes; any combination.
#[derive(Clone, Debug, Default)]
pub struct RerunTargets {
    /// Write an `.rrd` file here.
    pub save: Option<PathBuf>,
    /// Start a viewer (`rerun` on PATH) and stream to it.
    pub spawn: bool,
    /// Stream to a running viewer, e.g. `rerun+http://127.0.0.1:9876/proxy`.
    pub connect: Option<String>,
}

/// What was recorded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecordStats {
    /// Episodes recorded.
    pub episodes: usize,
    /// Steps recorded, over all episodes.
    pub steps: usize,
}

fn sdk(e: impl std::fmt::Display) -> RecordError {
    RecordError::Rerun(e.to_string())
}

/// `host:port` of a `rerun+http://host:port/proxy` URL, checked by the SDK's own parser.
fn proxy_uri(url: &str) -> Result<(re_uri::ProxyUri, String), RecordError> {
    let Ok(re_uri::RedapUri::Proxy(uri)) = url.parse::<re_uri::RedapUri>() else {
        return Err(RecordError::Rerun(format!(
            "--connect {url:?} is not a viewer URL like rerun+http://127.0.0.1:9876/proxy"
        )));
    };
    let rest = url.split_once("://").map_or(url, |(_, r)| r);
    let authority = rest.split('/').next().unwrap_or(rest).to_owned();
    Ok((uri, authority))
}

/// Fails unless something accepts TCP connections at `authority` within two seconds: the
/// gRPC sink itself would silently drop the data.
fn check_listening(url: &str, authority: &str) -> Result<(), RecordError> {
    let no_viewer = |reason: String| RecordError::NoViewer {
        url: url.to_owned(),
        reason,
    };
    let addrs: Vec<_> = authority
        .to_socket_addrs()
        .map_err(|e| no_viewer(e.to_string()))?
        .collect();
    let mut last = String::from("address did not resolve");
    for addr in addrs {
        match TcpStream::connect_timeout(&addr, Duration::from_secs(2)) {
            Ok(_) => return Ok(()),
            Err(e) => last = e.to_string(),
        }
    }
    Err(no_viewer(last))
}

/// Steps logged between two waits for the destinations to take them: the stream's queue
/// holds this many steps' pictures at most (a 22×22 world's image is 1.5 MB raw); fewer
/// would cut the recording into more, smaller chunks (16 steps: 25 KB a step on BossLevel
/// against 14 KB unpaced; 64: see docs/performance.md).
const FLUSH_STEPS: usize = 64;

/// The application id of every recording (the viewer keys blueprints by it).
const APP_ID: &str = "groundscope";

/// Where the maps of the words shown are logged.
pub const WORD_MAPS: &str = "attention/words";

/// Where the maps of the words the debugger folds are logged ([`crate::record::fold`]): kept
/// in the recording, under a path of their own whose views the default layout hides.
pub const FUNCTION_WORD_MAPS: &str = "attention/function_words";

/// The entity path of word `i` of a mission: under [`WORD_MAPS`], or [`FUNCTION_WORD_MAPS`]
/// where its map is `folded`.
pub fn word_path(i: usize, word: &str, folded: bool) -> String {
    let under = if folded {
        FUNCTION_WORD_MAPS
    } else {
        WORD_MAPS
    };
    format!("{under}/{i}_{word}")
}

/// A mission's `words` (its attention trace's) as a recording lays them out: each with whether
/// its map folds, by the debugger's rule ([`folded_words`]) on `world`'s mission.
pub fn mission_words<'a>(words: Vec<&'a str>, world: &World) -> Vec<(&'a str, bool)> {
    let folded = folded_words(&roles_of(world), words.len(), None);
    words.into_iter().zip(folded).collect()
}

/// The word-map entity paths of a recording of these missions (each its words with whether
/// they fold, [`mission_words`]), in mission order — by the word's position, then the word —
/// whatever the mission's length (as strings, "10_…" would sort before "2_…"); the blueprint
/// shows one view per path, a folded word's hidden.
pub fn word_paths<'a>(missions: impl IntoIterator<Item = Vec<(&'a str, bool)>>) -> Vec<String> {
    missions
        .into_iter()
        .flat_map(|words| {
            words
                .into_iter()
                .enumerate()
                .map(|(i, (w, folded))| (i, w.to_owned(), folded))
                .collect::<Vec<_>>()
        })
        .collect::<BTreeSet<_>>()
        .into_iter()
        .map(|(i, w, folded)| word_path(i, &w, folded))
        .collect()
}

/// Records `episodes` to the targets and finalises them: the `.rrd` gets its footer and is
/// renamed into place only when everything was written. `stop` aborts between steps. Step
/// pictures are computed one episode ahead on a second thread.
pub fn record_rerun(
    episodes: &[EpisodeTrace],
    targets: &RerunTargets,
    alpha: f64,
    stop: Option<&StopFlag>,
) -> Result<RecordStats, RecordError> {
    let first = episodes.first().ok_or(RecordError::Empty)?;
    // The mission the trace's words are of: its last world's (a probe may have changed it).
    let paths = word_paths(
        episodes
            .iter()
            .map(|e| mission_words(e.words(), &e.final_world)),
    );
    let mut recorder = RerunRecorder::start(targets, first, episodes.len(), &paths)?;
    super::scene::with_scene_blocks(episodes, alpha, |ep, first, scenes| {
        recorder.push_block(ep, first, scenes, stop)
    })?;
    recorder.finish()
}

/// A recording being streamed episode by episode and block by block of steps
/// ([`SCENE_BLOCK`](super::scene::SCENE_BLOCK)), each block flushed to its destinations
/// before the next: no more than one episode's trace and one block's pictures are held
/// ([`record_rerun`] for episodes already in memory).
pub struct RerunRecorder {
    rec: RecordingStream,
    file: Option<(PendingFile, RrdWriter)>,
    connect: Option<String>,
    episodes: usize,
    pushed: usize,
    global: i64,
    /// The last scene of the block before, while an episode is being pushed (its marks are
    /// logged as changes from it).
    prev: Option<StepScene>,
}

impl RerunRecorder {
    /// Checks every destination, opens the stream and logs the static parts. `first` is the
    /// first episode (its checkpoint, level and seed go into the recording's metadata),
    /// `episodes` how many will be pushed, `word_paths` the word maps of all of them
    /// ([`word_paths`]).
    pub fn start(
        targets: &RerunTargets,
        first: &EpisodeTrace,
        episodes: usize,
        word_paths: &[String],
    ) -> Result<Self, RecordError> {
        let pending = targets.save.as_deref().map(PendingFile::new).transpose()?;
        let connect = targets
            .connect
            .as_deref()
            .map(|url| {
                let (uri, authority) = proxy_uri(url)?;
                check_listening(url, &authority)?;
                Ok::<_, RecordError>(uri)
            })
            .transpose()?;
        let mut sinks: Vec<Box<dyn LogSink>> = Vec::new();
        let mut file = None;
        if let Some(p) = pending {
            let (sink, writer) =
                super::rrd_file::create(p.path()).map_err(|e| super::io_err(p.dest(), &e))?;
            sinks.push(Box::new(sink));
            file = Some((p, writer));
        }
        if let Some(uri) = connect {
            sinks.push(Box::new(GrpcSink::new(uri)));
        }
        if targets.spawn {
            sinks.push(Box::new(GrpcSink::new(spawn_viewer()?)));
        }
        if sinks.is_empty() {
            return Err(RecordError::Rerun(
                "no destination: give --save FILE.rrd, --spawn or --connect URL".into(),
            ));
        }
        let name = if episodes == 1 {
            format!("{} seed {}", first.mission, first.seed)
        } else {
            format!("{episodes} episodes from seed {}", first.seed)
        };
        let attention = first.variant.name() == "attention";
        let rec = RecordingStreamBuilder::new(APP_ID)
            .recording_name(name)
            .enabled(true)
            .set_sinks(sinks)
            .map_err(sdk)?;
        layout::send_layout(
            &rec,
            word_paths,
            attention,
            first.steps.iter().any(|s| s.faithfulness.is_some()),
            (
                first.final_world.grid.width(),
                first.final_world.grid.height(),
            ),
            first.n_actions,
        )?;
        // Recordings of the same episodes then differ only in row ids.
        rec.set_log_time_enabled(false);
        log_static(&rec, first, episodes)?;
        Ok(Self {
            rec,
            file,
            connect: targets.connect.clone(),
            episodes,
            pushed: 0,
            global: 0,
            prev: None,
        })
    }

    /// Logs one episode, its scenes computed block by block ([`Self::push_block`]).
    pub fn push(
        &mut self,
        ep: &EpisodeTrace,
        alpha: f64,
        stop: Option<&StopFlag>,
    ) -> Result<(), RecordError> {
        super::scene::for_each_block(ep, alpha, |first, scenes| {
            self.push_block(ep, first, scenes, stop)
        })
    }

    /// Logs steps `first..` of `ep` with their scenes
    /// ([`scene_block`](super::scene::scene_block)), blocks of an episode in order, and waits
    /// until the destinations took them, so that the stream's queue holds one block at most.
    /// Fails at once if the file has already failed (a full disk), or with
    /// [`RecordError::Interrupted`] once `stop`.
    pub fn push_block(
        &mut self,
        ep: &EpisodeTrace,
        first: usize,
        scenes: &[StepScene],
        stop: Option<&StopFlag>,
    ) -> Result<(), RecordError> {
        if let Some((p, w)) = &self.file
            && let Some(e) = w.failed()
        {
            return Err(super::io_err(p.dest(), &e));
        }
        let e = self.pushed;
        let rec = &self.rec;
        if first == 0 {
            self.prev = None;
        }
        for (j, scene) in scenes.iter().enumerate() {
            let k = first + j;
            let Some(step) = ep.steps.get(k) else {
                break;
            };
            if stopped(stop) {
                return Err(RecordError::Interrupted);
            }
            rec.set_time_sequence("step", self.global);
            if self.episodes > 1 {
                rec.set_time_sequence("episode", e as i64);
            }
            if step.t == 0 && self.episodes > 1 {
                rec.log("mission", &rerun::TextDocument::new(ep.mission.as_str()))
                    .map_err(sdk)?;
            }
            let prev = match j.checked_sub(1) {
                Some(i) => scenes.get(i),
                None => self.prev.as_ref(),
            };
            log_step(rec, ep, e, k, scene, prev)?;
            self.global += 1;
        }
        let end = first + scenes.len();
        if end.is_multiple_of(FLUSH_STEPS) || end >= ep.steps.len() {
            // A failed flush (a viewer gone) is reported by `finish`; here it only paces.
            let _ = rec.flush_blocking();
        }
        self.prev = scenes.last().cloned();
        if end >= ep.steps.len() {
            self.pushed += 1;
            self.prev = None;
        }
        Ok(())
    }

    /// Flushes every destination and finishes the file (footer, fsync, rename into place).
    pub fn finish(self) -> Result<RecordStats, RecordError> {
        let (stats, file) = self.finish_pending()?;
        if let Some(p) = file {
            p.commit()?;
        }
        Ok(stats)
    }

    /// [`Self::finish`] but for the rename: the finished `.rrd`, if there is one, is handed
    /// back under its temporary name, for a caller that puts several outputs in place together
    /// once every one is complete ([`PendingFile::commit`]; dropped, it removes itself).
    pub fn finish_pending(self) -> Result<(RecordStats, Option<PendingFile>), RecordError> {
        let flushed = self.rec.flush_blocking();
        // The last handle: dropping it closes the streams.
        drop(self.rec);
        let pending = match self.file {
            Some((p, writer)) => {
                writer.finish().map_err(|e| super::io_err(p.dest(), &e))?;
                Some(p)
            }
            None => None,
        };
        flushed.map_err(|e| match &self.connect {
            // The file is fine, so a failed flush is the viewer's.
            Some(url) => RecordError::NoViewer {
                url: url.clone(),
                reason: format!(
                    "it did not take the stream ({})",
                    first_line(&e.to_string())
                ),
            },
            None => sdk(e),
        })?;
        let stats = RecordStats {
            episodes: self.pushed,
            steps: self.global as usize,
        };
        Ok((stats, pending))
    }
}

fn first_line(text: &str) -> &str {
    text.lines().next().unwrap_or(text).trim()
}

/// Starts `rerun` from PATH and returns the address it listens on.
fn spawn_viewer() -> Result<re_uri::ProxyUri, RecordError> {
    let on_path = std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|d| d.join("rerun").is_file()));
    if !on_path {
        return Err(RecordError::Rerun(format!(
            "--spawn: no `rerun` viewer on PATH (install it with `pip install rerun-sdk=={RERUN_SDK_VERSION}`, or write a file with --save)"
        )));
    }
    let info = rerun::spawn(&rerun::SpawnOptions::default())
        .map_err(|e| RecordError::Rerun(format!("--spawn: {}", first_line(&e.to_string()))))?;
    Ok(proxy_uri(&format!("rerun+http://127.0.0.1:{}/proxy", info.port))?.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn word_maps_keep_mission_order_past_ten_words() {
        let long: Vec<&str> = "put the red ball next to the blue key and then go to a box"
            .split(' ')
            .collect();
        let shown = |words: &[&'static str]| -> Vec<(&'static str, bool)> {
            words.iter().map(|w| (*w, false)).collect()
        };
        let paths = word_paths([shown(&long)]);
        let want: Vec<String> = long
            .iter()
            .enumerate()
            .map(|(i, w)| word_path(i, w, false))
            .collect();
        assert_eq!(paths, want);
        // Two missions: each position once per word, positions in order.
        let two = word_paths([
            shown(&["go", "to", "the", "key"]),
            shown(&["go", "to", "a", "ball"]),
        ]);
        assert_eq!(
            two,
            [
                "attention/words/0_go",
                "attention/words/1_to",
                "attention/words/2_a",
                "attention/words/2_the",
                "attention/words/3_ball",
                "attention/words/3_key"
            ]
        );
    }

    /// A folded word's map goes under a path of its own, in the same order as the others.
    #[test]
    fn a_folded_words_map_is_kept_under_its_own_path() {
        let world = crate::env::LevelConfig::babyai(
            crate::env::LevelId::parse("BabyAI-BossLevel-v0").unwrap(),
            false,
        )
        .generate(3)
        .unwrap();
        let tokens = crate::env::vocab::tokenize(&world.mission).unwrap();
        let words = crate::env::vocab::words(&tokens);
        assert!(
            words.len() > crate::record::fold::FOLD_ABOVE_WORDS,
            "{}",
            world.mission
        );
        let laid = mission_words(words.clone(), &world);
        let paths = word_paths([laid.clone()]);
        assert_eq!(paths.len(), words.len());
        for (i, ((w, folded), path)) in laid.iter().zip(&paths).enumerate() {
            let under = if *folded {
                FUNCTION_WORD_MAPS
            } else {
                WORD_MAPS
            };
            assert_eq!(path, &format!("{under}/{i}_{w}"));
        }
        // Every description has an article: a function word.
        assert!(
            laid.iter().any(|(w, f)| matches!(*w, "the" | "a") && *f),
            "{laid:?}"
        );
        assert!(laid.iter().any(|(_, f)| !f), "{laid:?}");
    }
}

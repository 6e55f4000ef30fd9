//! BabyAI's action clauses ("go to …", "pick up …", "open …", "put … next to …"), object
//! descriptions and their surface text (`verifier.py`). Sequences of clauses: [`super::instr`].

use std::fmt;

use serde::{Deserialize, Serialize};

use super::error::EnvError;
use super::grid::{DIR_TO_VEC, Grid, Pos, Rooms};
use super::object::{Color, ObjectKind, WorldObj};

/// The kind of task an action instruction asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TaskKind {
    /// `GoToInstr`: face a matching object.
    GoTo,
    /// `PickupInstr`: pick up a matching object.
    Pickup,
    /// `OpenInstr`: open a matching door.
    Open,
    /// `PutNextInstr`: put a matching object next to another.
    PutNext,
}

impl TaskKind {
    /// The class name the Python dumps use (`"GoToInstr"`, `"PickupInstr"`, ...).
    pub fn instr_class(self) -> &'static str {
        match self {
            Self::GoTo => "GoToInstr",
            Self::Pickup => "PickupInstr",
            Self::Open => "OpenInstr",
            Self::PutNext => "PutNextInstr",
        }
    }

    /// The kind with class name `name`, if any.
    pub fn from_class(name: &str) -> Option<Self> {
        [Self::GoTo, Self::Pickup, Self::Open, Self::PutNext]
            .into_iter()
            .find(|k| k.instr_class() == name)
    }

    /// The verb phrase that starts the clause.
    pub fn verb(self) -> &'static str {
        match self {
            Self::GoTo => "go to",
            Self::Pickup => "pick up",
            Self::Open => "open",
            Self::PutNext => "put",
        }
    }
}

impl fmt::Display for TaskKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::GoTo => "goto",
            Self::Pickup => "pickup",
            Self::Open => "open",
            Self::PutNext => "putnext",
        })
    }
}

/// BabyAI's location qualifiers, relative to the agent's pose at reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Loc {
    /// "on your left".
    Left,
    /// "on your right".
    Right,
    /// "in front of you".
    Front,
    /// "behind you".
    Behind,
}

impl Loc {
    /// The name used in dumps.
    pub fn name(self) -> &'static str {
        match self {
            Self::Left => "left",
            Self::Right => "right",
            Self::Front => "front",
            Self::Behind => "behind",
        }
    }

    /// The location called `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::Left, Self::Right, Self::Front, Self::Behind]
            .into_iter()
            .find(|l| l.name() == name)
    }
}

/// `ObjDesc`: an optional type, colour and location.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ObjDesc {
    /// Object type; `None` reads "object".
    pub kind: Option<ObjectKind>,
    /// Colour; `None` omits it.
    pub color: Option<Color>,
    /// Location relative to the agent's start pose.
    pub loc: Option<Loc>,
}

impl ObjDesc {
    /// Whether `obj` has the described type and colour (location not considered).
    pub fn matches(&self, obj: &WorldObj) -> bool {
        self.kind.is_none_or(|k| k == obj.kind) && self.color.is_none_or(|c| c == obj.color)
    }

    /// `find_matching_objs(use_location=True)`: the ids and positions of all matching objects
    /// (walls included, as BabyAI scans every cell), in MiniGrid's x-major scan order, for an
    /// agent at `agent_pos` facing `agent_dir`. A location word keeps only the objects of the
    /// agent's room on that side of it.
    pub fn find_matching(
        &self,
        grid: &Grid,
        rooms: Rooms,
        agent_pos: Pos,
        agent_dir: u8,
    ) -> (Vec<u32>, Vec<Pos>) {
        self.matching_among(grid.objects(), rooms, agent_pos, agent_dir)
    }

    /// [`Self::find_matching`] over `objects`, the grid's [`Grid::objects_but_walls`]: the
    /// same answer, since only a description without a type (or of walls) can match a wall,
    /// and for those the whole grid is scanned.
    pub fn find_matching_among(
        &self,
        objects: &[(Pos, WorldObj)],
        grid: &Grid,
        rooms: Rooms,
        agent_pos: Pos,
        agent_dir: u8,
    ) -> (Vec<u32>, Vec<Pos>) {
        if self.may_match_walls() {
            return self.find_matching(grid, rooms, agent_pos, agent_dir);
        }
        self.matching_among(objects.iter().copied(), rooms, agent_pos, agent_dir)
    }

    /// Whether [`Self::find_matching_among`] finds an object at a position `keep` accepts,
    /// without gathering them: level generation draws descriptions until one matches, a dozen
    /// times per level on the mixed levels.
    pub fn any_matching_among(
        &self,
        objects: &[(Pos, WorldObj)],
        grid: &Grid,
        rooms: Rooms,
        agent_pos: Pos,
        agent_dir: u8,
        mut keep: impl FnMut(Pos) -> bool,
    ) -> bool {
        if self.may_match_walls() {
            return self
                .matched(grid.objects(), rooms, agent_pos, agent_dir)
                .any(|(pos, _)| keep(pos));
        }
        self.matched(objects.iter().copied(), rooms, agent_pos, agent_dir)
            .any(|(pos, _)| keep(pos))
    }

    /// Only a description without a type (or of walls) can match a wall, which
    /// [`Grid::objects_but_walls`] leaves out.
    fn may_match_walls(self) -> bool {
        self.kind.is_none_or(|k| k == ObjectKind::Wall)
    }

    fn matching_among(
        self,
        objects: impl Iterator<Item = (Pos, WorldObj)>,
        rooms: Rooms,
        agent_pos: Pos,
        agent_dir: u8,
    ) -> (Vec<u32>, Vec<Pos>) {
        self.matched(objects, rooms, agent_pos, agent_dir)
            .map(|(pos, obj)| (obj.id, pos))
            .unzip()
    }

    /// Whether `pos` lies on the side of the agent at `agent_pos`, facing `agent_dir`, that
    /// `loc` names: minigrid's half-planes of `find_matching_objs` (the room aside), the one
    /// definition the verifier and the location words' region score use.
    pub fn on_side(loc: Loc, pos: Pos, agent_pos: Pos, agent_dir: u8) -> bool {
        let d1 = DIR_TO_VEC[usize::from(agent_dir & 3)];
        let d2 = (-d1.1, d1.0);
        let v = (pos.0 - agent_pos.0, pos.1 - agent_pos.1);
        let dot = |d: Pos| v.0 * d.0 + v.1 * d.1;
        match loc {
            Loc::Left => dot(d2) < 0,
            Loc::Right => dot(d2) > 0,
            Loc::Front => dot(d1) > 0,
            Loc::Behind => dot(d1) < 0,
        }
    }

    /// The objects among `objects` this description picks out: type and colour, and with a
    /// location word only those of the agent's room on that side of it.
    fn matched(
        self,
        objects: impl Iterator<Item = (Pos, WorldObj)>,
        rooms: Rooms,
        agent_pos: Pos,
        agent_dir: u8,
    ) -> impl Iterator<Item = (Pos, WorldObj)> {
        let room = rooms.room_of(agent_pos);
        objects.filter(move |&(pos, obj)| {
            if !self.matches(&obj) {
                return false;
            }
            let Some(loc) = self.loc else {
                return true;
            };
            rooms.pos_inside(room, pos) && Self::on_side(loc, pos, agent_pos, agent_dir)
        })
    }

    /// `ObjDesc.surface`: article + [colour] + type [+ location]; "the" iff exactly one
    /// object matches.
    pub fn surface(&self, n_matches: usize) -> String {
        let mut s = String::with_capacity(40);
        self.push_surface(n_matches, &mut s);
        s
    }

    /// [`Self::surface`] appended to `out` (a mission's text is built in one buffer: level
    /// generation makes one per reset, and the words' separate strings were a quarter of a
    /// two-clause level's reset).
    pub fn push_surface(&self, n_matches: usize, out: &mut String) {
        out.push_str(if n_matches > 1 { "a " } else { "the " });
        if let Some(c) = self.color {
            out.push_str(c.name());
            out.push(' ');
        }
        out.push_str(self.kind.map_or("object", ObjectKind::name));
        match self.loc {
            Some(Loc::Front) => out.push_str(" in front of you"),
            Some(Loc::Behind) => out.push_str(" behind you"),
            Some(l @ (Loc::Left | Loc::Right)) => {
                out.push_str(" on your ");
                out.push_str(l.name());
            }
            None => {}
        }
    }
}

/// A single-clause (action) instruction: what to do with which objects.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Instruction {
    /// Go to, pick up, open or put next to.
    pub task: TaskKind,
    /// The description of the object(s) acted on (PutNext: the object to move).
    pub desc: ObjDesc,
    /// PutNext's second description, the object(s) to put the first next to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fixed: Option<ObjDesc>,
    /// BabyAI's `strict` flag: picking up (or opening) a wrong object fails.
    pub strict: bool,
}

impl Instruction {
    /// A clause on one description (GoTo, Pickup, Open).
    pub fn new(task: TaskKind, desc: ObjDesc) -> Self {
        Self {
            task,
            desc,
            fixed: None,
            strict: false,
        }
    }

    /// PutNext: put an object matching `moved` next to one matching `fixed`.
    pub fn put_next(moved: ObjDesc, fixed: ObjDesc) -> Self {
        Self {
            task: TaskKind::PutNext,
            desc: moved,
            fixed: Some(fixed),
            strict: false,
        }
    }

    /// The mission text for a one-description clause, e.g. `"go to the red key"`; PutNext
    /// reads its second description as matching `n_matches` objects too (see
    /// [`Self::surface_with`]).
    pub fn surface(&self, n_matches: usize) -> String {
        self.surface_with(n_matches, n_matches)
    }

    /// The mission text with the number of objects each description matched.
    pub fn surface_with(&self, n_matches: usize, n_fixed: usize) -> String {
        let mut s = String::with_capacity(64);
        self.push_surface_with(n_matches, n_fixed, &mut s);
        s
    }

    /// [`Self::surface_with`] appended to `out`.
    pub fn push_surface_with(&self, n_matches: usize, n_fixed: usize, out: &mut String) {
        if let (TaskKind::PutNext, Some(fixed)) = (self.task, self.fixed) {
            out.push_str("put ");
            self.desc.push_surface(n_matches, out);
            out.push_str(" next to ");
            fixed.push_surface(n_fixed, out);
        } else {
            out.push_str(self.task.verb());
            out.push(' ');
            self.desc.push_surface(n_matches, out);
        }
    }

    /// Parses one BabyAI clause: `("go to" | "pick up" | "open") DESC` or `"put" DESC "next"
    /// "to" DESC`, where `DESC` is `("the" | "a") [colour] (type | "object") [location]`.
    pub fn parse(text: &str) -> Result<Self, EnvError> {
        let words = super::vocab::split_words(text);
        let w: Vec<&str> = words.iter().map(String::as_str).collect();
        Self::parse_words(&w).map_err(|e| EnvError::InvalidMission {
            mission: text.to_owned(),
            reason: e.describe(&w),
        })
    }

    /// [`Self::parse`] on words already split; an error points at the word (index in `w`).
    pub(crate) fn parse_words(w: &[&str]) -> Result<Self, ParseError> {
        const VERBS: &str = "\"go to\", \"pick up\", \"open\" or \"put\"";
        let (task, rest) = match w {
            ["go", "to", rest @ ..] => (TaskKind::GoTo, rest),
            ["pick", "up", rest @ ..] => (TaskKind::Pickup, rest),
            ["open", rest @ ..] => (TaskKind::Open, rest),
            ["put", rest @ ..] => (TaskKind::PutNext, rest),
            [] => {
                return Err(ParseError::missing(
                    0,
                    format!("a clause ({VERBS}) is missing"),
                ));
            }
            ["go", ..] => return Err(ParseError::at(1, "\"go\" must be followed by \"to\"")),
            ["pick", ..] => {
                return Err(ParseError::at(1, "\"pick\" must be followed by \"up\""));
            }
            _ => {
                return Err(ParseError::at(
                    0,
                    format!("a clause must start with {VERBS}"),
                ));
            }
        };
        let verb = w.len() - rest.len();
        if task == TaskKind::PutNext {
            let Some(at) = rest.windows(2).position(|p| p == ["next", "to"]) else {
                return Err(ParseError::at(
                    0,
                    "needs \"next to\" and the object to put it next to",
                ));
            };
            let (moved, kind_at) = parse_desc(&rest[..at]).map_err(|e| e.shift(verb))?;
            let fixed_at = verb + at + 2;
            let (fixed, _) = parse_desc(&rest[at + 2..]).map_err(|e| e.shift(fixed_at))?;
            if moved.kind == Some(ObjectKind::Door) {
                return Err(ParseError::at(
                    verb + kind_at,
                    "a door cannot be put next to anything",
                ));
            }
            return Ok(Self::put_next(moved, fixed));
        }
        let (desc, kind_at) = parse_desc(rest).map_err(|e| e.shift(verb))?;
        match (task, desc.kind) {
            (TaskKind::Pickup, Some(ObjectKind::Door)) => {
                Err(ParseError::at(verb + kind_at, "a door cannot be picked up"))
            }
            (TaskKind::Open, k) if k != Some(ObjectKind::Door) => {
                Err(ParseError::at(verb + kind_at, "only a door can be opened"))
            }
            _ => Ok(Self::new(task, desc)),
        }
    }
}

/// Where a mission stops being a BabyAI instruction: the index of the word at fault (the
/// number of words when something is missing at the end) and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct ParseError {
    /// Index of the word, among the mission's words.
    at: usize,
    /// Something is missing before word `at` (rather than word `at` being wrong).
    missing: bool,
    /// Why.
    reason: String,
}

impl ParseError {
    /// Word `at` is wrong.
    fn at(at: usize, reason: impl Into<String>) -> Self {
        Self {
            at,
            missing: false,
            reason: reason.into(),
        }
    }

    /// Something is missing before word `at`.
    fn missing(at: usize, reason: impl Into<String>) -> Self {
        Self {
            at,
            missing: true,
            reason: reason.into(),
        }
    }

    /// The same error in words that start `by` words later.
    pub(crate) fn shift(self, by: usize) -> Self {
        Self {
            at: self.at + by,
            ..self
        }
    }

    /// The reason, naming the word at fault and its position (counted from 1) among the
    /// mission's words `w`: `word 6 "please": …`, `after word 5 "and": … is missing`.
    pub(crate) fn describe(&self, w: &[&str]) -> String {
        let shown = |i: usize| super::error::shown(w[i]);
        match (w.len(), self.at < w.len()) {
            (0, _) => format!("the mission has no words: {}", self.reason),
            (_, true) if self.missing => {
                format!(
                    "before word {} {}: {}",
                    self.at + 1,
                    shown(self.at),
                    self.reason
                )
            }
            (_, true) => format!("word {} {}: {}", self.at + 1, shown(self.at), self.reason),
            (n, false) => format!("after word {n} {}, the last: {}", shown(n - 1), self.reason),
        }
    }
}

/// `("the" | "a") [colour] (type | "object") [location phrase]`, with the index of its type
/// word.
fn parse_desc(w: &[&str]) -> Result<(ObjDesc, usize), ParseError> {
    const KINDS: &str = "key, ball, box, door or \"object\"";
    const LOCS: [(&[&str], Loc); 4] = [
        (&["in", "front", "of", "you"], Loc::Front),
        (&["behind", "you"], Loc::Behind),
        (&["on", "your", "left"], Loc::Left),
        (&["on", "your", "right"], Loc::Right),
    ];
    const WHERE: &str =
        "\"in front of you\", \"behind you\", \"on your left\" or \"on your right\"";
    let rest = match w {
        ["the" | "a", rest @ ..] => rest,
        [] => {
            return Err(ParseError::missing(
                0,
                "an object (\"the\" or \"a\", then what it is) is missing",
            ));
        }
        _ => {
            return Err(ParseError::at(
                0,
                "an article (\"the\" or \"a\") must start each description",
            ));
        }
    };
    let (color, rest) = match rest {
        [c, rest @ ..] if Color::from_name(c).is_some() => (Color::from_name(c), rest),
        _ => (None, rest),
    };
    let kind_at = w.len() - rest.len();
    let (kind, rest) = match rest {
        ["object", rest @ ..] => (None, rest),
        [t, rest @ ..] => {
            match ObjectKind::from_name(t).filter(|k| k.can_pickup() || *k == ObjectKind::Door) {
                Some(k) => (Some(k), rest),
                None => return Err(ParseError::at(kind_at, format!("not {KINDS}"))),
            }
        }
        [] => {
            return Err(ParseError::missing(
                kind_at,
                format!("it names no object ({KINDS})"),
            ));
        }
    };
    let loc_at = w.len() - rest.len();
    if rest.is_empty() {
        return Ok((
            ObjDesc {
                kind,
                color,
                loc: None,
            },
            kind_at,
        ));
    }
    if let Some((_, loc)) = LOCS.iter().find(|(p, _)| *p == rest) {
        return Ok((
            ObjDesc {
                kind,
                color,
                loc: Some(*loc),
            },
            kind_at,
        ));
    }
    // The first word that no location phrase allows, or the end of an unfinished one.
    let agree = LOCS
        .iter()
        .map(|(p, _)| p.iter().zip(rest).take_while(|(a, b)| a == b).count())
        .max()
        .unwrap_or(0);
    if agree == rest.len() {
        return Err(ParseError::missing(
            loc_at + agree,
            format!("the location is unfinished ({WHERE})"),
        ));
    }
    Err(ParseError::at(
        loc_at + agree,
        format!(
            "unexpected after the object (only {WHERE} may follow it; clauses are joined by \
             \"and\", \", then\" or \"after you\")"
        ),
    ))
}

#[cfg(test)]
mod tests;

//! Level ids: a registered BabyAI level, a registered MiniGrid environment, or a MiniGrid
//! class with its arguments, as one small copyable index.

use serde::{Deserialize, Serialize};

use super::babyai::LevelSpec;
use super::error::EnvError;

/// A level of minigrid 3.2.0 by its gym id: a registered BabyAI level, a registered MiniGrid
/// environment, or a MiniGrid class with its arguments
/// (`MultiRoomEnv(minNumRooms=7, maxNumRooms=7, maxRoomSize=8)`, see
/// [`crate::env::minigrid::spelling`]). Serialised as the id (a class as its spelling).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LevelId(u16);

/// Classes spelt with their arguments, interned on first use so that a [`LevelId`] stays a
/// small copyable index (a process names a handful).
static CLASSES: std::sync::Mutex<Vec<&'static LevelSpec>> = std::sync::Mutex::new(Vec::new());

/// Most distinct class spellings one process may name (each interns a few hundred bytes).
const MAX_CLASSES: usize = 4096;

fn babyai_len() -> usize {
    super::babyai::registry::LEVELS.len()
}

fn registered_len() -> usize {
    babyai_len() + super::minigrid::registry::LEVELS.len()
}

impl LevelId {
    /// The level registered as `id`, or the MiniGrid class `id` spells; an unknown id names
    /// the closest ones of both families, a WFC id says that minigrid cannot build it.
    pub fn parse(id: &str) -> Result<Self, EnvError> {
        let registered = super::babyai::registry::LEVELS
            .iter()
            .chain(super::minigrid::registry::LEVELS)
            .position(|l| l.id == id);
        if let Some(i) = registered {
            return Ok(Self(i as u16));
        }
        let bad = |reason: String| EnvError::InvalidConfig {
            field: "level".into(),
            reason,
        };
        if super::minigrid::WFC_IDS.contains(&id) {
            return Err(bad(format!(
                "{id} is registered by minigrid 3.2.0 but minigrid itself cannot build it: its \
                 PyPI wheel ships no WFC pattern files, so there is no reference to be exact \
                 against (`groundscope env list` lists the 172 levels)"
            )));
        }
        if super::minigrid::looks_like_class(id) {
            return Self::intern(id).map_err(bad);
        }
        Err(bad(format!(
            "{} is not a level of minigrid 3.2.0 (closest: {}; `groundscope env list` lists \
             all 172: 96 BabyAI, 76 MiniGrid, or spell a MiniGrid class as \
             MultiRoomEnv(minNumRooms=7, maxNumRooms=7))",
            super::error::shown(id),
            super::babyai::closest_ids(id).join(", ")
        )))
    }

    /// The class `text` spells, interned under its canonical spelling.
    fn intern(text: &str) -> Result<Self, String> {
        let (class, max_steps) = super::minigrid::parse_class(text)?;
        let mut id = class.spelling();
        if let Some(m) = max_steps {
            id = format!("{}, max_steps={m})", id.strip_suffix(')').unwrap_or(&id));
            id = id.replacen("(, ", "(", 1);
        }
        let mut classes = CLASSES
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(i) = classes.iter().position(|s| s.id == id) {
            return Ok(Self((registered_len() + i) as u16));
        }
        if classes.len() >= MAX_CLASSES {
            return Err(format!(
                "more than {MAX_CLASSES} distinct classes named in one process"
            ));
        }
        let spec = LevelSpec {
            id: Box::leak(id.into_boxed_str()),
            rooms: class.rooms(),
            max_steps: Some(max_steps.unwrap_or_else(|| class.default_max_steps())),
            family: super::babyai::Family::MiniGrid(class),
        };
        classes.push(Box::leak(Box::new(spec)));
        Ok(Self((registered_len() + classes.len() - 1) as u16))
    }

    /// Every registered level, BabyAI's 96 then MiniGrid's 76, each in its registry's order.
    pub fn all() -> impl Iterator<Item = Self> {
        (0..registered_len()).map(|i| Self(i as u16))
    }

    /// The 96 BabyAI levels.
    pub fn babyai_all() -> impl Iterator<Item = Self> {
        (0..babyai_len()).map(|i| Self(i as u16))
    }

    /// The 76 MiniGrid environments.
    pub fn minigrid_all() -> impl Iterator<Item = Self> {
        (babyai_len()..registered_len()).map(|i| Self(i as u16))
    }

    /// The level's spec.
    pub fn spec(self) -> &'static LevelSpec {
        let i = usize::from(self.0);
        let babyai = super::babyai::registry::LEVELS;
        let minigrid = super::minigrid::registry::LEVELS;
        if i < babyai.len() {
            return &babyai[i];
        }
        if i < registered_len() {
            return &minigrid[i - babyai.len()];
        }
        let classes = CLASSES
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        // Ids are only made by `intern`, which pushed this one.
        classes
            .get(i - registered_len())
            .copied()
            .unwrap_or(&minigrid[0])
    }

    /// The MiniGrid class, for one of MiniGrid's environments; `None` for BabyAI's levels.
    pub fn minigrid(self) -> Option<super::minigrid::Class> {
        match self.spec().family {
            super::babyai::Family::MiniGrid(c) => Some(c),
            _ => None,
        }
    }

    /// The gym id (a class: its canonical spelling).
    pub fn id(self) -> &'static str {
        self.spec().id
    }
}

impl Serialize for LevelId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.id())
    }
}

impl<'de> Deserialize<'de> for LevelId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let id = String::deserialize(d)?;
        Self::parse(&id).map_err(serde::de::Error::custom)
    }
}

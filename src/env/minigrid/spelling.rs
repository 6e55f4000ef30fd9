//! The one spelling of a MiniGrid class with its keyword arguments, as Python would build it:
//! `MultiRoomEnv(minNumRooms=7, maxNumRooms=7, maxRoomSize=8)`,
//! `CrossingEnv(size=11, num_crossings=5, obstacle_type=wall)`,
//! `ObstructedMaze_Full(agent_room=(2, 1), num_quarters=2)`. Values are integers, `True` /
//! `False`, `None`, tuples of integers, and bare or quoted words; `max_steps` is accepted by
//! every class. Unknown classes, unknown arguments and values minigrid would refuse (or loop
//! forever on) are errors naming them.

use super::registry::Class;
use crate::env::error::shown;
use crate::env::grid::Pos;
use crate::env::object::ObjectKind;

/// One argument's value.
#[derive(Clone, Debug, PartialEq)]
enum Value {
    Int(i64),
    Bool(bool),
    None,
    Tuple(Vec<i64>),
    Word(String),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Int(v) => write!(f, "{v}"),
            Self::Bool(b) => f.write_str(if *b { "True" } else { "False" }),
            Self::None => f.write_str("None"),
            Self::Tuple(v) => {
                let parts: Vec<String> = v.iter().map(ToString::to_string).collect();
                write!(f, "({})", parts.join(", "))
            }
            Self::Word(w) => f.write_str(w),
        }
    }
}

/// The classes the spelling knows, with their arguments in Python's order.
const CLASSES: &[(&str, &[&str])] = &[
    ("EmptyEnv", &["size", "agent_start_pos", "agent_start_dir"]),
    ("DoorKeyEnv", &["size"]),
    ("FourRoomsEnv", &["agent_pos", "goal_pos"]),
    ("LavaGapEnv", &["size", "obstacle_type"]),
    (
        "DistShiftEnv",
        &[
            "width",
            "height",
            "agent_start_pos",
            "agent_start_dir",
            "strip2_row",
        ],
    ),
    ("CrossingEnv", &["size", "num_crossings", "obstacle_type"]),
    (
        "DynamicObstaclesEnv",
        &["size", "agent_start_pos", "agent_start_dir", "n_obstacles"],
    ),
    ("FetchEnv", &["size", "numObjs"]),
    ("GoToDoorEnv", &["size"]),
    ("GoToObjectEnv", &["size", "numObjs"]),
    ("PutNearEnv", &["size", "numObjs"]),
    ("RedBlueDoorEnv", &["size"]),
    ("LockedRoomEnv", &["size"]),
    ("MemoryEnv", &["size", "random_length"]),
    (
        "MultiRoomEnv",
        &[
            "minNumRooms",
            "maxNumRooms",
            "maxRoomSize",
            "width",
            "height",
        ],
    ),
    ("PlaygroundEnv", &[]),
    ("KeyCorridorEnv", &["num_rows", "obj_type", "room_size"]),
    ("UnlockEnv", &[]),
    ("UnlockPickupEnv", &[]),
    ("BlockedUnlockPickupEnv", &[]),
    ("ObstructedMaze_1Dlhb", &["key_in_box", "blocked"]),
    (
        "ObstructedMaze_Full",
        &[
            "agent_room",
            "key_in_box",
            "blocked",
            "num_quarters",
            "num_rooms_visited",
        ],
    ),
    (
        "ObstructedMaze_Full_V1",
        &[
            "agent_room",
            "key_in_box",
            "blocked",
            "num_quarters",
            "num_rooms_visited",
        ],
    ),
];

/// Largest grid side a class may be given (bounds the work; minigrid has no limit).
pub const MAX_SIDE: i64 = 64;

/// Whether `text` is written as a class (`Name(...)` or a known class name alone).
pub fn looks_like_class(text: &str) -> bool {
    let name = text.split('(').next().unwrap_or("").trim();
    CLASSES.iter().any(|(c, _)| *c == name) || (text.contains('(') && text.ends_with(')'))
}

/// Parses the spelling into the class and its `max_steps` (`None`: the class's default).
pub fn parse_class(text: &str) -> Result<(Class, Option<u32>), String> {
    let text = text.trim();
    let (name, args) = match text.split_once('(') {
        Some((name, rest)) => {
            let inner = rest
                .strip_suffix(')')
                .ok_or_else(|| format!("{} does not end with ')'", shown(text)))?;
            (name.trim(), split_args(inner)?)
        }
        None => (text, Vec::new()),
    };
    let Some((_, known)) = CLASSES.iter().find(|(c, _)| *c == name) else {
        let names: Vec<&str> = CLASSES.iter().map(|(c, _)| *c).collect();
        return Err(format!(
            "{} is not a MiniGrid class of minigrid 3.2.0 (classes: {})",
            shown(name),
            names.join(", ")
        ));
    };
    let mut a = Args {
        class: name,
        given: args,
    };
    for (k, _) in &a.given {
        if k != "max_steps" && !known.contains(&k.as_str()) {
            return Err(format!(
                "{name} has no argument {} (its arguments: {}, max_steps)",
                shown(k),
                known.join(", ")
            ));
        }
    }
    let max_steps = match a.take("max_steps") {
        None | Some(Value::None) => None,
        Some(v) => Some(a.count("max_steps", &v, 1, i64::from(u32::MAX))? as u32),
    };
    let class = build(name, &mut a)?;
    check(&class)?;
    Ok((class, max_steps))
}

/// The arguments given, taken one by one.
struct Args<'a> {
    class: &'a str,
    given: Vec<(String, Value)>,
}

impl Args<'_> {
    fn take(&mut self, key: &str) -> Option<Value> {
        let i = self.given.iter().position(|(k, _)| k == key)?;
        Some(self.given.remove(i).1)
    }

    fn bad(&self, key: &str, v: &Value, why: &str) -> String {
        format!("{}: {key}={v}: {why}", self.class)
    }

    fn count(&self, key: &str, v: &Value, lo: i64, hi: i64) -> Result<i64, String> {
        match v {
            Value::Int(n) if (lo..=hi).contains(n) => Ok(*n),
            Value::Int(_) => Err(self.bad(key, v, &format!("must be in {lo}..={hi}"))),
            _ => Err(self.bad(key, v, "must be an integer")),
        }
    }

    fn int(&mut self, key: &str, default: i64, lo: i64, hi: i64) -> Result<i32, String> {
        match self.take(key) {
            None => Ok(default as i32),
            Some(v) => self.count(key, &v, lo, hi).map(|n| n as i32),
        }
    }

    fn flag(&mut self, key: &str, default: bool) -> Result<bool, String> {
        match self.take(key) {
            None => Ok(default),
            Some(Value::Bool(b)) => Ok(b),
            Some(v) => Err(self.bad(key, &v, "must be True or False")),
        }
    }

    fn pair(&mut self, key: &str, default: Option<Pos>) -> Result<Option<Pos>, String> {
        match self.take(key) {
            None => Ok(default),
            Some(Value::None) => Ok(None),
            Some(Value::Tuple(t))
                if t.len() == 2 && t.iter().all(|v| (0..MAX_SIDE).contains(v)) =>
            {
                Ok(Some((t[0] as i32, t[1] as i32)))
            }
            Some(v) => Err(self.bad(key, &v, "must be None or a pair (x, y) of cells")),
        }
    }

    fn start(&mut self, default: Option<Pos>) -> Result<Option<(Pos, u8)>, String> {
        let pos = self.pair("agent_start_pos", default)?;
        let dir = self.int("agent_start_dir", 0, 0, 3)? as u8;
        Ok(pos.map(|p| (p, dir)))
    }

    fn obstacle(&mut self) -> Result<bool, String> {
        match self.take("obstacle_type") {
            None => Ok(true),
            Some(Value::Word(w)) if w.eq_ignore_ascii_case("lava") => Ok(true),
            Some(Value::Word(w)) if w.eq_ignore_ascii_case("wall") => Ok(false),
            Some(v) => Err(self.bad("obstacle_type", &v, "must be lava or wall")),
        }
    }
}

fn build(name: &str, a: &mut Args<'_>) -> Result<Class, String> {
    let side =
        |a: &mut Args<'_>, key: &str, default: i64, lo: i64| a.int(key, default, lo, MAX_SIDE);
    Ok(match name {
        "EmptyEnv" => Class::Empty {
            size: side(a, "size", 8, 3)?,
            agent_start: a.start(Some((1, 1)))?,
        },
        "DoorKeyEnv" => Class::DoorKey {
            size: side(a, "size", 8, 5)?,
        },
        "FourRoomsEnv" => Class::FourRooms {
            agent_pos: a.pair("agent_pos", None)?,
            goal_pos: a.pair("goal_pos", None)?,
        },
        "LavaGapEnv" => {
            let size = match a.take("size") {
                None => return Err("LavaGapEnv: size is required (minigrid has no default)".into()),
                Some(v) => a.count("size", &v, 5, MAX_SIDE)? as i32,
            };
            Class::LavaGap {
                size,
                lava: a.obstacle()?,
            }
        }
        "DistShiftEnv" => Class::DistShift {
            width: side(a, "width", 9, 7)?,
            height: side(a, "height", 7, 4)?,
            agent_start: a.start(Some((1, 1)))?,
            strip2_row: a.int("strip2_row", 2, 1, MAX_SIDE - 2)?,
        },
        "CrossingEnv" => Class::Crossing {
            size: side(a, "size", 9, 5)?,
            num_crossings: a.int("num_crossings", 1, 0, MAX_SIDE)? as usize,
            lava: a.obstacle()?,
        },
        "DynamicObstaclesEnv" => {
            let size = side(a, "size", 8, 4)?;
            let agent_start = a.start(Some((1, 1)))?;
            let n = a.int("n_obstacles", 4, 0, MAX_SIDE)?;
            // `n <= size / 2 + 1` (a float division in Python), else `int(size / 2)`.
            let n_obstacles = if 2 * n <= size + 2 { n } else { size / 2 };
            Class::DynamicObstacles {
                size,
                agent_start,
                n_obstacles: n_obstacles as usize,
            }
        }
        "FetchEnv" => Class::Fetch {
            size: side(a, "size", 8, 4)?,
            num_objs: a.int("numObjs", 3, 1, 64)? as usize,
        },
        "GoToDoorEnv" => Class::GoToDoor {
            size: side(a, "size", 5, 5)?,
        },
        "GoToObjectEnv" => Class::GoToObject {
            size: side(a, "size", 6, 4)?,
            num_objs: a.int("numObjs", 2, 1, 18)? as usize,
        },
        "PutNearEnv" => Class::PutNear {
            size: side(a, "size", 6, 5)?,
            num_objs: a.int("numObjs", 2, 2, 18)? as usize,
        },
        "RedBlueDoorEnv" => Class::RedBlueDoors {
            size: side(a, "size", 8, 4)?,
        },
        "LockedRoomEnv" => Class::LockedRoom {
            size: side(a, "size", 19, 13)?,
        },
        "MemoryEnv" => Class::Memory {
            size: side(a, "size", 8, 7)?,
            random_length: a.flag("random_length", false)?,
        },
        "MultiRoomEnv" => {
            let need = |a: &mut Args<'_>, key: &str| match a.take(key) {
                None => Err(format!(
                    "MultiRoomEnv: {key} is required (minigrid has no default)"
                )),
                Some(v) => a.count(key, &v, 1, 64).map(|n| n as i32),
            };
            let min_rooms = need(a, "minNumRooms")?;
            let max_rooms = need(a, "maxNumRooms")?;
            Class::MultiRoom {
                min_rooms,
                max_rooms,
                max_room_size: a.int("maxRoomSize", 10, 4, MAX_SIDE)?,
                width: side(a, "width", 25, 5)?,
                height: side(a, "height", 25, 5)?,
            }
        }
        "PlaygroundEnv" => Class::Playground,
        "KeyCorridorEnv" => {
            let num_rows = a.int("num_rows", 3, 1, 16)?;
            let obj = match a.take("obj_type") {
                None => ObjectKind::Ball,
                Some(Value::Word(w)) => match ObjectKind::from_name(&w) {
                    Some(k) if ObjectKind::PICKABLE.contains(&k) => k,
                    _ => {
                        return Err(a.bad("obj_type", &Value::Word(w), "must be key, ball or box"));
                    }
                },
                Some(v) => return Err(a.bad("obj_type", &v, "must be key, ball or box")),
            };
            Class::KeyCorridor {
                num_rows,
                obj,
                room_size: a.int("room_size", 6, 3, 16)?,
            }
        }
        "UnlockEnv" => Class::Unlock,
        "UnlockPickupEnv" => Class::UnlockPickup,
        "BlockedUnlockPickupEnv" => Class::BlockedUnlockPickup,
        "ObstructedMaze_1Dlhb" => Class::ObstructedMaze1 {
            key_in_box: a.flag("key_in_box", true)?,
            blocked: a.flag("blocked", true)?,
        },
        _ => {
            let v1 = name == "ObstructedMaze_Full_V1";
            let room = a.pair("agent_room", Some((1, 1)))?.unwrap_or((1, 1));
            if room.0 > 2 || room.1 > 2 {
                return Err(format!(
                    "{name}: agent_room={room:?}: must be a room of the 3 × 3"
                ));
            }
            Class::ObstructedMazeFull {
                v1,
                agent_room: room,
                key_in_box: a.flag("key_in_box", true)?,
                blocked: a.flag("blocked", true)?,
                num_quarters: a.int("num_quarters", 4, 1, 4)? as usize,
                num_rooms_visited: a.int("num_rooms_visited", 25, 1, 1000)?,
            }
        }
    })
}

/// What minigrid asserts (or loops forever on) for arguments the ranges above let through.
fn check(class: &Class) -> Result<(), String> {
    let name = class.class_name();
    match *class {
        Class::Crossing { size, .. } | Class::Memory { size, .. } if size % 2 == 0 => Err(format!(
            "{name}: size={size}: must be odd (minigrid asserts it)"
        )),
        Class::MultiRoom {
            min_rooms,
            max_rooms,
            ..
        } if max_rooms < min_rooms => Err(format!(
            "MultiRoomEnv: maxNumRooms={max_rooms} is below minNumRooms={min_rooms}"
        )),
        Class::Fetch { size, num_objs } | Class::GoToObject { size, num_objs }
            if num_objs as i32 > (size - 2) * (size - 2) / 2 =>
        {
            Err(format!(
                "{name}: numObjs={num_objs} do not fit a room of size {size} (at most {})",
                (size - 2) * (size - 2) / 2
            ))
        }
        Class::PutNear { size, num_objs }
            if num_objs as i32 > ((size - 1) / 2) * ((size - 1) / 2) =>
        {
            Err(format!(
                "PutNearEnv: numObjs={num_objs} objects, none beside another, do not fit a room of size {size}"
            ))
        }
        Class::DynamicObstacles {
            size, n_obstacles, ..
        } if n_obstacles as i32 > (size - 2) * (size - 2) - 2 => Err(format!(
            "DynamicObstaclesEnv: n_obstacles={n_obstacles} do not fit a room of size {size}"
        )),
        _ => Ok(()),
    }
}

/// Splits `k=v, k=v` at the commas outside parentheses.
fn split_args(inner: &str) -> Result<Vec<(String, Value)>, String> {
    let mut out = Vec::new();
    let (mut depth, mut start) = (0i32, 0usize);
    let mut parts = Vec::new();
    for (i, c) in inner.char_indices() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    for part in parts.into_iter().map(str::trim).filter(|p| !p.is_empty()) {
        let (k, v) = part
            .split_once('=')
            .ok_or_else(|| format!("{} is not keyword=value", shown(part)))?;
        let k = k.trim().to_owned();
        if out.iter().any(|(seen, _)| *seen == k) {
            return Err(format!("argument {} given twice", shown(&k)));
        }
        out.push((k, value(v.trim())?));
    }
    Ok(out)
}

fn value(v: &str) -> Result<Value, String> {
    let int = |s: &str| {
        s.trim()
            .parse::<i64>()
            .map_err(|_| format!("{} is not an integer", shown(s.trim())))
    };
    Ok(match v {
        "True" => Value::Bool(true),
        "False" => Value::Bool(false),
        "None" => Value::None,
        _ if v.starts_with('(') && v.ends_with(')') => {
            let body = &v[1..v.len() - 1];
            let items: Result<Vec<i64>, String> = body
                .split(',')
                .filter(|s| !s.trim().is_empty())
                .map(int)
                .collect();
            Value::Tuple(items?)
        }
        _ if v.starts_with(['-', '+']) || v.starts_with(|c: char| c.is_ascii_digit()) => {
            Value::Int(int(v)?)
        }
        _ => {
            let w = v.trim_matches(|c| c == '\'' || c == '"');
            if w.is_empty() || !w.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(format!("{} is not a value", shown(v)));
            }
            Value::Word(w.to_owned())
        }
    })
}

impl Class {
    /// The canonical spelling: the class and every argument, in Python's order.
    pub fn spelling(&self) -> String {
        let p =
            |p: Option<Pos>| p.map_or_else(|| "None".to_owned(), |(x, y)| format!("({x}, {y})"));
        let start = |s: Option<(Pos, u8)>| {
            format!(
                "agent_start_pos={}, agent_start_dir={}",
                p(s.map(|s| s.0)),
                s.map_or(0, |s| s.1)
            )
        };
        let b = |v: bool| if v { "True" } else { "False" };
        let obstacle = |lava: bool| if lava { "lava" } else { "wall" };
        let args = match *self {
            Class::Empty { size, agent_start } => format!("size={size}, {}", start(agent_start)),
            Class::DoorKey { size }
            | Class::GoToDoor { size }
            | Class::RedBlueDoors { size }
            | Class::LockedRoom { size } => format!("size={size}"),
            Class::FourRooms {
                agent_pos,
                goal_pos,
            } => {
                format!("agent_pos={}, goal_pos={}", p(agent_pos), p(goal_pos))
            }
            Class::LavaGap { size, lava } => {
                format!("size={size}, obstacle_type={}", obstacle(lava))
            }
            Class::DistShift {
                width,
                height,
                agent_start,
                strip2_row,
            } => format!(
                "width={width}, height={height}, {}, strip2_row={strip2_row}",
                start(agent_start)
            ),
            Class::Crossing {
                size,
                num_crossings,
                lava,
            } => format!(
                "size={size}, num_crossings={num_crossings}, obstacle_type={}",
                obstacle(lava)
            ),
            Class::DynamicObstacles {
                size,
                agent_start,
                n_obstacles,
            } => format!(
                "size={size}, {}, n_obstacles={n_obstacles}",
                start(agent_start)
            ),
            Class::Fetch { size, num_objs }
            | Class::GoToObject { size, num_objs }
            | Class::PutNear { size, num_objs } => format!("size={size}, numObjs={num_objs}"),
            Class::Memory {
                size,
                random_length,
            } => format!("size={size}, random_length={}", b(random_length)),
            Class::MultiRoom {
                min_rooms,
                max_rooms,
                max_room_size,
                width,
                height,
            } => format!(
                "minNumRooms={min_rooms}, maxNumRooms={max_rooms}, maxRoomSize={max_room_size}, width={width}, height={height}"
            ),
            Class::Playground
            | Class::Unlock
            | Class::UnlockPickup
            | Class::BlockedUnlockPickup => String::new(),
            Class::KeyCorridor {
                num_rows,
                obj,
                room_size,
            } => format!("num_rows={num_rows}, obj_type={obj}, room_size={room_size}"),
            Class::ObstructedMaze1 {
                key_in_box,
                blocked,
            } => format!("key_in_box={}, blocked={}", b(key_in_box), b(blocked)),
            Class::ObstructedMazeFull {
                agent_room,
                key_in_box,
                blocked,
                num_quarters,
                num_rooms_visited,
                ..
            } => format!(
                "agent_room={}, key_in_box={}, blocked={}, num_quarters={num_quarters}, num_rooms_visited={num_rooms_visited}",
                p(Some(agent_room)),
                b(key_in_box),
                b(blocked)
            ),
        };
        format!("{}({args})", self.class_name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registered_classes_round_trip_through_their_spelling() {
        for spec in super::super::registry::LEVELS {
            let crate::env::babyai::Family::MiniGrid(class) = spec.family else {
                panic!("{}", spec.id)
            };
            let (back, max_steps) = parse_class(&class.spelling()).unwrap();
            assert_eq!(back, class, "{}", spec.id);
            assert_eq!(max_steps, None);
        }
    }

    #[test]
    fn bad_arguments_are_named() {
        let err = |s: &str| parse_class(s).unwrap_err();
        assert!(err("MultiRoomEnv(minNumRooms=2)").contains("maxNumRooms"));
        assert!(err("MultiRoomEnv(minNumRooms=2, maxNumRooms=3, rooms=4)").contains("\"rooms\""));
        assert!(err("CrossingEnv(size=10)").contains("odd"));
        assert!(err("DoorKeyEnv(size=1000)").contains("size"));
        assert!(err("NotAnEnv(size=5)").contains("NotAnEnv"));
        assert!(err("FetchEnv(size=5, numObjs=True)").contains("numObjs"));
        let (c, m) =
            parse_class("MultiRoomEnv(minNumRooms=7, maxNumRooms=7, maxRoomSize=8, max_steps=99)")
                .unwrap();
        assert_eq!(m, Some(99));
        assert_eq!(
            c.spelling(),
            "MultiRoomEnv(minNumRooms=7, maxNumRooms=7, maxRoomSize=8, width=25, height=25)"
        );
    }
}

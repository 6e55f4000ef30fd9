//! The tile renderer's unit tests.

use super::*;

const TS: u32 = 64;

fn obj(kind: ObjectKind, color: Color) -> WorldObj {
    WorldObj::new(kind, color, 7)
}

/// The pixel at tile coordinates `(u, v)` (fractions of the tile).
fn at(img: &RgbImage, u: f64, v: f64) -> Rgb {
    let s = f64::from(img.width());
    img.get_pixel((u * s) as u32, (v * s) as u32).0
}

fn is_red(p: Rgb) -> bool {
    p[0] > 200 && p[1] < 40 && p[2] < 40
}

fn is_black(p: Rgb) -> bool {
    p.iter().all(|&c| c < 40)
}

#[test]
fn a_wall_tile_is_grey_everywhere() {
    let img = render_tile(Some(obj(ObjectKind::Wall, Color::Grey)), None, false, 32);
    assert_eq!(img.dimensions(), (32, 32));
    assert!(img.pixels().all(|p| p.0 == palette::GRID_LINE));
}

#[test]
fn an_empty_tile_is_black_with_a_one_pixel_grid_line_at_32px() {
    let img = render_tile(None, None, false, 32);
    assert_eq!(img.get_pixel(16, 0).0, palette::GRID_LINE);
    assert_eq!(img.get_pixel(0, 16).0, palette::GRID_LINE);
    assert_eq!(img.get_pixel(16, 1).0, palette::BACKGROUND);
    assert_eq!(img.get_pixel(1, 16).0, palette::BACKGROUND);
    assert_eq!(img.get_pixel(16, 16).0, palette::BACKGROUND);
}

#[test]
fn highlight_brightens_floor_to_minigrids_grey() {
    let img = render_tile(None, None, true, 32);
    assert_eq!(img.get_pixel(16, 16).0, [76, 76, 76]);
    assert_eq!(img.get_pixel(16, 0).0, [146, 146, 146]);
}

#[test]
fn a_ball_fills_the_centre_and_leaves_the_corner_black() {
    let img = render_tile(Some(obj(ObjectKind::Ball, Color::Blue)), None, false, TS);
    assert_eq!(at(&img, 0.5, 0.5), Color::Blue.rgb());
    assert_eq!(img.get_pixel(TS - 1, TS - 1).0, palette::BACKGROUND);
    // Just inside and just outside the 0.31 radius.
    assert_eq!(at(&img, 0.5 + 0.27, 0.5), Color::Blue.rgb());
    assert_eq!(at(&img, 0.5 + 0.35, 0.5), palette::BACKGROUND);
    // The rim is antialiased: some pixel is strictly between blue and black.
    assert!(img.pixels().any(|p| p.0[2] > 0 && p.0[2] < 255));
}

#[test]
fn a_box_is_an_outline_with_a_slit() {
    let img = render_tile(Some(obj(ObjectKind::Box, Color::Yellow)), None, false, TS);
    let c = Color::Yellow.rgb();
    assert_eq!(at(&img, 0.14, 0.3), c, "left side of the outline");
    assert_eq!(at(&img, 0.3, 0.3), palette::BACKGROUND, "hollow inside");
    assert_eq!(at(&img, 0.5, 0.5), c, "slit across the middle");
    assert_eq!(at(&img, 0.05, 0.5), palette::BACKGROUND, "outside the box");
}

#[test]
fn a_key_has_a_shaft_teeth_and_a_ring_with_a_hole() {
    let img = render_tile(Some(obj(ObjectKind::Key, Color::Purple)), None, false, TS);
    let c = Color::Purple.rgb();
    assert_eq!(at(&img, 0.56, 0.6), c, "shaft");
    assert_eq!(at(&img, 0.43, 0.84), c, "tooth");
    assert_eq!(
        at(&img, 0.43, 0.74),
        palette::BACKGROUND,
        "gap between teeth"
    );
    assert_eq!(
        at(&img, 0.56, 0.28),
        palette::BACKGROUND,
        "hole of the ring"
    );
    assert_eq!(at(&img, 0.56, 0.15), c, "ring");
}

#[test]
fn doors_differ_by_state() {
    let c = Color::Red.rgb();
    let mut door = obj(ObjectKind::Door, Color::Red);
    door.state = DoorState::Open;
    let open = render_tile(Some(door), None, false, TS);
    assert_eq!(at(&open, 0.5, 0.5), palette::BACKGROUND);
    assert_eq!(at(&open, 0.9, 0.5), c);
    door.state = DoorState::Closed;
    let closed = render_tile(Some(door), None, false, TS);
    assert_eq!(at(&closed, 0.5, 0.5), palette::BACKGROUND);
    assert_eq!(at(&closed, 0.75, 0.5), c, "handle");
    assert_eq!(at(&closed, 0.1, 0.5), c, "inner frame");
    door.state = DoorState::Locked;
    let locked = render_tile(Some(door), None, false, TS);
    assert_eq!(
        at(&locked, 0.3, 0.3),
        palette::scaled(c, palette::LOCKED_DOOR_SHADE)
    );
    assert_eq!(at(&locked, 0.6, 0.53), c, "key slot");
}

#[test]
fn floor_goal_and_lava_fill_the_tile() {
    let floor = render_tile(Some(obj(ObjectKind::Floor, Color::Blue)), None, false, TS);
    assert_eq!(at(&floor, 0.5, 0.5), [0, 0, 127]);
    let goal = render_tile(Some(obj(ObjectKind::Goal, Color::Green)), None, false, TS);
    assert_eq!(at(&goal, 0.5, 0.5), Color::Green.rgb());
    let lava = render_tile(Some(obj(ObjectKind::Lava, Color::Red)), None, false, TS);
    assert_eq!(at(&lava, 0.5, 0.1), palette::LAVA);
    assert!(lava.pixels().any(|p| is_black(p.0)), "lava has dark waves");
}

/// `(u, v)` given for direction 0, turned by 90° clockwise (on screen) `dir` times.
fn turn(dir: u8, (u, v): (f64, f64)) -> (f64, f64) {
    (0..dir).fold((u, v), |(u, v), _| (0.5 - (v - 0.5), 0.5 + (u - 0.5)))
}

#[test]
fn the_agent_points_its_way_in_every_direction() {
    for dir in 0..4 {
        let img = render_tile(None, Some(dir), false, TS);
        let px = |p| {
            let (u, v) = turn(dir, p);
            at(&img, u, v)
        };
        assert!(is_red(px((0.72, 0.5))), "dir {dir}: tip");
        assert!(is_black(px((0.72, 0.3))), "dir {dir}: beside the tip");
        assert!(is_red(px((0.25, 0.3))), "dir {dir}: wide base");
        assert!(is_black(px((0.06, 0.5))), "dir {dir}: behind the base");
    }
    // Quarter turns of a square tile are exact: every direction paints as many pixels.
    let red: Vec<usize> = (0..4)
        .map(|dir| {
            let img = render_tile(None, Some(dir), false, TS);
            img.pixels().filter(|p| p.0[0] > 0).count()
        })
        .collect();
    assert!(red.iter().all(|&n| n.abs_diff(red[0]) <= 2), "{red:?}");
    // Directions 1 and 3 are mirror images top to bottom.
    let down = render_tile(None, Some(1), false, TS);
    let up = render_tile(None, Some(3), false, TS);
    assert!(is_red(at(&down, 0.5, 0.72)) && is_black(at(&down, 0.5, 0.06)));
    assert!(is_red(at(&up, 0.5, 0.28)) && is_black(at(&up, 0.5, 0.94)));
}

#[test]
fn the_agent_stands_on_what_is_under_it() {
    let mut door = obj(ObjectKind::Door, Color::Green);
    door.state = DoorState::Open;
    let img = render_tile(Some(door), Some(0), false, TS);
    assert_eq!(at(&img, 0.9, 0.1), Color::Green.rgb());
    assert!(is_red(at(&img, 0.5, 0.5)));
}

#[test]
fn a_carried_object_shows_beside_the_triangle() {
    let ball = obj(ObjectKind::Ball, Color::Red);
    let img = render_agent_tile(Some(ball), 3, false, TS);
    // Ball centre in the corner frame: (0.55 + 0.45·0.5, 0.45·0.5).
    assert_eq!(at(&img, 0.775, 0.225), Color::Red.rgb());
    assert!(
        is_black(at(&img, 0.775, 0.5)),
        "the corner frame ends at 0.45"
    );
    assert!(is_red(at(&img, 0.5, 0.3)), "triangle still drawn");
    let empty = render_agent_tile(None, 3, false, TS);
    assert!(is_black(at(&empty, 0.775, 0.225)));
}

#[test]
fn degenerate_tile_sizes_do_not_panic() {
    assert_eq!(render_tile(None, Some(2), true, 0).dimensions(), (0, 0));
    let one = render_tile(Some(obj(ObjectKind::Key, Color::Red)), Some(1), false, 1);
    assert_eq!(one.dimensions(), (1, 1));
}

#[test]
fn the_cache_gives_the_tile_it_was_asked_for() {
    let mut cache = TileCache::new(16);
    let wall = Some(obj(ObjectKind::Wall, Color::Grey));
    let a = cache.get(TileKey::cell(wall, None, false)).clone();
    let b = cache.get(TileKey::cell(None, None, true)).clone();
    assert_eq!(a, render_tile(wall, None, false, 16));
    assert_eq!(b, render_tile(None, None, true, 16));
    assert_ne!(a, b);
}

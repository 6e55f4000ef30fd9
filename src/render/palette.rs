//! Every colour the renderer paints, in one place: `MiniGrid`'s palette (`COLORS` and the
//! constants its `render` methods hard-code) and the heat maps' viridis table.

use crate::env::Color;

/// An 8-bit RGB colour.
pub type Rgb = [u8; 3];

/// Empty floor and the holes shapes cut out of objects: `MiniGrid` paints them black.
pub const BACKGROUND: Rgb = [0, 0, 0];

/// The grid line on the top and left edge of every tile.
pub const GRID_LINE: Rgb = [100, 100, 100];

/// The agent's triangle.
pub const AGENT: Rgb = [255, 0, 0];

/// Lava, whatever its nominal colour (`MiniGrid` hard-codes orange).
pub const LAVA: Rgb = [255, 128, 0];

/// Cells the agent did not see, in the view render: near black, as the floor is before the
/// highlight every seen cell gets, and hatched with [`UNSEEN_HATCH`] so that they read as
/// unseen, not as floor or as the panel behind the picture.
pub const UNSEEN: Rgb = [0, 0, 0];

/// The hatching of unseen cells in the view render: a grey between the panel's background
/// (27) and a seen floor (76), on the diagonals the maps' unseen cells are hatched along.
pub const UNSEEN_HATCH: Rgb = [58, 58, 66];

/// Colour the highlight blends towards (`highlight_img`'s default).
pub const HIGHLIGHT_TOWARDS: Rgb = [255, 255, 255];

/// Weight of [`HIGHLIGHT_TOWARDS`] in a highlighted pixel.
pub const HIGHLIGHT_ALPHA: f64 = 0.30;

// The grounding marks sit on viridis heat maps, whose purple-blue-green-yellow they must not
// be mistaken for: white, orange and red lie outside that ramp.

/// Grounding mark: the map is at or above the threshold on the object's cell (`acc`).
pub const GROUNDING_HIT: Rgb = [255, 255, 255];

/// Grounding mark: the map reaches the threshold only next to the object (`acc_ng`/`acc_bs`).
pub const GROUNDING_NEAR: Rgb = [255, 140, 0];

/// Grounding mark: a miss.
pub const GROUNDING_MISS: Rgb = [255, 0, 60];

/// Outline of the mission's targets in the world picture: magenta, which is neither an
/// object colour nor on the viridis ramp of the overlay.
pub const TARGET: Rgb = [255, 0, 255];

/// The chosen action's bar and the selected word's, in the debugger and in Rerun: near white,
/// so that orange means one thing — a grounding mark "only nearby" ([`GROUNDING_NEAR`]).
pub const CHOSEN_BAR: Rgb = [235, 235, 235];

/// Every other bar of the action and word-weight charts.
pub const BAR: Rgb = [70, 130, 200];

/// The dots marking the cells the agent has already stood on.
pub const TRAIL: Rgb = [230, 230, 230];

/// A clause of the instruction already done: its targets' frames and its line in the tree.
pub const CLAUSE_DONE: Rgb = [150, 150, 150];

/// A clause the sequence has not reached yet.
pub const CLAUSE_LATER: Rgb = [90, 170, 255];

/// Shade of a locked door's panel relative to its frame.
pub const LOCKED_DOOR_SHADE: f64 = 0.45;

/// Shade of a floor tile relative to its colour.
pub const FLOOR_SHADE: f64 = 0.5;

/// Relative luminance of an sRGB colour (Rec. 709 weights on linear light), 0 to 1.
pub fn luminance(c: Rgb) -> f64 {
    let lin = |v: u8| {
        let v = f64::from(v) / 255.0;
        if v <= 0.040_45 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    };
    0.2126 * lin(c[0]) + 0.7152 * lin(c[1]) + 0.0722 * lin(c[2])
}

/// WCAG 2's contrast ratio of two colours, 1 to 21 (3 is its floor for graphics).
pub fn contrast(a: Rgb, b: Rgb) -> f64 {
    let (x, y) = (luminance(a), luminance(b));
    (x.max(y) + 0.05) / (x.min(y) + 0.05)
}

/// `MiniGrid`'s RGB of an object colour (`COLORS`).
#[inline]
pub fn object(color: Color) -> Rgb {
    color.rgb()
}

/// `c` multiplied by `factor`, truncated as numpy truncates when a float image is stored
/// into `MiniGrid`'s `uint8` canvas.
#[inline]
pub fn scaled(c: Rgb, factor: f64) -> Rgb {
    c.map(|v| (f64::from(v) * factor).clamp(0.0, 255.0) as u8)
}

/// `MiniGrid`'s `highlight_img`: `c + (255 − c)·0.3`, truncated.
#[inline]
pub fn highlight(c: Rgb) -> Rgb {
    let mut out = c;
    for (o, t) in out.iter_mut().zip(HIGHLIGHT_TOWARDS) {
        let v = f64::from(*o);
        *o = (v + HIGHLIGHT_ALPHA * (f64::from(t) - v)).clamp(0.0, 255.0) as u8;
    }
    out
}

/// Matplotlib's `viridis` (256 entries, `_cm_listed.py`), each channel `round(255·v)`.
pub const VIRIDIS: [Rgb; 256] = [
    [68, 1, 84],
    [68, 2, 86],
    [69, 4, 87],
    [69, 5, 89],
    [70, 7, 90],
    [70, 8, 92],
    [70, 10, 93],
    [70, 11, 94],
    [71, 13, 96],
    [71, 14, 97],
    [71, 16, 99],
    [71, 17, 100],
    [71, 19, 101],
    [72, 20, 103],
    [72, 22, 104],
    [72, 23, 105],
    [72, 24, 106],
    [72, 26, 108],
    [72, 27, 109],
    [72, 28, 110],
    [72, 29, 111],
    [72, 31, 112],
    [72, 32, 113],
    [72, 33, 115],
    [72, 35, 116],
    [72, 36, 117],
    [72, 37, 118],
    [72, 38, 119],
    [72, 40, 120],
    [72, 41, 121],
    [71, 42, 122],
    [71, 44, 122],
    [71, 45, 123],
    [71, 46, 124],
    [71, 47, 125],
    [70, 48, 126],
    [70, 50, 126],
    [70, 51, 127],
    [70, 52, 128],
    [69, 53, 129],
    [69, 55, 129],
    [69, 56, 130],
    [68, 57, 131],
    [68, 58, 131],
    [68, 59, 132],
    [67, 61, 132],
    [67, 62, 133],
    [66, 63, 133],
    [66, 64, 134],
    [66, 65, 134],
    [65, 66, 135],
    [65, 68, 135],
    [64, 69, 136],
    [64, 70, 136],
    [63, 71, 136],
    [63, 72, 137],
    [62, 73, 137],
    [62, 74, 137],
    [62, 76, 138],
    [61, 77, 138],
    [61, 78, 138],
    [60, 79, 138],
    [60, 80, 139],
    [59, 81, 139],
    [59, 82, 139],
    [58, 83, 139],
    [58, 84, 140],
    [57, 85, 140],
    [57, 86, 140],
    [56, 88, 140],
    [56, 89, 140],
    [55, 90, 140],
    [55, 91, 141],
    [54, 92, 141],
    [54, 93, 141],
    [53, 94, 141],
    [53, 95, 141],
    [52, 96, 141],
    [52, 97, 141],
    [51, 98, 141],
    [51, 99, 141],
    [50, 100, 142],
    [50, 101, 142],
    [49, 102, 142],
    [49, 103, 142],
    [49, 104, 142],
    [48, 105, 142],
    [48, 106, 142],
    [47, 107, 142],
    [47, 108, 142],
    [46, 109, 142],
    [46, 110, 142],
    [46, 111, 142],
    [45, 112, 142],
    [45, 113, 142],
    [44, 113, 142],
    [44, 114, 142],
    [44, 115, 142],
    [43, 116, 142],
    [43, 117, 142],
    [42, 118, 142],
    [42, 119, 142],
    [42, 120, 142],
    [41, 121, 142],
    [41, 122, 142],
    [41, 123, 142],
    [40, 124, 142],
    [40, 125, 142],
    [39, 126, 142],
    [39, 127, 142],
    [39, 128, 142],
    [38, 129, 142],
    [38, 130, 142],
    [38, 130, 142],
    [37, 131, 142],
    [37, 132, 142],
    [37, 133, 142],
    [36, 134, 142],
    [36, 135, 142],
    [35, 136, 142],
    [35, 137, 142],
    [35, 138, 141],
    [34, 139, 141],
    [34, 140, 141],
    [34, 141, 141],
    [33, 142, 141],
    [33, 143, 141],
    [33, 144, 141],
    [33, 145, 140],
    [32, 146, 140],
    [32, 146, 140],
    [32, 147, 140],
    [31, 148, 140],
    [31, 149, 139],
    [31, 150, 139],
    [31, 151, 139],
    [31, 152, 139],
    [31, 153, 138],
    [31, 154, 138],
    [30, 155, 138],
    [30, 156, 137],
    [30, 157, 137],
    [31, 158, 137],
    [31, 159, 136],
    [31, 160, 136],
    [31, 161, 136],
    [31, 161, 135],
    [31, 162, 135],
    [32, 163, 134],
    [32, 164, 134],
    [33, 165, 133],
    [33, 166, 133],
    [34, 167, 133],
    [34, 168, 132],
    [35, 169, 131],
    [36, 170, 131],
    [37, 171, 130],
    [37, 172, 130],
    [38, 173, 129],
    [39, 173, 129],
    [40, 174, 128],
    [41, 175, 127],
    [42, 176, 127],
    [44, 177, 126],
    [45, 178, 125],
    [46, 179, 124],
    [47, 180, 124],
    [49, 181, 123],
    [50, 182, 122],
    [52, 182, 121],
    [53, 183, 121],
    [55, 184, 120],
    [56, 185, 119],
    [58, 186, 118],
    [59, 187, 117],
    [61, 188, 116],
    [63, 188, 115],
    [64, 189, 114],
    [66, 190, 113],
    [68, 191, 112],
    [70, 192, 111],
    [72, 193, 110],
    [74, 193, 109],
    [76, 194, 108],
    [78, 195, 107],
    [80, 196, 106],
    [82, 197, 105],
    [84, 197, 104],
    [86, 198, 103],
    [88, 199, 101],
    [90, 200, 100],
    [92, 200, 99],
    [94, 201, 98],
    [96, 202, 96],
    [99, 203, 95],
    [101, 203, 94],
    [103, 204, 92],
    [105, 205, 91],
    [108, 205, 90],
    [110, 206, 88],
    [112, 207, 87],
    [115, 208, 86],
    [117, 208, 84],
    [119, 209, 83],
    [122, 209, 81],
    [124, 210, 80],
    [127, 211, 78],
    [129, 211, 77],
    [132, 212, 75],
    [134, 213, 73],
    [137, 213, 72],
    [139, 214, 70],
    [142, 214, 69],
    [144, 215, 67],
    [147, 215, 65],
    [149, 216, 64],
    [152, 216, 62],
    [155, 217, 60],
    [157, 217, 59],
    [160, 218, 57],
    [162, 218, 55],
    [165, 219, 54],
    [168, 219, 52],
    [170, 220, 50],
    [173, 220, 48],
    [176, 221, 47],
    [178, 221, 45],
    [181, 222, 43],
    [184, 222, 41],
    [186, 222, 40],
    [189, 223, 38],
    [192, 223, 37],
    [194, 223, 35],
    [197, 224, 33],
    [200, 224, 32],
    [202, 225, 31],
    [205, 225, 29],
    [208, 225, 28],
    [210, 226, 27],
    [213, 226, 26],
    [216, 226, 25],
    [218, 227, 25],
    [221, 227, 24],
    [223, 227, 24],
    [226, 228, 24],
    [229, 228, 25],
    [231, 228, 25],
    [234, 229, 26],
    [236, 229, 27],
    [239, 229, 28],
    [241, 229, 29],
    [244, 230, 30],
    [246, 230, 32],
    [248, 230, 33],
    [251, 231, 35],
    [253, 231, 37],
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn highlight_blends_a_third_towards_white() {
        assert_eq!(highlight(BACKGROUND), [76, 76, 76]);
        assert_eq!(highlight(GRID_LINE), [146, 146, 146]);
        assert_eq!(highlight([255, 255, 255]), [255, 255, 255]);
        assert_eq!(highlight(AGENT), [255, 76, 76]);
    }

    #[test]
    fn scaled_truncates_like_numpy() {
        assert_eq!(scaled([255, 255, 0], FLOOR_SHADE), [127, 127, 0]);
        assert_eq!(scaled([112, 39, 195], LOCKED_DOOR_SHADE), [50, 17, 87]);
    }

    #[test]
    fn viridis_table_has_the_published_anchors() {
        assert_eq!(VIRIDIS[0], [68, 1, 84]);
        assert_eq!(VIRIDIS[128], [33, 145, 140]);
        assert_eq!(VIRIDIS[255], [253, 231, 37]);
    }
}

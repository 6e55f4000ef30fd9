//! Pictures of the world, the agent's view and per-cell heat maps, in `MiniGrid`'s look.
//!
//! Tiles are drawn as `MiniGrid` 3.2's `Grid.render_tile` draws them (supersampled 3× and
//! averaged down, the same shapes, colours and grid line), so a world render matches
//! `env.get_full_render(highlight, tile_size)` pixel for pixel up to float rounding.
//!
//! Conventions:
//! - World renders are `width·tile_size` × `height·tile_size`; cell `(x, y)` starts at pixel
//!   [`px_in_image`]`((x, y), tile_size)`, `y` growing downward; directions are 0 = right,
//!   1 = down, 2 = left, 3 = up.
//! - View renders and view maps are agent-up: a [`ViewMap`] is indexed `map[vy][vx]`, row
//!   `vy` (0 = farthest ahead, 6 = the agent's row), column `vx` (0 = the agent's left); the
//!   agent stands at `(vx, vy) = (3, 6)`, bottom middle, facing up. Observations themselves
//!   stay x-major (`image[vx][vy]`), as in [`crate::env`].
//! - Nothing is cached between calls; a render reuses tiles only within itself.
//!
//! Every colour lives in [`palette`].

pub mod heatmap;
pub mod overlay;
pub mod palette;
pub mod tiles;
pub mod view;
pub mod world;

use std::path::{Path, PathBuf};

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use thiserror::Error;

pub use heatmap::{ViewMap, blend, colorbar, colorize, render_heatmap, viridis};
pub use image::RgbImage;
pub use overlay::{draw_trail, outline_targets, overlay_on_world, ring_referents};
pub use tiles::{render_agent_tile, render_tile};
pub use view::{decode_view_cell, render_view};
pub use world::{px_in_image, render_world, visible_cells};

/// Everything that can go wrong while rendering or saving; file errors name the path.
#[derive(Debug, Error)]
pub enum RenderError {
    /// Creating, writing or renaming the file failed.
    #[error("cannot write {}: {error}", path.display())]
    Io {
        /// The file being written.
        path: PathBuf,
        /// The underlying error.
        error: std::io::Error,
    },
    /// The image could not be encoded (e.g. it is 0 pixels wide).
    #[error("cannot encode {} as PNG: {error}", path.display())]
    Encode {
        /// The file being written.
        path: PathBuf,
        /// The underlying error.
        error: image::ImageError,
    },
    /// Two images that must have the same size do not.
    #[error("image sizes differ: {}×{} vs {}×{}", base.0, base.1, overlay.0, overlay.1)]
    SizeMismatch {
        /// Width and height of the image written to.
        base: (u32, u32),
        /// Width and height of the image blended in.
        overlay: (u32, u32),
    },
}

/// Writes `img` as a PNG at `path` (see [`crate::files::write_output`]): a regular file is
/// replaced atomically, so readers never see a half-written file and a failure leaves no file
/// behind; a device or FIFO is written in place; a symlink keeps pointing where it did.
pub fn save_png(img: &RgbImage, path: &Path) -> Result<(), RenderError> {
    let mut bytes = Vec::new();
    PngEncoder::new(&mut bytes)
        .write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            ExtendedColorType::Rgb8,
        )
        .map_err(|error| RenderError::Encode {
            path: path.to_path_buf(),
            error,
        })?;
    crate::files::write_output(path, &bytes).map_err(|error| RenderError::Io {
        path: path.to_path_buf(),
        error,
    })
}

/// A small known world for the module's tests.
#[cfg(test)]
pub(crate) mod fixtures {
    use crate::env::{
        Color, Grid, Instruction, ObjDesc, ObjectKind, Pos, TaskKind, World, WorldObj,
    };

    /// The agent's cell in [`world`].
    pub const AGENT: Pos = (3, 5);
    /// The agent faces up.
    pub const AGENT_DIR: u8 = 3;
    /// The red ball's cell in [`world`].
    pub const BALL: Pos = (5, 2);

    /// An 8×8 walled room, a red ball at [`BALL`], the agent at [`AGENT`] facing up.
    pub fn world() -> World {
        world_sized(8, 8)
    }

    /// A `width`×`height` walled room laid out as [`world`].
    pub fn world_sized(width: usize, height: usize) -> World {
        let mut grid = Grid::new(width, height);
        let mut next_id = 0;
        grid.wall_ring(&mut next_id);
        grid.set(
            BALL,
            Some(WorldObj::new(ObjectKind::Ball, Color::Red, next_id)),
        );
        next_id += 1;
        let instr = Instruction {
            task: TaskKind::GoTo,
            desc: ObjDesc {
                kind: Some(ObjectKind::Ball),
                color: Some(Color::Red),
                loc: None,
            },
            fixed: None,
            strict: false,
        };
        World::new(grid, AGENT, AGENT_DIR, None, instr, 64, false, next_id)
            .expect("the fixture world is valid")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn save_png_writes_a_png_that_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("world.png");
        let img = render_world(&fixtures::world(), 12, true);
        save_png(&img, &path).unwrap();
        let back = image::open(&path).unwrap().to_rgb8();
        assert_eq!(back.dimensions(), img.dimensions());
        assert_eq!(back, img);
        // Saving again replaces the file; no temporary file stays behind.
        save_png(&render_heatmap(&[[0.5; 7]; 7], 4, 0.0, 1.0), &path).unwrap();
        assert_eq!(image::open(&path).unwrap().to_rgb8().dimensions(), (28, 28));
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["world.png"]);
    }

    #[test]
    fn save_png_into_a_missing_directory_fails_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("missing").join("world.png");
        let err = save_png(&RgbImage::new(4, 4), &path).unwrap_err();
        assert!(matches!(err, RenderError::Io { .. }));
        assert!(err.to_string().contains("missing"), "{err}");
        assert!(!path.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn a_failed_encode_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.png");
        let err = save_png(&RgbImage::new(0, 0), &path).unwrap_err();
        assert!(matches!(err, RenderError::Encode { .. }), "{err}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
